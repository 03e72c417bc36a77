// `nephele bench --cruise`: tiles that last (EllipsoidSettings::reuse) against every tile
// every frame, on flights: the cruise bench's 60 s cruise over ~4000 ellipsoids
// (cruise.json), its sharp turn (cruise_turn.json), approach.json, flythrough.json and
// layer_flight.json. Both run `--method auto` (the compositor's defaults under auto), frame by
// frame in turn, so that a busy machine slows both alike; every frame of the reuse run is
// compared with the same frame with every tile fresh.
#include "bench_command.hpp"

#include "bench_util.hpp"
#include "flythrough_command.hpp"
#include "render_command.hpp"

#include "nephele/gl.hpp"
#include "nephele/image.hpp"
#include "nephele/log.hpp"
#include "nephele/sky.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

struct CruiseFrame {
    double onMs = 0, offMs = 0;
    double repeatMs = -1;  // every 10th frame: the reuse run's same frame again (nothing newly stale: its floor)
    double aloneMs = -1;   // Flight::reuseAlone: the same frame with --reuse on --cloud-lod off
    int impostors = 0, impostorsMade = 0;  // the on run's clouds drawn as impostors, and of those made this frame
    int must = 0;                          // reuse: tiles rendered for want of a usable image
    bool repacked = false;                 // reuse: the atlas was packed anew
    int onTiles = 0, offTiles = 0, visible = 0;
    std::int64_t onPixels = 0, offPixels = 0;
    double psnr = 0;                     // dB, the reuse frame against the fresh one (8-bit sRGB, as written)
    double onChange = 0, offChange = 0;  // mean |change| from the frame before (FrameChanges)
};

struct Flight {
    std::string scene, what;
    double fps = 0;  // frames a second; 0: --fps's (the cruise at 30 and at 6 keep their own)
    std::vector<CruiseFrame> frames;
    double firstOnMs = 0, firstOffMs = 0;  // frame 0: the grids made and every tile rendered (both)
    bool reuseAlone = false;               // also run --reuse on --cloud-lod off (what each part gives)
    std::string pathFrom;                  // a flight file (data/flights) whose keyframes replace the scene's path
    double erosion = 0;                    // > 0: the scene's detail on (Medium::Detail::erosion), its own settings
    double seconds = 0;                    // > 0: only the path's first seconds
    std::string key;                       // its name in --flights and the CSV (empty: the scene's file name)
    const std::string& id() const { return key.empty() ? scene : key; }
};

// The keyframes of a `nephele fly --script` flight file (data/flights/*.json).
std::vector<Keyframe> flightKeyframes(const std::string& file) {
    std::ifstream in(file);
    if (!in) throw std::runtime_error("cannot read " + file);
    const nlohmann::json j = nlohmann::json::parse(in);
    std::vector<Keyframe> path;
    for (const auto& k : j.at("keyframes")) {
        Keyframe f;
        f.t = k.at("t").get<double>();
        const auto p = k.at("position").get<std::vector<double>>(), l = k.at("look_at").get<std::vector<double>>();
        f.position = Vec3(p.at(0), p.at(1), p.at(2)), f.lookAt = Vec3(l.at(0), l.at(1), l.at(2));
        path.push_back(f);
    }
    if (path.size() < 2) throw std::runtime_error(file + ": fewer than two keyframes");
    return path;
}

// The cloud LOD's bound: every frame of the defaults at least this close to every tile fresh
// with the LOD off (docs/compositor.md, "One impostor per far cloud").
constexpr double kLodBoundDb = 45;


RenderOptions optionsFor(bool reuse, bool lod, GlBackend backend) {
    RenderOptions o;
    o.method = Method::Auto;
    o.backend = backend;
    o.layered = autoLayeredSettings();
    o.ellipsoid = autoEllipsoidSettings();
    o.ellipsoid.reuse = reuse;
    o.ellipsoid.cloudLod = lod;
    if (!reuse) o.layered.reusePeriod = 1;  // "off": the far field drawn afresh every frame too
    return o;
}

