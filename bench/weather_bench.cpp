// `nephele bench --weather`: a flight through near_and_far.json while the weather changes the
// way a host's CIGI packets change it (coverage, base, thickness, wind, the sun, a second layer
// on and off), each change ramping over --transition seconds, frame by frame: SkyRenderer's
// host API (update once a frame, draw) against the one-call render() of
// before, each frame of the two taking turns so that a busy machine slows both alike. The
// target: the worst frame at most 1.5 times the median frame. A third renderer draws the first
// frame again in the same turns (the same work every frame): the machine's own spread of frame
// times, measured in the same run, against which a loaded machine's result is read.
#include "bench_command.hpp"

#include "bench_util.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/host_view.hpp"
#include "nephele/opaque.hpp"
#include "nephele/sky.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <sstream>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

using Clock = std::chrono::steady_clock;

// A change of the weather at a frame of the flight, as a host applies a CIGI packet.
struct WeatherEvent {
    int frame;
    std::string what;
    std::function<void(Weather&)> apply;
};

// The layer's control as the weather holds it, to change one field of it.
CloudLayerControl controlOf(const Weather& w) {
    const Layer& l = w.layers.at(1).layer;
    CloudLayerControl c;
    c.layerId = 1;
    c.cloudType = CigiCloudType::Other1;  // keeps the layer's density and near LOD
    c.coverage = l.coverage * 100, c.baseElevation = l.base, c.thickness = l.thickness;
    c.horizontalWindSpeed = glm::length(l.wind);
    c.windDirection = glm::degrees(std::atan2(-l.wind.x, -l.wind.y));
    return c;
}

Sun sunAt(double azimuthDeg, double elevationDeg) {
    Sun s;
    const double a = glm::radians(azimuthDeg), e = glm::radians(elevationDeg);
    s.direction = Vec3(std::sin(a) * std::cos(e), std::cos(a) * std::cos(e), std::sin(e));
    return s;
}

// The sweep: one change of each kind (a second layer on with the wind's change, off with the
// sun's last), then two at once, spread over the flight.
std::vector<WeatherEvent> sweep(int frames) {
    auto at = [&](double f) { return std::max(1, int(std::lround(f * frames))); };
    auto layer = [](auto change) {
        return [change](Weather& w) {
            CloudLayerControl c = controlOf(w);
            change(c);
            w.apply(c);
        };
    };
    return {
        {at(0.1), "coverage 60% -> 75%", layer([](CloudLayerControl& c) { c.coverage = 75; })},
        {at(0.2), "base 2500 -> 2300 m", layer([](CloudLayerControl& c) { c.baseElevation = 2300; })},
        {at(0.3), "thickness 600 -> 800 m", layer([](CloudLayerControl& c) { c.thickness = 800; })},
        {at(0.4), "wind 6 m/s -> 15 m/s from 200 deg, and layer 2 on: altocumulus 40% at 4000 m, 300 m thick",
         [](Weather& w) {
             CloudLayerControl c = controlOf(w);
             c.horizontalWindSpeed = 15, c.windDirection = 200;
             w.apply(c);
             CloudLayerControl second;
             second.layerId = 2;
             second.cloudType = CigiCloudType::Altocumulus;
             second.coverage = 40, second.baseElevation = 4000, second.thickness = 300;
             second.horizontalWindSpeed = 8, second.windDirection = 250;
             w.apply(second);
         }},
        {at(0.5), "sun azimuth 56 -> 80 deg, elevation 68 -> 40 deg", [](Weather& w) { w.sun = sunAt(80, 40); }},
        {at(0.65), "coverage 45% and thickness 500 m",
         layer([](CloudLayerControl& c) { c.coverage = 45, c.thickness = 500; })},
        {at(0.8), "sun elevation 40 -> 25 deg, and layer 2 off",
         [](Weather& w) {
             w.sun = sunAt(90, 25);
             w.layers.at(2).enabled = false;
         }},
    };
}

