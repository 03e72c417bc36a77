#include "bench_command.hpp"

#include "output_files.hpp"

#include "nephele/camera.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/gardner.hpp"
#include "nephele/gl.hpp"
#include "nephele/metrics.hpp"
#include "nephele/opaque.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <random>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

// Uniform in [0, 1) from raw mt19937 output (identical on every standard library).
struct Random {
    std::mt19937 engine;
    explicit Random(unsigned seed) : engine(seed) {}
    double operator()() { return double(engine() >> 5) * 0x1.0p-27; }
    double range(double lo, double hi) { return lo + (hi - lo) * (*this)(); }
};

std::string firstLineOf(const std::string& file, const std::string& key) {
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);)
        if (line.rfind(key, 0) == 0) {
            const auto colon = line.find(':');
            return colon == std::string::npos ? line : line.substr(colon + 2);
        }
    return "unknown";
}

std::string utcNow() {
    const std::time_t t = std::time(nullptr);
    char buf[64];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
    return buf;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

using Clock = std::chrono::steady_clock;

struct Row {
    int count = 0;
    double ms = 0, baselineMs = 0, floorMs = 0, fusedMs = 0;
    EllipsoidStats stats, baselineStats;
};

}  // namespace

Scene benchScene(int count, int width, int height) {
    Scene s;
    s.file = "bench";
    s.camera.position = {0, 0, 1500};
    s.camera.direction = {0, 1, 0};
    s.camera.fovYDeg = 60;
    s.camera.width = width;
    s.camera.height = height;
    const View view = makeView(s.camera);
    Random rnd(20261122);
    const int clouds = (count + 15) / 16;
    for (int c = 0, made = 0; c < clouds; ++c) {
        Cloud cloud;
        cloud.name = "bench" + std::to_string(c);
        const double dist = rnd.range(3000, 9000);
        const Vec3 centre = s.camera.position + dist * view.forward +
                            rnd.range(-0.8, 0.8) * dist * view.tanHalfX * view.right +
                            rnd.range(-0.3, 0.6) * dist * view.tanHalfY * view.up;
        const int n = std::min(16, count - made);
        for (int i = 0; i < n; ++i, ++made) {
            Ellipsoid e;
            e.center = centre + Vec3(rnd.range(-450, 450), rnd.range(-450, 450), rnd.range(-120, 220));
            const double r = rnd.range(120, 300);
            e.radii = {r * rnd.range(0.9, 1.2), r * rnd.range(0.9, 1.2), r * rnd.range(0.6, 0.8)};
            e.rotationDeg = {0, 0, rnd.range(0, 180)};
            cloud.ellipsoids.push_back(e);
        }
        s.clouds.push_back(cloud);
    }
    return s;
}

namespace {

// Median wall times of `frames` frames per method (after two warm-up rounds), each finished
// with glFinish. The methods take turns frame by frame, so that a busy machine slows them
// alike and their ratios hold.
std::vector<double> timeFrames(int frames, FrameTarget& target, const OpaquePass& opaque, const Scene& scene,
                               const View& view, const std::vector<std::function<void()>>& methods) {
    std::vector<std::vector<double>> ms(methods.size());
    for (int i = 0; i < frames + 2; ++i)
        for (std::size_t m = 0; m < methods.size(); ++m) {
            opaque.draw(scene, view, target.framebuffer());
            gl::glFinish();
            const auto t0 = Clock::now();
            methods[m]();
            gl::glFinish();
            const double elapsed = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
            if (i >= 2) ms[m].push_back(elapsed);
        }
    std::vector<double> out;
    for (auto& v : ms) out.push_back(median(v));
    return out;
}

struct Accuracy {
    std::string what;
    double psnr = 0, iou = -1, mae = -1;
};

Image gpuFrame(const Scene& scene, const EllipsoidSettings& settings) {
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    EllipsoidRenderer(settings).render(scene, view, target.framebuffer(), !scene.objects.empty());
    Image img = target.readColor();
    for (float& v : img.pixels) v = std::clamp(v, 0.0f, 1.0f);
    return img;
}

std::vector<Accuracy> measureAccuracy(const BenchOptions& o) {
    std::vector<Accuracy> out;
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns.size, ns.cells, ns.octaves, ns.seed);
    auto exactFrame = [&](const Scene& scene) {
        Image img = renderGardnerExact(scene, makeView(scene.camera), noise, ns);
        for (float& v : img.pixels) v = std::clamp(v, 0.0f, 1.0f);
        return img;
    };
    auto against = [&](const std::string& what, const Scene& scene, const EllipsoidSettings& settings) {
        Accuracy a;
        a.what = what;
        a.psnr = psnr(channels(gpuFrame(scene, settings), 0, 3), channels(exactFrame(scene), 0, 3));
        return a;
    };
    for (const char* name : {"single.json", "two_clouds.json", "cumulus27.json", "flythrough.json", "example.json"}) {
        Scene scene = loadScene(o.scenesDir + "/" + name);
        Accuracy a = against(name, scene, {});
        if (scene.objects.empty()) {
            scene.medium.noise = 0;
            const Image gpu = gpuFrame(scene, {});
            const Image alpha = channels(gpu, 3, 1);
            const Image physics = exactDensityOpacity(scene, makeView(scene.camera));
            const RenderComparison c = compareRenders(channels(gpu, 0, 3), channels(gpu, 0, 3), &alpha, &physics);
            a.iou = c.alphaIou;
            a.mae = c.alphaMae;
        }
        out.push_back(a);
    }
    EllipsoidSettings u8;
    u8.precision = AtlasPrecision::Unorm8;
    out.push_back(against("cumulus27.json, 8-bit atlas", loadScene(o.scenesDir + "/cumulus27.json"), u8));
    const Scene probe = loadScene(o.scenesDir + "/box_in_thin_cloud.json");
    EllipsoidSettings stencil;
    stencil.flyThrough = FlyThrough::Stencil;
    out.push_back(against("box_in_thin_cloud.json, fly-through: fraction", probe, {}));
    out.push_back(against("box_in_thin_cloud.json, fly-through: stencil (paper)", probe, stencil));
    std::cerr << "bench: accuracy done\n";
    return out;
}

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

}  // namespace

