// `nephele bench --layered`: the layered far field (Wang, Ji & Zhang 2011) against its floor,
// over the layer's extent and the annulus count N, in one run: ms per frame, draw calls,
// instances, the floor (the same instances' fragments as plain textured meshes, blended
// once: LayeredRenderer::renderFloor) and the ratio to it, the cloud-shadow pass's share,
// and the renderer before the speed work of this bench (full resolution, LayeredSettings::downsample = 1) on the
// same frames, for the speed-up.
#include "bench_command.hpp"

#include "bench_util.hpp"

#include "layered_hooks.hpp"
#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/layered.hpp"
#include "nephele/sky.hpp"
#include "nephele/near_lod.hpp"
#include "nephele/opaque.hpp"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

struct Row {
    double extent = 0;  // m
    int layers = 0;     // N
    double ms = 0, floorMs = 0, noShadowMs = 0, beforeMs = 0;
    LayeredStats stats, floorStats;
};

// The near_and_far.json view of its far-field layer (eye 900 m up, looking 7 degrees up at a
// layer at 2500-3100 m, ground below the horizon) with the layer's extent set.
Scene layeredBenchScene(double extent, int width, int height) {
    Scene s;
    s.file = "layered bench";
    s.camera.position = {0, -4000, 900};
    s.camera.direction = glm::normalize(Vec3(0, 4000, 500));
    s.camera.fovYDeg = 60;
    s.camera.width = width;
    s.camera.height = height;
    Layer l;
    l.base = 2500, l.thickness = 600, l.coverage = 0.6, l.density = 0.8;
    l.wind = Vec2(6, 2);
    l.extent = extent;
    s.layers.push_back(l);
    return s;
}

// `--method auto` on near_and_far.json (its explicit cumulus, the layer's near LOD within
// kAutoNearRadius + kAutoBlendBand as ellipsoids, the layer beyond), as apps/nephele/render_command.cpp
// draws it: the far field (the layered sky), the near field (the near LOD's update and the
// compositor with the near and explicit clouds), the whole frame, and the far field's floor.
struct AutoSplit {
    double ms = 0, farMs = 0, nearMs = 0, floorMs = 0;
    int nearClouds = 0;
};
AutoSplit timeAutoNearAndFar(const LayeredBenchOptions& o, FrameTarget& target, const OpaquePass& opaque, int frames) {
    Scene scene = loadScene(o.bench.scenesDir + "/near_and_far.json");
    scene.camera.width = o.width, scene.camera.height = o.height;
    const View view = makeView(scene.camera);
    // auto's settings (nephele/sky.hpp): the hand-off radii, the billboard disc beyond the
    // band, tiles that last.
    LayeredSettings ls = autoLayeredSettings();
    ls.cacheDir = o.bench.cacheDir;
    if (o.bench.quick) useQuickLighting(ls.lighting);
    LayeredRenderer far(ls);
    NearLod nearLod(NearLodSettings{}, ls);
    EllipsoidRenderer near(autoEllipsoidSettings());
    const bool objects = !scene.objects.empty();
    const double t = 0;
    AutoSplit a;
    auto drawNear = [&] {
        const std::vector<Cloud> clouds = nearLod.update(scene, view.eye, t);
        a.nearClouds = int(clouds.size());
        near.render(withNearClouds(scene, clouds), view, target.framebuffer(), objects);
    };
    const std::vector<double> ms = timeFrames(frames, target, opaque, scene, view,
                                              {[&] {
                                                   far.render(scene, view, target.framebuffer(), t);
                                                   drawNear();
                                               },
                                               [&] { far.render(scene, view, target.framebuffer(), t); }, drawNear,
                                               [&] { renderFloor(far, scene, view, target.framebuffer(), t); }});
    a.ms = ms[0], a.farMs = ms[1], a.nearMs = ms[2], a.floorMs = ms[3];
    return a;
}

// Prints what is wrong with --extents or --layer-counts and returns false.
bool checkRanges(const LayeredBenchOptions& o) {
    if (o.extents.empty() || o.counts.empty()) {
        std::cerr << "nephele: bench: --extents and --counts need at least one value each\n";
        return false;
    }
    for (double e : o.extents)
        if (!(e > 0 && e <= 1e6)) {
            std::cerr << "nephele: bench: --extents: " << e << " m is out of range (0, 1e6]\n";
            return false;
        }
    for (int n : o.counts)
        if (n < 2 || n > 1024) {
            std::cerr << "nephele: bench: --counts: N = " << n << " is out of range 2..1024\n";
            return false;
        }
    return true;
}

