// `nephele bench --queries`: what the host's cloud queries cost (issue #35 §4: "each costs
// microseconds"). Per scene, after SkyRenderer::prepare and an update at the camera (its near
// LOD made, its background work done): densityAt, transmittance over 1 km and 10 km from points
// that hold matter around the eye, and insideCloud at points inside a cloud, in microseconds per call (median
// of five passes, one thread), beside the floor of the same points: the path tracer's own
// extinction field (ExtinctionField) of the explicit clouds, the least a point query can cost.
#include "bench_command.hpp"
#include "bench_util.hpp"

#include "render_command.hpp"

#include "nephele/gl.hpp"
#include "nephele/pathtrace.hpp"
#include "nephele/sky.hpp"

#include <chrono>
#include <random>
#include <sstream>
#include <stdexcept>

namespace nephele::cli {
namespace {

// Microseconds per call of f over the points: the median of five passes.
template <class F>
double microseconds(const std::vector<Vec3>& points, F&& f) {
    std::vector<double> passes;
    volatile double sink = 0;
    for (int pass = 0; pass < 5; ++pass) {
        const auto t0 = std::chrono::steady_clock::now();
        double sum = 0;
        for (std::size_t i = 0; i < points.size(); ++i) sum += f(points[i], i);
        passes.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() /
                         double(points.size()));
        sink = sink + sum;
    }
    return median(passes);
}

// Points within `radius` m of the eye horizontally, between the lowest and highest matter: the
// explicit clouds' boxes and the layers' slabs.
std::vector<Vec3> pointsAround(const Scene& s, const Vec3& eye, double radius, int n) {
    double lo = 1e300, hi = -1e300;
    for (const Cloud& c : s.clouds)
        for (const Ellipsoid& e : c.ellipsoids) {
            const double r = std::max({e.radii.x, e.radii.y, e.radii.z});
            lo = std::min(lo, e.center.z - r), hi = std::max(hi, e.center.z + r);
        }
    for (const Layer& l : s.layers) lo = std::min(lo, l.base), hi = std::max(hi, l.base + l.thickness);
    if (!(hi > lo)) lo = eye.z - 100, hi = eye.z + 100;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1), z(lo, hi);
    std::vector<Vec3> out;
    while (int(out.size()) < n) {
        const double hx = u(rng), hy = u(rng);  // one by one: a call's arguments come in the compiler's order
        const Vec2 h(hx, hy);
        if (glm::length(h) <= 1) out.push_back(Vec3(eye.x + radius * h.x, eye.y + radius * h.y, z(rng)));
    }
    return out;
}

}  // namespace

int runQueryBench(const QueryBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    std::ostringstream csv, md;
    std::string renderer;
    csv << "scene,ellipsoids,near_clouds,layers,density_us,transmittance_1km_us,transmittance_10km_us,inside_us,"
           "mean_depth_m,floor_us\n";
    md << "| scene | explicit ellipsoids | near clouds | layers | densityAt | transmittance 1 km | transmittance 10 km "
          "| "
          "insideCloud (mean depth) | floor: the path tracer's field |\n|---|---|---|---|---|---|---|---|---|\n";
    try {
        ContextOptions co;
        co.backend = o.bench.backend;
        auto context = Context::create(co);
        renderer = context->description();
        for (const std::string& name : o.scenes) {
            Scene scene = loadScene(o.bench.scenesDir + "/" + name);
            scene.camera.width = scene.camera.height = 64;  // the draws are not what is measured
            SkyRenderer sky;
            sky.prepare(scene);
            const Vec3 eye = scene.camera.position;
            const Weather weather = Weather::of(scene);
            sky.update(0, weather, eye);
            sky.waitForBackgroundWork();
            const SkyUpdateStats stats = sky.update(0, weather, eye);
            // The points that hold matter (where a query does its work), and of them those inside a cloud.
            std::vector<Vec3> points, inside;
            for (const Vec3& p : pointsAround(scene, eye, o.radius, 200 * o.points)) {
                if (int(points.size()) < o.points && sky.densityAt(p) > 0) points.push_back(p);
                if (int(inside.size()) < o.points && sky.insideCloud(p).inside) inside.push_back(p);
                if (int(points.size()) == o.points && int(inside.size()) == o.points) break;
            }
            if (points.empty() || inside.empty()) throw std::runtime_error(name + ": no matter found near the camera");
            std::vector<Vec3> dirs;
            std::mt19937 rng(9);
            std::normal_distribution<double> g;
            for (int i = 0; i < o.points; ++i) {
                const double x = g(rng), y = g(rng), z = g(rng);  // one by one, as above
                dirs.push_back(glm::normalize(Vec3(x, y, 0.3 * z)));
            }
            const NoiseVolume noise = makeNoiseVolume(NoiseSettings{});
            const ExtinctionField field(scene, &noise, nullptr, eye);
            const double density = microseconds(points, [&](const Vec3& p, std::size_t) { return sky.densityAt(p); });
            const double t1 =
                microseconds(points, [&](const Vec3& p, std::size_t i) { return sky.transmittance(p, dirs[i], 1000); });
            const double t10 = microseconds(
                points, [&](const Vec3& p, std::size_t i) { return sky.transmittance(p, dirs[i], 10000); });
            const double in =
                microseconds(inside, [&](const Vec3& p, std::size_t) { return sky.insideCloud(p).depth; });
            double depth = 0;
            for (const Vec3& p : inside) depth += sky.insideCloud(p).depth / double(inside.size());
            const double floor = microseconds(points, [&](const Vec3& p, std::size_t) { return field(p); });
            int ellipsoids = 0;
            for (const Cloud& c : scene.clouds) ellipsoids += int(c.ellipsoids.size());
            csv << name << "," << ellipsoids << "," << stats.nearLod.clouds << "," << scene.layers.size() << ","
                << fmt("%.3f", density) << "," << fmt("%.2f", t1) << "," << fmt("%.2f", t10) << "," << fmt("%.2f", in)
                << "," << fmt("%.1f", depth) << "," << fmt("%.3f", floor) << "\n";
            md << "| " << name << " | " << ellipsoids << " | " << stats.nearLod.clouds << " | " << scene.layers.size()
               << " | " << fmt("%.2f", density) << " µs | " << fmt("%.1f", t1) << " µs | " << fmt("%.1f", t10)
               << " µs | " << fmt("%.1f", in) << " µs (" << fmt("%.0f", depth) << " m) | " << fmt("%.2f", floor)
               << " µs |\n";
        }
    } catch (const std::exception& e) {
        return reportError(e, "the query bench");
    }
    std::ostringstream page;
    page
        << "Measured by `nephele bench --queries` on " << utcNow() << ", " << machineLine(renderer)
        << ". Per call, one "
        << "thread, median of five passes over " << o.points << " points that hold matter (insideCloud: " << o.points
        << " points inside a cloud), drawn within " << fmt("%.0f", o.radius)
        << " m of the camera (horizontally) between the lowest and the highest matter, after `prepare`, an `update` at "
           "the camera and its background work; rays from the points in random directions, mostly horizontal. The "
           "floor is the path tracer's extinction field of the explicit clouds at the same points.\n\n"
        << md.str();
    return publishTextBench("bench --queries", o.bench.outDir, "query bench", "query_bench", csv.str(), page.str());
}

}  // namespace nephele::cli