void fly(Flight& f, const CruiseBenchOptions& o) {
    Scene scene = loadScene(o.bench.scenesDir + "/" + f.scene);
    scene.camera.width = o.width, scene.camera.height = o.height;
    if (!f.pathFrom.empty()) scene.path = flightKeyframes(o.bench.scenesDir + "/../flights/" + f.pathFrom);
    if (f.erosion > 0) scene.medium.detail.erosion = f.erosion;
    const double t0 = scene.path.front().t,
                 t1 = std::min({o.bench.quick ? t0 + 1.0 : scene.path.back().t, scene.path.back().t,
                                f.seconds > 0 ? t0 + f.seconds : scene.path.back().t});
    const int frames = frameCount(t0, t1, f.fps);
    FrameRenderer on(optionsFor(true, true, o.bench.backend)), off(optionsFor(false, false, o.bench.backend));
    std::unique_ptr<FrameRenderer> alone;
    if (f.reuseAlone) alone = std::make_unique<FrameRenderer>(optionsFor(true, false, o.bench.backend));
    gl::setChecks(false);  // timing: no glGetError round trips
    FrameChanges onChanges, offChanges;
    for (int k = 0; k < frames; ++k) {
        const double t = t0 + k / f.fps;
        const Frame a = on.render(scene, t);
        const Frame b = off.render(scene, t);
        const double aloneMs = alone ? alone->render(scene, t).ms : -1;
        onChanges.add(a.color);
        offChanges.add(b.color);
        if (k == 0) {
            f.firstOnMs = a.ms, f.firstOffMs = b.ms;
            continue;
        }
        CruiseFrame c;
        c.onMs = a.ms, c.offMs = b.ms, c.aloneMs = aloneMs;
        c.impostors = a.stats.impostors, c.impostorsMade = a.stats.impostorsRendered;
        c.onTiles = a.stats.tilesRendered, c.offTiles = b.stats.tilesRendered, c.visible = b.stats.visible;
        c.onPixels = a.stats.tilePixelsRendered, c.offPixels = b.stats.tilePixelsRendered;
        c.psnr = psnr8(a.color, b.color);
        c.must = a.stats.tilesMust, c.repacked = a.stats.atlasRepacked;
        if (k % 10 == 0) c.repeatMs = on.render(scene, t).ms;
        c.onChange = onChanges.changes().back(), c.offChange = offChanges.changes().back();
        f.frames.push_back(c);
        reportProgress("bench --cruise " + f.scene, double(k + 1) / frames);
    }
    gl::setChecks(true);
}

template <class F>
std::vector<double> column(const std::vector<CruiseFrame>& frames, F get) {
    std::vector<double> v;
    for (const CruiseFrame& c : frames) v.push_back(double(get(c)));
    return v;
}
double mean(const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0 : s / double(v.size());
}
double maxOf(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }
double minOf(const std::vector<double>& v) { return v.empty() ? 0 : *std::min_element(v.begin(), v.end()); }
// Frame pacing (issue 37 §4): "median / worst (worst ÷ median)" of a flight's frame times.
std::string evenness(const std::vector<double>& ms) {
    const double m = median(ms), worst = maxOf(ms);
    return fmt("%.1f", m) + " / " + fmt("%.1f", worst) + " (" + fmt("%.2f", worst / std::max(m, 1e-9)) + ")";
}