// Every extent and N: the layered sky as shipped, its floor, without shadows and before its
// speed work, interleaved. Throws.
std::vector<Row> timeLayers(const LayeredBenchOptions& o, const std::vector<double>& extents,
                            const std::vector<int>& counts, int frames, FrameTarget& target, const OpaquePass& opaque) {
    std::map<int, std::unique_ptr<LayeredRenderer>> current, noShadow, before;
    for (int n : counts) {
        LayeredSettings s;
        s.layers = n;
        s.cacheDir = o.bench.cacheDir;
        if (o.bench.quick) useQuickLighting(s.lighting);
        current[n] = std::make_unique<LayeredRenderer>(s);
        LayeredSettings ns = s;
        ns.shadows = false;
        noShadow[n] = std::make_unique<LayeredRenderer>(ns);
        LayeredSettings bs = s;
        bs.downsample = 1;
        before[n] = std::make_unique<LayeredRenderer>(bs);
    }
    std::vector<Row> rows;
    for (double extent : extents)
        for (int n : counts) {
            const Scene scene = layeredBenchScene(extent, o.width, o.height);
            const View view = makeView(scene.camera);
            Row r;
            r.extent = extent, r.layers = n;
            const double t = 0;
            const std::vector<double> ms =
                timeFrames(frames, target, opaque, scene, view,
                           {[&] { r.stats = current[n]->render(scene, view, target.framebuffer(), t); },
                            [&] { r.floorStats = renderFloor(*current[n], scene, view, target.framebuffer(), t); },
                            [&] { noShadow[n]->render(scene, view, target.framebuffer(), t); },
                            [&] { before[n]->render(scene, view, target.framebuffer(), t); }});
            r.ms = ms[0], r.floorMs = ms[1], r.noShadowMs = ms[2], r.beforeMs = ms[3];
            std::cerr << "bench: extent " << fmt("%.0f", extent / 1000) << " km, N = " << n << ": " << fmt("%.1f", r.ms)
                      << " ms, floor " << fmt("%.1f", r.floorMs) << " ms, without shadows " << fmt("%.1f", r.noShadowMs)
                      << " ms, before " << fmt("%.1f", r.beforeMs) << " ms\n";
            rows.push_back(r);
        }
    return rows;
}

std::string layeredCsv(const std::vector<Row>& rows) {
    std::ostringstream csv;
    csv << "extent_m,layers,ms,floor_ms,ratio_to_floor,no_shadow_ms,shadow_pass_ms,before_ms,speedup_vs_before,"
           "draw_calls,instances,shadow_draw_calls,floor_draw_calls\n";
    for (const Row& r : rows)
        csv << fmt("%.0f", r.extent) << "," << r.layers << "," << fmt("%.3f", r.ms) << "," << fmt("%.3f", r.floorMs)
            << "," << fmt("%.3f", r.ms / r.floorMs) << "," << fmt("%.3f", r.noShadowMs) << ","
            << fmt("%.3f", r.ms - r.noShadowMs) << "," << fmt("%.3f", r.beforeMs) << ","
            << fmt("%.3f", r.beforeMs / r.ms) << "," << r.stats.drawCalls << "," << r.stats.instances << ","
            << r.stats.shadowDrawCalls << "," << r.floorStats.drawCalls << "\n";
    return csv.str();
}