struct FrameTime {
    double ms = 0, updateMs = 0, beforeMs = 0;
    double steadyMs = 0;  // the first frame drawn again: the same work every frame
    SkyUpdateStats update;
    int uploads = 0, pendingLayers = 0, beforeLightVolumes = 0;
    double farFieldMs = 0, tilesMs = 0, compositeMs = 0;
    int passes = 0, visible = 0;
    int tilesRendered = 0, tilesMust = 0, lightUploads = 0, impostorsRendered = 0;  // what a slow tile pass did
    double tileMegapixels = 0, planMs = 0;
    bool atlasGrown = false;
    bool farFieldReused = false;  // the far field kept what it could of the last frame (else every pixel afresh)
    double farFieldKept = 0;      // the share of its reduced pixels kept (LayeredStats::reusedPixels)
    // What the process waited on during update + draw (getrusage, every thread): page faults
    // that read from disk, those that did not, and switches away from a running thread.
    long majorFaults = 0, minorFaults = 0, involuntarySwitches = 0;
    std::string event;
};

rusage processUsage() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u;
}

// The flight: the scene camera moving along its heading at `speed` m/s, `frames` frames at `fps`.
std::vector<FrameTime> fly(const WeatherBenchOptions& o, const Scene& scene, const std::string& cacheDir, int frames) {
    LayeredSettings ls = autoLayeredSettings();
    ls.cacheDir = cacheDir;
    EllipsoidSettings es = autoEllipsoidSettings();
    if (o.bench.quick) {  // a run for tests: every part exercised, the lighting coarse
        useQuickLighting(ls.lighting);
        es.light.size = 8, es.light.sunPhotons = es.light.skyPhotons = 4096;
    }
    SkySettings hs{ls, {}, es};
    hs.timings = hs.ellipsoid.timings = true;  // the draw's ms by part, to tell what a slow frame spent
    SkyRenderer host(hs), before(SkySettings{ls, {}, es});
    // The steady frame: frame 0's view and weather at t = 0, the far field drawn afresh, the
    // clouds' tiles all kept after its first frames: the same work each frame.
    SkySettings ss{ls, {}, es};
    ss.layered.reusePeriod = 1;
    SkyRenderer steady(ss);
    steady.prepare(scene);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass opaque;
    host.prepare(scene);
    Weather weather = Weather::of(scene);
    weather.transitionSeconds = o.transition;
    Scene old = scene;  // what render() draws: the same weather applied to a scene
    const Weather firstWeather = weather;
    const View firstView = makeView(scene.camera);
    const std::vector<WeatherEvent> events = sweep(frames);
    const double dt = 1.0 / o.fps;
    const Vec3 heading = glm::normalize(Vec3(scene.camera.direction.x, scene.camera.direction.y, 0));
    std::vector<FrameTime> out;
    for (int f = -2; f < frames; ++f) {  // two warm-up frames
        FrameTime ft;
        for (const WeatherEvent& e : events)
            if (e.frame == f) e.apply(weather), ft.event = e.what;
        old.layers = weather.enabledLayers();
        old.sun = weather.sun;
        const double t = std::max(f, 0) * dt;
        Camera camera = scene.camera;
        camera.position += heading * (o.speed * t);
        const View view = makeView(camera);
        const ViewDesc desc = viewDescOf(view, target.framebuffer());
        opaque.draw(old, view, target.framebuffer());
        gl::glFinish();
        const rusage u0 = processUsage();
        auto t0 = Clock::now();
        ft.update = host.update(f <= 0 ? 0 : dt, weather, view.eye);
        ft.updateMs = msSince(t0);
        const SkyStats st = host.draw(desc);
        gl::glFinish();
        ft.ms = msSince(t0);
        const rusage u1 = processUsage();
        ft.majorFaults = u1.ru_majflt - u0.ru_majflt, ft.minorFaults = u1.ru_minflt - u0.ru_minflt;
        ft.involuntarySwitches = u1.ru_nivcsw - u0.ru_nivcsw;
        ft.uploads = st.layered.uploads, ft.pendingLayers = st.layered.pendingLayers;
        ft.farFieldReused = st.layered.reusedFrame;
        ft.farFieldKept = st.layered.reducedPixels > 0 && st.layered.reusedPixels > 0
                              ? double(st.layered.reusedPixels) / double(st.layered.reducedPixels)
                              : 0.0;
        ft.farFieldMs = st.farFieldMs, ft.tilesMs = st.ellipsoids.tilesMs, ft.compositeMs = st.ellipsoids.compositeMs;
        ft.passes = st.ellipsoids.passes, ft.visible = st.ellipsoids.visible;
        ft.tilesRendered = st.ellipsoids.tilesRendered, ft.lightUploads = st.ellipsoids.lightUploads;
        ft.atlasGrown = st.ellipsoids.atlasGrown;
        ft.tilesMust = st.ellipsoids.tilesMust, ft.impostorsRendered = st.ellipsoids.impostorsRendered;
        ft.tileMegapixels = 1e-6 * double(st.ellipsoids.tilePixelsRendered), ft.planMs = st.ellipsoids.planMs;
        opaque.draw(old, view, target.framebuffer());
        gl::glFinish();
        t0 = Clock::now();
        ft.beforeLightVolumes =
            before.render(old, view, target.framebuffer(), t, !old.objects.empty()).ellipsoids.lightVolumes;
        gl::glFinish();
        ft.beforeMs = msSince(t0);
        opaque.draw(scene, firstView, target.framebuffer());
        gl::glFinish();
        t0 = Clock::now();
        steady.update(0, firstWeather, firstView.eye);
        steady.draw(viewDescOf(firstView, target.framebuffer()));
        gl::glFinish();
        ft.steadyMs = msSince(t0);
        if (f >= 0) out.push_back(ft);
    }
    host.waitForBackgroundWork();
    return out;
}