std::string csvOf(const std::vector<Flight>& flights) {
    std::ostringstream csv;
    csv << "flight,frame,on_ms,off_ms,repeat_ms,on_tiles,on_tiles_without_image,atlas_repacked,off_tiles,visible,on_"
           "tile_pixels,"
           "off_tile_pixels,psnr_db,on_change,off_change,reuse_alone_ms,impostors,impostors_made\n";
    for (const Flight& f : flights)
        for (std::size_t i = 0; i < f.frames.size(); ++i) {
            const CruiseFrame& c = f.frames[i];
            csv << f.id() << "," << i + 1 << "," << fmt("%.3f", c.onMs) << "," << fmt("%.3f", c.offMs) << ","
                << (c.repeatMs < 0 ? std::string() : fmt("%.3f", c.repeatMs)) << "," << c.onTiles << "," << c.must
                << "," << (c.repacked ? 1 : 0) << "," << c.offTiles << "," << c.visible << "," << c.onPixels << ","
                << c.offPixels << "," << fmt("%.2f", c.psnr) << "," << fmt("%.6f", c.onChange) << ","
                << fmt("%.6f", c.offChange) << "," << (c.aloneMs < 0 ? std::string() : fmt("%.3f", c.aloneMs)) << ","
                << c.impostors << "," << c.impostorsMade << "\n";
        }
    return csv.str();
}