int runBench(const BenchOptions& o) {
    std::error_code ec;
    fs::create_directories(o.outDir, ec);
    if (!fs::is_directory(o.outDir)) {
        std::cerr << "nephele: bench: cannot create the output folder '" << o.outDir << "'\n";
        return 2;
    }
    if (!o.readme.empty() && !fs::is_regular_file(o.readme)) {
        std::cerr << "nephele: bench: --readme '" << o.readme << "' is not a file\n";
        return 2;
    }
    std::vector<Row> rows;
    std::vector<Accuracy> accuracy;
    std::string renderer;
    try {
        ContextOptions co;
        co.backend = o.backend;
        auto context = Context::create(co);
        renderer = context->description();
        gl::setChecks(false);  // timing: no glGetError round trips
        FrameTarget target(o.width, o.height);
        OpaquePass opaque;
        EllipsoidSettings instancedSettings, baselineSettings, fusedSettings;
        baselineSettings.instanced = false;
        fusedSettings.colourMatrixPass = false;
        EllipsoidRenderer instanced(instancedSettings), baseline(baselineSettings), fused(fusedSettings);
        for (int count : o.counts) {
            const Scene scene = benchScene(count, o.width, o.height);
            const View view = makeView(scene.camera);
            Row r;
            r.count = count;
            const std::vector<double> ms = timeFrames(
                o.frames, target, opaque, scene, view,
                {[&] { r.stats = instanced.render(scene, view, target.framebuffer(), false); },
                 [&] { instanced.renderFloor(scene, view, target.framebuffer()); },
                 [&] { r.baselineStats = baseline.render(scene, view, target.framebuffer(), false); },
                 [&] { fused.render(scene, view, target.framebuffer(), false); }});
            r.ms = ms[0], r.floorMs = ms[1], r.baselineMs = ms[2], r.fusedMs = ms[3];
            std::cerr << "bench: " << count << " ellipsoids: " << fmt("%.1f", r.ms) << " ms, floor "
                      << fmt("%.1f", r.floorMs) << " ms, baseline " << fmt("%.1f", r.baselineMs) << " ms, fused "
                      << fmt("%.1f", r.fusedMs) << " ms\n";
            rows.push_back(r);
        }
        gl::setChecks(true);
        gl::checkAlways("bench");
        if (o.accuracy) accuracy = measureAccuracy(o);
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench failed: " << e.what() << "\n";
        return 1;
    }

    const std::string when = utcNow();
    const std::string cpu = firstLineOf("/proc/cpuinfo", "model name");
    const std::string machine = cpu + ", " + std::to_string(std::thread::hardware_concurrency()) + " cores; " + renderer;

    std::ostringstream csv;
    csv << "ellipsoids,visible,ms,floor_ms,baseline_ms,fused_ms,ratio_to_floor,speedup_vs_baseline,draw_calls,"
           "baseline_draw_calls,passes,utilisation,tile_pixels,screen_pixels\n";
    for (const Row& r : rows)
        csv << r.count << "," << r.stats.visible << "," << fmt("%.3f", r.ms) << "," << fmt("%.3f", r.floorMs) << ","
            << fmt("%.3f", r.baselineMs) << "," << fmt("%.3f", r.fusedMs) << "," << fmt("%.3f", r.ms / r.floorMs) << "," << fmt("%.3f", r.baselineMs / r.ms)
            << "," << r.stats.drawCalls << "," << r.baselineStats.drawCalls << "," << r.stats.passes << ","
            << fmt("%.3f", r.stats.utilisation) << "," << r.stats.tilePixels << "," << r.stats.screenPixels << "\n";

    std::ostringstream md;
    md << "Measured by `nephele bench` on " << when << ", " << machine << ", at " << o.width << "x" << o.height
       << ", median of " << o.frames << " frames (wall time to glFinish; the sky is drawn before the clock starts; the "
          "methods take turns frame by frame). "
       << "The floor is the same tiles' unavoidable pixel work alone (each tile's pixels blended once per pass, each "
          "tile's screen rectangle composited once, one draw each per pass); the baseline is the paper's one draw per "
          "ellipsoid (same shaders, a viewport and a draw per tile and per composite); fused applies the colour "
          "matrix in the composite instead of its own pass (same image).\n\n";
    md << "| ellipsoids | ms/frame | floor ms | baseline ms | fused ms | × floor | fused × floor | speed-up vs baseline "
          "| draws | baseline draws | passes | atlas use |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Row& r : rows)
        md << "| " << r.count << " | " << fmt("%.1f", r.ms) << " | " << fmt("%.1f", r.floorMs) << " | "
           << fmt("%.1f", r.baselineMs) << " | " << fmt("%.1f", r.fusedMs) << " | " << fmt("%.2f", r.ms / r.floorMs)
           << " | " << fmt("%.2f", r.fusedMs / r.floorMs) << " | "
           << fmt("%.1f", r.baselineMs / r.ms) << " | " << r.stats.drawCalls << " | " << r.baselineStats.drawCalls
           << " | " << r.stats.passes << " | " << fmt("%.0f%%", 100 * r.stats.utilisation) << " |\n";
    md << "\n![ms per frame against ellipsoid count](docs/ellipsoid_bench.png)\n";
    if (!accuracy.empty()) {
        md << "\nAccuracy on the shared scenes at their own size, same run: the GPU compositor against "
              "`--method gardner-exact` (PSNR of linear RGB clamped to [0, 1]), and for scenes without objects, with "
              "`medium.noise: 0`, its opacity (`--alpha`) against the exact opacity of the format's density field.\n\n"
              "| scene, setting | GPU vs exact PSNR | opacity IoU(α>0.5) | opacity MAE |\n|---|---:|---:|---:|\n";
        for (const Accuracy& a : accuracy)
            md << "| " << a.what << " | " << fmt("%.1f dB", a.psnr) << " | "
               << (a.iou < 0 ? std::string("—") : fmt("%.3f", a.iou)) << " | "
               << (a.mae < 0 ? std::string("—") : fmt("%.4f", a.mae)) << " |\n";
    }

    const std::string csvPath = (fs::path(o.outDir) / "ellipsoid_bench.csv").string();
    const std::string mdPath = (fs::path(o.outDir) / "ellipsoid_bench.md").string();
    const std::string pngPath = (fs::path(o.outDir) / "ellipsoid_bench.png").string();
    try {
        OutputFiles files;
        files.add(csvPath, [&](const std::string& p) { std::ofstream(p) << csv.str(); });
        files.add(mdPath, [&](const std::string& p) { std::ofstream(p) << md.str(); });
        files.commit();
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench: writing the results failed: " << e.what() << "\n";
        return 1;
    }
    // The chart: Debian's matplotlib, through /usr/bin/python3.
    const std::string script = std::string(NEPHELE_SOURCE_DIR) + "/demo/plot_bench.py";
    const std::string cmd = "/usr/bin/python3 '" + script + "' '" + csvPath + "' '" + pngPath + "' '" + when + "'";
    if (std::system(cmd.c_str()) != 0) {
        std::cerr << "nephele: bench: the chart failed (needs /usr/bin/python3 with python3-matplotlib; ./setup.sh "
                     "installs it)\n";
        return 1;
    }
    if (!o.readme.empty()) {
        std::ifstream in(o.readme);
        std::stringstream text;
        text << in.rdbuf();
        std::string readme = text.str();
        const std::string begin = "<!-- BEGIN GENERATED: ellipsoid bench -->", end = "<!-- END GENERATED: ellipsoid bench -->";
        const auto b = readme.find(begin), e = readme.find(end);
        if (b == std::string::npos || e == std::string::npos || e < b) {
            std::cerr << "nephele: bench: " << o.readme << " has no '" << begin << "' ... '" << end << "' section\n";
            return 1;
        }
        readme = readme.substr(0, b + begin.size()) + "\n" + md.str() + readme.substr(e);
        OutputFiles files;
        files.add(o.readme, [&](const std::string& p) { std::ofstream(p) << readme; });
        files.commit();
    }
    std::cout << md.str();
    std::cerr << "nephele: bench wrote " << csvPath << ", " << mdPath << ", " << pngPath
              << (o.readme.empty() ? "" : ", " + o.readme) << "\n";
    return 0;
}

}  // namespace nephele::cli