std::string csvOf(const std::vector<FrameTime>& frames) {
    std::ostringstream csv;
    csv << "frame,ms,update_ms,draw_ms,before_ms,light_grids_finished,light_grids_pending,light_stand_ins,light_ms,"
           "cells_made,cells_pending,background_jobs,texture_uploads,layers_waiting,before_light_grids,far_field_ms,"
           "tiles_ms,"
           "composite_ms,passes,visible,tiles_rendered,tiles_must,tile_megapixels,impostors_rendered,plan_ms,light_"
           "uploads,atlas_grown,transition,major_faults,minor_faults,involuntary_switches,far_field_reused,far_field_"
           "kept,steady_ms,event\n";
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const FrameTime& f = frames[i];
        csv << i << "," << fmt("%.3f", f.ms) << "," << fmt("%.3f", f.updateMs) << "," << fmt("%.3f", f.ms - f.updateMs)
            << "," << fmt("%.3f", f.beforeMs) << "," << f.update.lightVolumes << "," << f.update.lightPending << ","
            << f.update.lightStandIns << "," << fmt("%.3f", f.update.lightMs) << "," << f.update.nearLod.generated
            << "," << f.update.nearLod.pending << "," << f.update.backgroundJobs << "," << f.uploads << ","
            << f.pendingLayers << "," << f.beforeLightVolumes << "," << fmt("%.3f", f.farFieldMs) << ","
            << fmt("%.3f", f.tilesMs) << "," << fmt("%.3f", f.compositeMs) << "," << f.passes << "," << f.visible << ","
            << f.tilesRendered << "," << f.tilesMust << "," << fmt("%.4f", f.tileMegapixels) << ","
            << f.impostorsRendered << "," << fmt("%.3f", f.planMs) << "," << f.lightUploads << "," << int(f.atlasGrown)
            << "," << fmt("%.3f", f.update.transition) << "," << f.majorFaults << "," << f.minorFaults << ","
            << f.involuntarySwitches << "," << int(f.farFieldReused) << "," << fmt("%.3f", f.farFieldKept) << ","
            << fmt("%.3f", f.steadyMs) << ",\"" << f.event << "\"\n";
    }
    return csv.str();
}