std::string markdownOf(const CruiseBenchOptions& o, const std::vector<Flight>& flights, const std::string& when,
                       const std::string& machine) {
    std::ostringstream md;
    md << "Measured by `nephele bench --cruise` on " << when << ", " << machine << ", at " << o.width << "x" << o.height
       << ", `--method auto` with its defaults (\"on\": back to front, `--reuse on`, `--cloud-lod on`, the far field "
          "reused across frames) and with `--reuse off --cloud-lod off --far-reuse 1` (\"off\": every tile rendered "
          "and the far field drawn afresh every frame), frame by frame in turn; on the cruise and the turn also "
          "`--reuse on --cloud-lod off` (\"reuse alone\": what tiles that last give without the "
          "cloud LOD: neither far impostors nor close tiles at what their image holds). A frame's ms is the draw's "
          "wall time to "
          "glFinish, the read-back not counted. Frame 0 (the clouds' radiance grids made, every tile rendered, in "
          "both) is "
          "left out of the figures and given apart. PSNR: each frame of \"on\" against the same frame of \"off\" "
          "(every tile "
          "fresh, the cloud LOD off), as 8-bit sRGB, and how many frames fall below the cloud LOD's bound of 45 dB. "
          "Flicker: the mean frame-to-frame change (mean |linear RGB difference| clamped to [0, 1]); the "
          "flicker index against the exact model is this change minus the exact model's, which is the same for both "
          "runs, so on − off is the difference of their indices. Reuse floor: every 10th frame the reuse run draws the "
          "same frame again, with nothing newly stale: what a frame costs when it renders only the tiles no reuse can "
          "keep (the eye inside, cut by the near plane, past 6× the error) and the budget's backlog, besides the "
          "composite, the planning and, on layer_flight, the layered sky. Tiles without an image: rendered whatever "
          "the budget (new in view, a "
          "part come into view, cut by the near plane).\n\n";
    md << "| flight | frames/s | frames | ms amortised on / off | on × faster | reuse alone ms (× faster) | reuse "
          "floor ms | "
          "median / worst ms on (worst ÷ median) | median / worst ms off (worst ÷ median) | tiles rendered a frame on "
          "(without an image) / off (visible) | impostors a frame (made) | "
          "tile Mpx "
          "a frame on / off | atlas repacks | PSNR min / median dB (frames below 45) | change on − off | worst frame "
          "change on / off | frame 0 "
          "ms on / off |\n"
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Flight& f : flights) {
        const auto& fr = f.frames;
        const auto onMs = column(fr, [](const CruiseFrame& c) { return c.onMs; });
        const auto offMs = column(fr, [](const CruiseFrame& c) { return c.offMs; });
        const auto psnr = column(fr, [](const CruiseFrame& c) { return c.psnr; });
        const auto onCh = column(fr, [](const CruiseFrame& c) { return c.onChange; });
        const auto offCh = column(fr, [](const CruiseFrame& c) { return c.offChange; });
        std::vector<double> repeat, alone;
        int repacks = 0;
        for (const CruiseFrame& c : fr) {
            if (c.repeatMs >= 0) repeat.push_back(c.repeatMs);
            if (c.aloneMs >= 0) alone.push_back(c.aloneMs);
            repacks += c.repacked ? 1 : 0;
        }
        md << "| " << f.what << " | " << fmt("%g", f.fps) << " | " << fr.size() << " | " << fmt("%.1f", mean(onMs))
           << " / " << fmt("%.1f", mean(offMs)) << " | " << fmt("%.2f", mean(offMs) / std::max(mean(onMs), 1e-9))
           << " | "
           << (alone.empty()
                   ? std::string("–")
                   : fmt("%.1f", mean(alone)) + " (" + fmt("%.2f", mean(offMs) / std::max(mean(alone), 1e-9)) + ")")
           << " | " << (repeat.empty() ? std::string("–") : fmt("%.1f", mean(repeat))) << " | " << evenness(onMs)
           << " | " << evenness(offMs) << " | "
           << fmt("%.0f", mean(column(fr, [](const CruiseFrame& c) { return c.onTiles; }))) << " ("
           << fmt("%.0f", mean(column(fr, [](const CruiseFrame& c) { return c.must; }))) << ") / "
           << fmt("%.0f", mean(column(fr, [](const CruiseFrame& c) { return c.offTiles; }))) << " ("
           << fmt("%.0f", mean(column(fr, [](const CruiseFrame& c) { return c.visible; }))) << ") | "
           << fmt("%.0f", mean(column(fr, [](const CruiseFrame& c) { return c.impostors; }))) << " ("
           << fmt("%.1f", mean(column(fr, [](const CruiseFrame& c) { return c.impostorsMade; }))) << ") | "
           << fmt("%.2f", mean(column(fr, [](const CruiseFrame& c) { return c.onPixels; })) / 1e6) << " / "
           << fmt("%.2f", mean(column(fr, [](const CruiseFrame& c) { return c.offPixels; })) / 1e6) << " | " << repacks
           << " | " << fmt("%.1f", minOf(psnr)) << " / " << fmt("%.1f", median(psnr)) << " ("
           << std::count_if(psnr.begin(), psnr.end(), [](double p) { return p < kLodBoundDb; }) << ") | "
           << fmt("%+.5f", mean(onCh) - mean(offCh)) << " | " << fmt("%.4f", maxOf(onCh)) << " / "
           << fmt("%.4f", maxOf(offCh)) << " | " << fmt("%.0f", f.firstOnMs) << " / " << fmt("%.0f", f.firstOffMs)
           << " |\n";
    }
    // The detail's cost: its flight against the same frames of the cruise without it.
    const auto plain =
        std::find_if(flights.begin(), flights.end(), [](const Flight& f) { return f.id() == "cruise.json"; });
    const auto detailed =
        std::find_if(flights.begin(), flights.end(), [](const Flight& f) { return f.id() == "cruise_detail"; });
    if (plain != flights.end() && detailed != flights.end() && !detailed->frames.empty() &&
        plain->frames.size() >= detailed->frames.size()) {
        const std::vector<CruiseFrame> same(plain->frames.begin(),
                                            plain->frames.begin() + std::ptrdiff_t(detailed->frames.size()));
        auto ms = [](const std::vector<CruiseFrame>& fr, bool on) {
            return mean(column(fr, [on](const CruiseFrame& c) { return on ? c.onMs : c.offMs; }));
        };
        md << "\n**The detail's cost on the cruise** (issue 34 §5 allows 1.5×): over the same " << same.size()
           << " frames, " << fmt("%.1f", ms(detailed->frames, true)) << " ms amortised with the detail against "
           << fmt("%.1f", ms(same, true)) << " without, **" << fmt("%.2f", ms(detailed->frames, true) / ms(same, true))
           << "×**, with the defaults (tiles that last, the cloud LOD); every tile fresh, "
           << fmt("%.1f", ms(detailed->frames, false)) << " against " << fmt("%.1f", ms(same, false)) << ", "
           << fmt("%.2f", ms(detailed->frames, false) / ms(same, false)) << "×.\n";
    }
    md << "\n![ms per frame: auto (reuse and cloud LOD on), reuse alone, both off](cruise_bench.png)\n";
    return md.str();
}

}  // namespace

