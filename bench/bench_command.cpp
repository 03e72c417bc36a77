#include "bench_command.hpp"

#include "bench_util.hpp"

#include "ellipsoid_hooks.hpp"
#include "nephele/camera.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/gardner.hpp"
#include "nephele/gl.hpp"
#include "nephele/metrics.hpp"
#include "nephele/opaque.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>

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

struct Row {
    int count = 0;
    double ms = 0, baselineMs = 0, floorMs = 0, separateMs = 0;
    double otherCompositeMs = 0;  // the defaults with the other composite order (see otherCompositeName)
    double detailMs = 0;          // the defaults on the field with the detail on (kBenchDetailErosion)
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

// The composite order that is not the default: the bench times it beside the defaults.
CompositeOrder otherComposite() {
    return EllipsoidSettings().order == CompositeOrder::Weighted ? CompositeOrder::PerEllipsoid
                                                                 : CompositeOrder::Weighted;
}
const char* otherCompositeName() { return otherComposite() == CompositeOrder::Weighted ? "weighted" : "back-to-front"; }

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

std::vector<Accuracy> measureAccuracy(const EllipsoidBenchOptions& o) {
    std::vector<Accuracy> out;
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns);
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
        Scene scene = loadScene(o.bench.scenesDir + "/" + name);
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
    out.push_back(against("cumulus27.json, 8-bit atlas", loadScene(o.bench.scenesDir + "/cumulus27.json"), u8));
    const Scene probe = loadScene(o.bench.scenesDir + "/box_in_thin_cloud.json");
    EllipsoidSettings stencil;
    stencil.flyThrough = FlyThrough::Stencil;
    out.push_back(against("box_in_thin_cloud.json, fly-through: fraction", probe, {}));
    out.push_back(against("box_in_thin_cloud.json, fly-through: stencil (paper)", probe, stencil));
    std::cerr << "bench: accuracy done\n";
    return out;
}

// Every count's frame time with the defaults, the floor, the baseline, the separate pass and
// the other composite, interleaved. Throws.
std::vector<Row> timeCounts(const EllipsoidBenchOptions& o) {
    std::vector<Row> rows;
    gl::setChecks(false);  // timing: no glGetError round trips
    FrameTarget target(o.width, o.height);
    OpaquePass opaque;
    // instanced: the defaults (batched, colour matrix fused into the composite); separate: batched
    // with the paper's own colour-matrix pass; baseline: the paper's pipeline, one draw per
    // ellipsoid and the separate colour-matrix pass.
    EllipsoidSettings instancedSettings, baselineSettings, separateSettings, otherSettings;
    baselineSettings.instanced = false;
    baselineSettings.colourMatrixPass = true;
    separateSettings.colourMatrixPass = true;
    otherSettings.order = otherComposite();
    // detail: the defaults on the detailed field, a renderer of its own (the clouds' radiance grids
    // hold the detail, so one renderer for both fields would make them again every frame).
    EllipsoidRenderer instanced(instancedSettings), baseline(baselineSettings), separate(separateSettings),
        other(otherSettings), detail(instancedSettings);
    for (int count : o.counts) {
        const Scene scene = benchScene(count, o.width, o.height);
        Scene detailed = scene;
        detailed.medium.detail.erosion = kBenchDetailErosion;
        const View view = makeView(scene.camera);
        Row r;
        r.count = count;
        const std::vector<double> ms =
            timeFrames(o.frames, target, opaque, scene, view,
                       {[&] { r.stats = instanced.render(scene, view, target.framebuffer(), false); },
                        [&] { renderFloor(instanced, scene, view, target.framebuffer()); },
                        [&] { r.baselineStats = baseline.render(scene, view, target.framebuffer(), false); },
                        [&] { separate.render(scene, view, target.framebuffer(), false); },
                        [&] { other.render(scene, view, target.framebuffer(), false); },
                        [&] { detail.render(detailed, view, target.framebuffer(), false); }});
        r.ms = ms[0], r.floorMs = ms[1], r.baselineMs = ms[2], r.separateMs = ms[3], r.otherCompositeMs = ms[4];
        r.detailMs = ms[5];
        std::cerr << "bench: " << count << " ellipsoids: " << fmt("%.1f", r.ms) << " ms, floor "
                  << fmt("%.1f", r.floorMs) << " ms, baseline " << fmt("%.1f", r.baselineMs)
                  << " ms, separate colour-matrix pass " << fmt("%.1f", r.separateMs) << " ms, " << otherCompositeName()
                  << " composite " << fmt("%.1f", r.otherCompositeMs) << " ms, with the detail "
                  << fmt("%.1f", r.detailMs) << " ms\n";
        rows.push_back(r);
    }
    gl::setChecks(true);
    gl::checkAlways("bench");
    return rows;
}