// The worst frame in [from, to).
std::size_t worstIn(const std::vector<double>& ms, std::size_t from, std::size_t to) {
    std::size_t w = from;
    for (std::size_t i = from; i < std::min(ms.size(), to); ++i)
        if (ms[i] > ms[w]) w = i;
    return w;
}

std::string summaryRow(const char* what, const std::vector<double>& ms) {
    const double med = median(ms);
    const std::size_t w = worstIn(ms, 0, ms.size());
    std::vector<double> sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    const double p95 = sorted[std::min(sorted.size() - 1, sorted.size() * 95 / 100)];
    const auto over = std::count_if(ms.begin(), ms.end(), [&](double x) { return x > 1.5 * med; });
    return std::string("| ") + what + " | " + fmt("%.1f", med) + " | " + fmt("%.2f", p95 / med) + " | " +
           fmt("%.1f", ms[w]) + " (" + std::to_string(w) + ") | " + fmt("%.2f", ms[w] / med) + " | " +
           std::to_string(over) + " |\n";
}

std::string markdownOf(const WeatherBenchOptions& o, const std::vector<FrameTime>& frames, const std::string& when,
                       const std::string& machine) {
    std::vector<double> ms, beforeMs, steadyMs;
    for (const FrameTime& f : frames)
        ms.push_back(f.ms), beforeMs.push_back(f.beforeMs), steadyMs.push_back(f.steadyMs);
    const double med = median(ms), beforeMed = median(beforeMs);
    std::ostringstream md;
    md << "Measured by `nephele bench --weather` on " << when << ", " << machine << ", at " << o.width << "x"
       << o.height << ": " << frames.size() << " frames of a flight through near_and_far.json (" << fmt("%.0f", o.speed)
       << " m/s along its heading, " << fmt("%.0f", o.fps)
       << " frames per second of simulated time) while the weather changes as below, each change ramping over "
       << fmt("%.1f", o.transition)
       << " s (Weather::transitionSeconds; a change during a ramp starts a new one from "
          "what is shown). A frame is SkyRenderer::update + "
          "draw of one channel, wall time to glFinish (the host's sky is drawn before the clock starts; the draw's "
          "parts "
          "are timed, a glFinish between them); before = the "
          "same frames with the one-call SkyRenderer::render of before, the same weather applied to its scene; the two "
          "take turns frame by frame, and with them a third renderer drawing the first frame again (its view and "
          "weather, the far field drawn afresh, the clouds' tiles kept: the same work every frame), whose spread is "
          "the machine's own in this run. The layers' lighting is computed, not loaded from a cache (the worst case). "
          "The clouds' radiance grids of new near-LOD clouds or a new sun are made on the worker thread, stand-ins "
          "lighting the clouds meanwhile (update() never waits for one; render() of before does).\n\n";
    md << "| | median ms | 95th percentile × median | worst ms (frame) | worst × median | frames over 1.5 × median "
          "|\n|---|---:|---:|---:|---:|---:|\n";
    md << summaryRow("update + draw", ms) << summaryRow("before: render()", beforeMs)
       << summaryRow("steady: the first frame again (the machine's floor)", steadyMs) << "\n";
    {
        const FrameTime& worst = frames[worstIn(ms, 0, ms.size())];
        md << "The worst frame by part (SkySettings::timings; the CSV has every frame's): update "
           << fmt("%.1f", worst.updateMs) << " ms, far field " << fmt("%.1f", worst.farFieldMs) << ", tiles "
           << fmt("%.1f", worst.tilesMs) << ", composite " << fmt("%.1f", worst.compositeMs) << " (" << worst.passes
           << " atlas passes, " << worst.visible << " ellipsoids visible; in the process, " << worst.majorFaults
           << " page faults that read the disk, " << worst.minorFaults << " that did not, " << worst.involuntarySwitches
           << " involuntary context switches).\n\n";
    }
    md << "Per change, the worst frame from it to the next change (at most 10 frames):\n\n";
    md << "| frame | change | update + draw ms | × median | × the 10 frames before | grids made on the worker (most "
          "pending) | "
          "cells made | before ms | × median |\n"
          "|---:|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (std::size_t i = 0; i < frames.size(); ++i) {
        if (frames[i].event.empty()) continue;
        std::size_t end = std::min(frames.size(), i + 10);
        for (std::size_t k = i + 1; k < end; ++k)
            if (!frames[k].event.empty()) end = k;
        const std::size_t w = worstIn(ms, i, end), b = worstIn(beforeMs, i, end);
        int volumes = 0, cells = 0, pending = 0;
        for (std::size_t k = i; k < end; ++k)
            volumes += frames[k].update.lightVolumes, cells += frames[k].update.nearLod.generated,
                pending = std::max(pending, frames[k].update.lightPending);
        // The frames just before the change: the same clouds in view, so that a stall shows
        // apart from what the flight itself brings into view.
        const std::vector<double> lead(ms.begin() + std::ptrdiff_t(i >= 10 ? i - 10 : 0),
                                       ms.begin() + std::ptrdiff_t(i));
        const std::string overLead = lead.empty() ? "" : fmt("%.2f", ms[w] / median(lead));
        md << "| " << i << " | " << frames[i].event << " | " << fmt("%.1f", ms[w]) << " | " << fmt("%.2f", ms[w] / med)
           << " | " << overLead << " | " << volumes << " (" << pending << ") | " << cells << " | "
           << fmt("%.1f", beforeMs[b]) << " | " << fmt("%.2f", beforeMs[b] / beforeMed) << " |\n";
    }
    md << "\n![ms per frame along the flight](weather_bench.png)\n";
    return md.str();
}

}  // namespace