std::string layeredMarkdown(const LayeredBenchOptions& o, const std::vector<Row>& rows,
                            const std::optional<AutoSplit>& autoSplit, int frames, const std::string& when,
                            const std::string& machine) {
    std::ostringstream md;
    md << "Measured by `nephele bench --layered` on " << when << ", " << machine << ", at " << o.width << "x"
       << o.height << ", median of " << frames
       << " frames (wall time to glFinish; the sky and ground are drawn before the clock starts; the variants take "
          "turns frame by frame). View: near_and_far.json's eye 900 m up looking 7° up at its layer (2500–3100 m, "
          "coverage 0.6, density 0.8), ground below the horizon. ms/frame is the layered sky as shipped (drawn at "
          "half resolution and upsampled with the frame's depth, cloud shadows fused into the upsampling); the floor "
          "is the same annulus and billboard instances at the frame's full resolution drawn with a trivial fragment "
          "shader (one 2D texture fetch, every fragment blended once, same depth test): the unavoidable pixel work of "
          "the geometry at the frame's resolution, which the half-resolution sky can undercut; shadows = ms/frame "
          "minus the same without shadows; before = the renderer before its speed work (full resolution, "
          "`LayeredSettings::downsample = 1`, shadows as a pass of their own; it shares the later city-glow program "
          "split, worth about 10% more), same frames.\n\n";
    md << "| extent | N | ms/frame | floor ms | × floor | shadows ms | before ms | speed-up | draws | instances |\n"
          "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Row& r : rows)
        md << "| " << fmt("%.0f km", r.extent / 1000) << " | " << r.layers << " | " << fmt("%.1f", r.ms) << " | "
           << fmt("%.1f", r.floorMs) << " | " << fmt("%.2f", r.ms / r.floorMs) << " | "
           << fmt("%.1f", r.ms - r.noShadowMs) << " | " << fmt("%.1f", r.beforeMs) << " | "
           << fmt("%.2f", r.beforeMs / r.ms) << " | "
           << r.stats.drawCalls + r.stats.shadowDrawCalls + r.stats.upsampleDrawCalls << " | " << r.stats.instances
           << " |\n";
    if (autoSplit)
        md << "\n`--method auto` on near_and_far.json (" << autoSplit->nearClouds
           << " clouds near the eye as ellipsoids: its explicit cumulus and the layer's near LOD within "
           << fmt("%.1f", (kAutoNearRadius + kAutoBlendBand) / 1000)
           << " km; the layer beyond), same run: " << fmt("%.1f", autoSplit->ms) << " ms per frame, "
           << fmt("%.2f", autoSplit->ms / autoSplit->floorMs) << "× the far field's floor ("
           << fmt("%.1f", autoSplit->floorMs) << " ms); far field " << fmt("%.1f", autoSplit->farMs) << " ms ("
           << fmt("%.2f", autoSplit->farMs / autoSplit->floorMs)
           << "× the floor), near field (near LOD update and compositor) " << fmt("%.1f", autoSplit->nearMs) << " ms ("
           << fmt("%.2f", autoSplit->nearMs / autoSplit->floorMs) << "× the far field's floor).\n";
    md << "\n![ms per frame against the layer count N](layered_bench.png)\n";
    return md.str();
}

}  // namespace

int runLayeredBench(const LayeredBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    if (!checkRanges(o)) return 2;
    const std::vector<int> counts = o.bench.quick ? std::vector<int>{2, 8} : o.counts;
    const std::vector<double> extents = o.bench.quick ? std::vector<double>{20000} : o.extents;
    const int frames = o.bench.quick ? 1 : o.frames;

    std::vector<Row> rows;
    std::string renderer;
    std::optional<AutoSplit> autoSplit;
    try {
        ContextOptions co;
        co.backend = o.bench.backend;
        auto context = Context::create(co);
        renderer = context->description();
        gl::setChecks(false);  // timing: no glGetError round trips
        FrameTarget target(o.width, o.height);
        OpaquePass opaque;
        rows = timeLayers(o, extents, counts, frames, target, opaque);
        autoSplit = timeAutoNearAndFar(o, target, opaque, frames);
        std::cerr << "bench: --method auto on near_and_far.json: " << fmt("%.1f", autoSplit->ms) << " ms (far "
                  << fmt("%.1f", autoSplit->farMs) << ", near " << fmt("%.1f", autoSplit->nearMs) << ", far floor "
                  << fmt("%.1f", autoSplit->floorMs) << ")\n";
        gl::setChecks(true);
        gl::checkAlways("bench --layered");
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench failed: " << e.what() << "\n";
        return 1;
    }
    const std::string when = utcNow();
    const std::string md = layeredMarkdown(o, rows, autoSplit, frames, when, machineLine(renderer));
    return publishChartBench(o.bench.outDir, "layered bench", "layered_bench", layeredCsv(rows), md, "plot_layered.py",
                             when, {std::to_string(o.width) + "x" + std::to_string(o.height)});
}

}  // namespace nephele::cli