std::string ellipsoidCsv(const std::vector<Row>& rows) {
    std::ostringstream csv;
    csv << "ellipsoids,visible,ms,floor_ms,baseline_ms,separate_pass_ms,ratio_to_floor,speedup_vs_baseline,draw_calls,"
           "baseline_draw_calls,passes,utilisation,tile_pixels,screen_pixels,"
        << (otherComposite() == CompositeOrder::Weighted ? "weighted_composite_ms" : "back_to_front_composite_ms")
        << ",detail_ms,detail_ratio\n";
    for (const Row& r : rows)
        csv << r.count << "," << r.stats.visible << "," << fmt("%.3f", r.ms) << "," << fmt("%.3f", r.floorMs) << ","
            << fmt("%.3f", r.baselineMs) << "," << fmt("%.3f", r.separateMs) << "," << fmt("%.3f", r.ms / r.floorMs)
            << "," << fmt("%.3f", r.baselineMs / r.ms) << "," << r.stats.drawCalls << "," << r.baselineStats.drawCalls
            << "," << r.stats.passes << "," << fmt("%.3f", r.stats.utilisation) << "," << r.stats.tilePixels << ","
            << r.stats.screenPixels << "," << fmt("%.3f", r.otherCompositeMs) << "," << fmt("%.3f", r.detailMs) << ","
            << fmt("%.3f", r.detailMs / r.ms) << "\n";
    return csv.str();
}

std::string ellipsoidMarkdown(const EllipsoidBenchOptions& o, const std::vector<Row>& rows,
                              const std::vector<Accuracy>& accuracy, const std::string& when,
                              const std::string& machine) {
    std::ostringstream md;
    md << "Measured by `nephele bench` on " << when << ", " << machine << ", at " << o.width << "x" << o.height
       << ", median of " << o.frames
       << " frames (wall time to glFinish; the sky is drawn before the clock starts; the "
          "methods take turns frame by frame). "
       << "The floor is the same tiles' unavoidable pixel work alone (each tile's pixels blended once per pass, each "
          "tile's screen rectangle composited once, one draw each per pass); the compositor (the defaults) batches "
          "each "
          "pass's tiles into one instanced draw and applies the colour matrix inside the composite; \"separate "
          "pass\" is the same with the paper's own colour-matrix copy pass (same image); the baseline is the "
          "paper's pipeline: one draw per ellipsoid (same shaders, a viewport and a draw per tile and per "
          "composite) and the separate colour-matrix pass; \""
       << otherCompositeName() << " composite\" is the defaults with the other composite order (`--composite`); "
       << "\"detail\" is the defaults on the same field with `medium.detail` on (erosion "
       << fmt("%.1f", kBenchDetailErosion) << ", the format's other defaults: octaves of 256 m down to 1 m, "
       << "faded by their projected size), \"× defaults\" its cost over the defaults' (docs/detail.md).\n\n";
    md << "| ellipsoids | ms/frame | floor ms | baseline ms | separate pass ms | " << otherCompositeName()
       << " composite ms | detail ms | × floor | separate pass × floor | detail × defaults | speed-up vs baseline "
          "| draws | baseline draws | passes | atlas use "
          "|\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Row& r : rows)
        md << "| " << r.count << " | " << fmt("%.1f", r.ms) << " | " << fmt("%.1f", r.floorMs) << " | "
           << fmt("%.1f", r.baselineMs) << " | " << fmt("%.1f", r.separateMs) << " | "
           << fmt("%.1f", r.otherCompositeMs) << " | " << fmt("%.1f", r.detailMs) << " | "
           << fmt("%.2f", r.ms / r.floorMs) << " | " << fmt("%.2f", r.separateMs / r.floorMs) << " | "
           << fmt("%.2f", r.detailMs / r.ms) << " | " << fmt("%.1f", r.baselineMs / r.ms) << " | " << r.stats.drawCalls
           << " | " << r.baselineStats.drawCalls << " | " << r.stats.passes << " | "
           << fmt("%.0f%%", 100 * r.stats.utilisation) << " |\n";
    md << "\n![ms per frame against ellipsoid count](ellipsoid_bench.png)\n";
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
    return md.str();
}

}  // namespace

int runBench(const EllipsoidBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    std::vector<Row> rows;
    std::vector<Accuracy> accuracy;
    std::string renderer;
    try {
        ContextOptions co;
        co.backend = o.bench.backend;
        auto context = Context::create(co);
        renderer = context->description();
        rows = timeCounts(o);
        if (o.accuracy) accuracy = measureAccuracy(o);
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench failed: " << e.what() << "\n";
        return 1;
    }
    const std::string when = utcNow();
    const std::string md = ellipsoidMarkdown(o, rows, accuracy, when, machineLine(renderer));
    return publishChartBench(o.bench.outDir, "ellipsoid bench", "ellipsoid_bench", ellipsoidCsv(rows), md,
                             "plot_bench.py", when);
}

}  // namespace nephele::cli