int runWeatherBench(const WeatherBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    if (!(o.fps > 0 && o.fps <= 1000) || !(o.speed >= 0 && o.speed <= 1000) || o.frames < 20 || o.frames > 100000) {
        std::cerr << "nephele: bench --weather: --fps must be in (0, 1000], the speed in [0, 1000] m/s and --frames "
                     "20..100000\n";
        return 2;
    }
    std::vector<FrameTime> frames;
    std::string renderer;
    try {
        Scene scene = loadScene(o.bench.scenesDir + "/near_and_far.json");
        scene.camera.width = o.width, scene.camera.height = o.height;
        ContextOptions co;
        co.backend = o.bench.backend;
        auto context = Context::create(co);
        renderer = context->description();
        gl::setChecks(false);                                       // timing: no glGetError round trips
        frames = fly(o, scene, "", o.bench.quick ? 24 : o.frames);  // no lighting cache: computed, the worst case
        gl::setChecks(true);
        gl::checkAlways("bench --weather");
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench failed: " << e.what() << "\n";
        return 1;
    }
    const std::string when = utcNow();
    const std::string md = markdownOf(o, frames, when, machineLine(renderer));
    const std::string csvPath = (fs::path(o.bench.outDir) / "weather_bench.csv").string();
    const std::string mdPath = (fs::path(o.bench.outDir) / "weather_bench.md").string();
    const std::string pngPath = (fs::path(o.bench.outDir) / "weather_bench.png").string();
    try {
        writeTextFiles({{csvPath, csvOf(frames)}, {mdPath, generatedSection("weather bench", md)}});
        runPlot("plot_weather.py",
                {csvPath, std::string(kChartsFolder) + "/weather_bench.png", when,
                 std::to_string(o.width) + "x" + std::to_string(o.height)},
                o.bench.outDir, {"weather_bench.png"});
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench: " << e.what() << "\n";
        return 1;
    }
    std::cout << md;
    std::cerr << "nephele: bench wrote " << csvPath << ", " << mdPath << ", " << pngPath << "\n";
    return 0;
}

}  // namespace nephele::cli
