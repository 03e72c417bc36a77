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
#include "nephele/log.hpp"
#include "nephele/opaque.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
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
    ls.reusePeriod = 1;  // a still view drawn again and again: every pixel afresh
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

// The far field along a flight: near_and_far.json's view flown forward at 70 m/s, turning 9
// degrees a second, at `fps` frames a second (30: 2.3 m and 0.3 degrees a frame), drawn by the
// layered sky as shipped (the far field reused across frames) and with every pixel drawn afresh
// (LayeredSettings::reusePeriod = 1), and the floor of each frame, in turn.
struct ReuseFlight {
    double fps = 30;
    std::vector<double> reusedMs, freshMs, floorMs, psnr, kept;  // per frame after the first
};

ReuseFlight flyFarField(const LayeredBenchOptions& o, double fps, int frames, FrameTarget& target,
                        const OpaquePass& opaque) {
    const Scene scene = layeredBenchScene(o.extents.front(), o.width, o.height);
    LayeredSettings s;
    s.cacheDir = o.bench.cacheDir;
    if (o.bench.quick) useQuickLighting(s.lighting);
    LayeredSettings fs = s;
    fs.reusePeriod = 1;
    LayeredRenderer reused(s), fresh(fs);
    ReuseFlight f;
    f.fps = fps;
    using Clock = std::chrono::steady_clock;
    auto timed = [&](const View& view, auto&& draw) {
        opaque.draw(scene, view, target.framebuffer());
        gl::glFinish();
        const auto t0 = Clock::now();
        draw();
        gl::glFinish();
        return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    };
    const double pitch = std::asin(scene.camera.direction.z);
    for (int k = 0; k < frames; ++k) {
        const double t = k / fps, yaw = glm::radians(9.0) * t;
        Camera c = scene.camera;
        const Vec3 heading(std::sin(yaw), std::cos(yaw), 0.0);
        c.position += heading * (70.0 * t);
        c.direction = glm::normalize(heading * std::cos(pitch) + Vec3(0, 0, std::sin(pitch)));
        const View view = makeView(c);
        LayeredStats stats;
        const double reusedMs = timed(view, [&] { stats = reused.render(scene, view, target.framebuffer(), t); });
        const Image a = target.readColor();
        const double freshMs = timed(view, [&] { fresh.render(scene, view, target.framebuffer(), t); });
        const Image b = target.readColor();
        const double floorMs = timed(view, [&] { renderFloor(fresh, scene, view, target.framebuffer(), t); });
        if (k == 0) continue;  // the first frame makes the textures
        f.reusedMs.push_back(reusedMs), f.freshMs.push_back(freshMs), f.floorMs.push_back(floorMs);
        f.psnr.push_back(psnr8(channels(a, 0, 3), channels(b, 0, 3)));
        if (stats.reusedPixels >= 0 && stats.reducedPixels > 0)
            f.kept.push_back(double(stats.reusedPixels) / double(stats.reducedPixels));
        reportProgress("bench --layered: the far field reused at " + fmt("%.0f", fps) + " fps", double(k + 1) / frames);
    }
    return f;
}

double meanOf(const std::vector<double>& v) {
    double sum = 0;
    for (double x : v) sum += x;
    return v.empty() ? 0 : sum / double(v.size());
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
        s.reusePeriod = 1;  // a still view drawn again and again: every pixel afresh (the flight below reuses)
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

// The far field reused: a row per flight rate.
std::string reuseMarkdown(const LayeredBenchOptions& o, const std::vector<ReuseFlight>& flights) {
    std::ostringstream md;
    md << "\n**The far field reused** (`LayeredSettings::reusePeriod`, `--far-reuse`; [how](layered.md#the-far-field-"
          "reused-across-frames)), same run: the view above flown forward at 70 m/s turning 9° a second (layer "
          "extent "
       << fmt("%.0f km", o.extents.front() / 1000)
       << ", N = 8), each frame drawn as shipped (a reduced pixel drawn afresh at least every "
       << LayeredSettings{}.reusePeriod << "th frame, sooner where its parallax bound passes "
       << fmt("%g", LayeredSettings{}.reuseError)
       << " reduced px; else the last frame's, reprojected) and with every pixel afresh, and the frame's floor, "
          "in turn; the first frame left out. Amortised = the mean over the frames; × "
          "floor = that over the floor's mean. Kept = the share of the reduced pixels the reprojection kept. PSNR: "
          "each reused frame against the same frame drawn afresh, 8-bit sRGB.\n\n";
    md << "| frames/s | frames | afresh ms (× floor) | reused ms amortised (× floor) | reused median / worst ms | "
          "floor ms | kept | PSNR min / median dB |\n|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const ReuseFlight& f : flights) {
        if (f.reusedMs.empty()) continue;
        const double floorMs = meanOf(f.floorMs);
        md << "| " << fmt("%.0f", f.fps) << " | " << f.reusedMs.size() << " | " << fmt("%.1f", meanOf(f.freshMs))
           << " (" << fmt("%.2f", meanOf(f.freshMs) / floorMs) << "×) | " << fmt("%.1f", meanOf(f.reusedMs)) << " ("
           << fmt("%.2f", meanOf(f.reusedMs) / floorMs) << "×) | " << fmt("%.1f", median(f.reusedMs)) << " / "
           << fmt("%.1f", *std::max_element(f.reusedMs.begin(), f.reusedMs.end())) << " | " << fmt("%.1f", floorMs)
           << " | " << (f.kept.empty() ? std::string("–") : fmt("%.0f%%", 100 * meanOf(f.kept))) << " | "
           << fmt("%.1f", *std::min_element(f.psnr.begin(), f.psnr.end())) << " / " << fmt("%.1f", median(f.psnr))
           << " |\n";
    }
    return md.str();
}

std::string layeredMarkdown(const LayeredBenchOptions& o, const std::vector<Row>& rows,
                            const std::optional<AutoSplit>& autoSplit, const std::vector<ReuseFlight>& flights,
                            int frames, const std::string& when, const std::string& machine) {
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
          "split, worth about 10% more), same frames. A still view drawn again and again: every variant draws every "
          "pixel afresh (`reusePeriod = 1`); the far field reused across frames is measured on a flight, below.\n\n";
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
    md << reuseMarkdown(o, flights);
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
    std::vector<ReuseFlight> flights;
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
        for (const double fps : {30.0, 10.0}) {
            flights.push_back(flyFarField(o, fps, o.bench.quick ? 4 : 61, target, opaque));
            const ReuseFlight& f = flights.back();
            std::cerr << "bench: the far field reused at " << fmt("%.0f", fps)
                      << " fps: " << fmt("%.1f", meanOf(f.reusedMs)) << " ms amortised, afresh "
                      << fmt("%.1f", meanOf(f.freshMs)) << " ms, floor " << fmt("%.1f", meanOf(f.floorMs))
                      << " ms, worst PSNR "
                      << fmt("%.1f", f.psnr.empty() ? 0.0 : *std::min_element(f.psnr.begin(), f.psnr.end())) << " dB\n";
        }
        gl::setChecks(true);
        gl::checkAlways("bench --layered");
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench failed: " << e.what() << "\n";
        return 1;
    }
    const std::string when = utcNow();
    const std::string md = layeredMarkdown(o, rows, autoSplit, flights, frames, when, machineLine(renderer));
    return publishChartBench(o.bench.outDir, "layered bench", "layered_bench", layeredCsv(rows), md, "plot_layered.py",
                             when, {std::to_string(o.width) + "x" + std::to_string(o.height)});
}

}  // namespace nephele::cli
