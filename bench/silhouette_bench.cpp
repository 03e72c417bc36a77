// `bench --silhouette`: the box-counting dimension of the alpha > 0.5 silhouette (metrics.hpp,
// boxes 2-32 px) of cumulus27 and dense_cumulus with and without the detail field, from 100 m,
// 1 km and 5 km, for the fast methods (issue 34: at least 1.25; cloud perimeters about 1.35).
#include "bench_command.hpp"
#include "bench_util.hpp"
#include "render_command.hpp"

#include "nephele/ellipsoid_space.hpp"
#include "nephele/metrics.hpp"

#include <cstdio>
#include <sstream>

namespace nephele::cli {
namespace {

// Whether x lies inside one of the scene's ellipsoids.
bool inMatter(const Scene& s, const Vec3& x) {
    for (const Cloud& c : s.clouds)
        for (const Ellipsoid& e : c.ellipsoids) {
            const Vec3 u = ellipsoidToUnit(e) * (x - e.center);
            if (glm::dot(u, u) < 1) return true;
        }
    return false;
}

// The scene seen along its camera's line to the mean of its first cloud's centres, the eye
// `distance` m before the first matter on that line (found in 1 m steps).
Scene atDistance(Scene s, double distance) {
    Vec3 centre(0.0);
    for (const Ellipsoid& e : s.clouds.at(0).ellipsoids) centre += e.center;
    centre /= double(s.clouds[0].ellipsoids.size());
    const Vec3 dir = glm::normalize(centre - s.camera.position);
    Vec3 front = s.camera.position;
    for (double t = 0; t < glm::length(centre - s.camera.position); t += 1.0)
        if (inMatter(s, s.camera.position + t * dir)) {
            front = s.camera.position + t * dir;
            break;
        }
    s.camera.position = front - distance * dir;
    s.camera.direction = dir;
    s.path.clear();
    return s;
}

}  // namespace

int runSilhouetteBench(const SilhouetteBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    const std::vector<std::string> names = o.bench.quick
                                               ? std::vector<std::string>{"dense_cumulus.json"}
                                               : std::vector<std::string>{"cumulus27.json", "dense_cumulus.json"};
    const std::vector<double> distances =
        o.bench.quick ? std::vector<double>{1000} : std::vector<double>{100, 1000, 5000};
    std::ostringstream csv, md;
    csv << "scene,distance_m,method,erosion,dimension\n";
    md << "Box-counting dimension of the α > 0.5 silhouette (boxes 2–32 px) at " << o.width << " px wide; "
       << "detail: `medium.detail` kind nephele, erosion " << o.erosion << " (off: erosion 0). "
       << "A smooth outline measures about 1.0, cloud perimeters about 1.35 (Lovejoy 1982).\n\n"
       << "| scene | distance | method | detail off | detail on |\n|---|---|---|---|---|\n";
    try {
        for (const std::string& name : names) {
            Scene base = loadScene(o.bench.scenesDir + "/" + name);
            const double aspect = double(base.camera.width) / base.camera.height;
            base.camera.width = o.width;
            base.camera.height = std::max(1, int(std::lround(o.width / aspect)));
            for (double d : distances)
                for (Method m : {Method::Ellipsoid, Method::Raymarch}) {
                    double dim[2];
                    for (int on = 0; on < 2; ++on) {
                        Scene s = atDistance(base, d);
                        s.medium.detail.erosion = on ? o.erosion : 0.0;
                        RenderOptions r;
                        r.method = m;
                        r.backend = o.bench.backend;
                        // The opacity alone is measured: small grids, made in a fraction of the
                        // time of real cumulus's 64^3 (the light does not move the silhouette).
                        r.ellipsoid.light.size = r.raymarch.light.size = 16;
                        r.ellipsoid.light.sunPhotons = r.ellipsoid.light.skyPhotons = 1 << 14;
                        r.raymarch.light = r.ellipsoid.light;
                        dim[on] = silhouetteDimension(renderFrame(s, r).alpha);
                        csv << name << "," << d << "," << methodName(m) << "," << s.medium.detail.erosion << ","
                            << fmt("%.3f", dim[on]) << "\n";
                    }
                    md << "| " << name << " | " << d << " m | " << methodName(m) << " | " << fmt("%.3f", dim[0])
                       << " | " << fmt("%.3f", dim[1]) << " |\n";
                }
        }
    } catch (const std::exception& e) {
        return reportError(e, "the silhouette bench");
    }
    return publishTextBench("bench --silhouette", o.bench.outDir, "silhouette bench", "silhouette_bench", csv.str(),
                            md.str());
}

}  // namespace nephele::cli