int runCruiseBench(const CruiseBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    std::vector<Flight> flights = {
        {"cruise.json", "cruise: 60 s at 70 m/s over 4017 ellipsoids in 150 cumulus", 0, {}, 0, 0, true},
        {"cruise_turn.json", "sharp turn: 180° in 3 s in that field", 0, {}, 0, 0, true},
        {"approach.json", "approach.json"},
        {"flythrough.json", "flythrough.json"},
        {"layer_flight.json", "layer_flight.json"},
        {"showcase.json",
         "showcase: into_cloud.json's flight (README command 1's scene)",
         0,
         {},
         0,
         0,
         false,
         "into_cloud.json"},
        // The detail's cost on the cruise (issue 34 §5: at most 1.5x the frame without it): the
        // cruise's first 20 s with data/scenes/detailed_cumulus.json's erosion, beside the cruise's
        // row (the same frames are its first 200).
        {"cruise.json",
         "cruise with the detail (erosion 1.5, the nephele kind): its first 20 s",
         0,
         {},
         0,
         0,
         false,
         "",
         kBenchDetailErosion,
         20,
         "cruise_detail"},
        // Even frames (issue 37 §4): the cruise at a simulator's pace and at a slow image generator's,
        // whatever --fps says: its first 20 s at 30 frames a second, all 60 s at 6.
        {"cruise.json", "cruise at 30 frames a second: its first 20 s", 30, {}, 0, 0, false, "", 0, 20, "cruise_30fps"},
        {"cruise.json", "cruise at 6 frames a second", 6, {}, 0, 0, false, "", 0, 0, "cruise_6fps"},
    };
    if (o.bench.quick) flights.resize(1), flights[0].scene = "approach.json", flights[0].what = "approach.json (1 s)";
    if (!o.flights.empty()) {
        for (const std::string& f : o.flights)
            if (std::none_of(flights.begin(), flights.end(), [&](const Flight& x) { return x.id() == f; })) {
                std::string known;
                for (const Flight& x : flights) known += (known.empty() ? "" : ", ") + x.id();
                std::cerr << "nephele: bench --cruise: --flights: no flight '" << f << "' (" << known << ")\n";
                return 2;
            }
        std::erase_if(flights, [&](const Flight& x) {
            return std::find(o.flights.begin(), o.flights.end(), x.id()) == o.flights.end();
        });
    }
    std::string renderer;
    try {
        ContextOptions co;
        co.backend = o.bench.backend;
        renderer = Context::create(co)->description();
        for (Flight& f : flights) {
            if (f.fps <= 0) f.fps = o.fps;
            fly(f, o);
        }
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench failed: " << e.what() << "\n";
        return 1;
    }
    const std::string when = utcNow();
    const std::string md = markdownOf(o, flights, when, machineLine(renderer));
    const std::string csvPath = (fs::path(o.bench.outDir) / "cruise_bench.csv").string();
    const std::string mdPath = (fs::path(o.bench.outDir) / "cruise_bench.md").string();
    const std::string pngPath = (fs::path(o.bench.outDir) / "cruise_bench.png").string();
    try {
        writeTextFiles({{csvPath, csvOf(flights)}, {mdPath, generatedSection("cruise bench", md)}});
        runPlot("plot_cruise.py",
                {csvPath, std::string(kChartsFolder) + "/cruise_bench.png", when,
                 std::to_string(o.width) + "x" + std::to_string(o.height)},
                o.bench.outDir, {"cruise_bench.png"});
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench: " << e.what() << "\n";
        return 1;
    }
    std::cout << md;
    std::cerr << "nephele: bench wrote " << csvPath << ", " << mdPath << ", " << pngPath << "\n";
    return 0;
}

}  // namespace nephele::cli
