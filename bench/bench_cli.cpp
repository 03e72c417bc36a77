#include "bench_cli.hpp"

#include "bench_util.hpp"
#include "cache_dir.hpp"
#include "cli_checks.hpp"
#include "layer_accuracy.hpp"
#include "render_command.hpp"

#include "nephele/limits.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <utility>

namespace nephele::cli {

namespace {

bool given(const BenchArgs& b, const char* flag) { return b.cmd->count(flag) > 0; }

// --width and --height over a bench's own frame size: --width alone sets the height at 16:9.
void giveSize(const BenchArgs& b, int& width, int& height) {
    if (given(b, "--width")) width = b.bo.width, height = std::max(16, int(std::lround(b.bo.width * 9.0 / 16.0)));
    if (given(b, "--height")) height = b.bo.height;
}

// Each bench's options from the flags: the shared ones, then those it takes of the others.
int runEllipsoidArgs(const BenchArgs& b) {
    EllipsoidBenchOptions o = b.bo;
    o.bench = b.common;
    return runBench(o);
}

int runAccuracyArgs(const BenchArgs& b) {
    AccuracyOptions o = b.ao;
    o.bench = b.common, o.frames = b.bo.frames;
    if (given(b, "--width")) o.width = b.bo.width;
    return runAccuracyBench(o);
}

int runLayerAccuracyArgs(const BenchArgs& b) {
    LayerAccuracyOptions o;
    o.bench = b.common, o.frames = b.bo.frames;
    if (given(b, "--width")) o.width = b.bo.width;
    if (given(b, "--spp")) o.referenceSpp = b.ao.referenceSpp;
    if (given(b, "--out-dir")) o.imageDir = b.common.outDir;  // the views' images
    return runLayerAccuracyBench(o);
}

int runLayeredArgs(const BenchArgs& b) {
    LayeredBenchOptions o = b.lbo;
    o.bench = b.common, o.frames = b.bo.frames;
    const bool widthGiven = given(b, "--width"), heightGiven = given(b, "--height");
    if (widthGiven) o.width = b.bo.width;
    if (heightGiven) o.height = b.bo.height;
    if (widthGiven != heightGiven) {  // one alone keeps the 16:9 aspect
        if (widthGiven) o.height = std::max(16, int(std::lround(o.width * 9.0 / 16.0)));
        else o.width = std::max(16, int(std::lround(o.height * 16.0 / 9.0)));
    }
    if (b.common.quick && !widthGiven && !heightGiven) o.width = 320, o.height = 180;
    return runLayeredBench(o);
}

int runWeatherArgs(const BenchArgs& b) {
    WeatherBenchOptions o = b.wbo;
    o.bench = b.common;
    if (given(b, "--frames")) o.frames = b.bo.frames;
    if (given(b, "--fps")) o.fps = b.flo.fps;
    giveSize(b, o.width, o.height);
    if (b.common.quick && !given(b, "--width")) o.width = 320, o.height = 180;
    return runWeatherBench(o);
}

int runCruiseArgs(const BenchArgs& b) {
    CruiseBenchOptions o;
    o.bench = b.common;
    o.flights = b.cruiseFlights;
    if (given(b, "--fps")) o.fps = b.flo.fps;
    giveSize(b, o.width, o.height);
    if (b.common.quick && !given(b, "--width")) o.width = 160, o.height = 90;
    return runCruiseBench(o);
}

int runScaleArgs(const BenchArgs& b) {
    ScaleBenchOptions o = b.sbo;
    o.bench = b.common;
    if (b.common.quick) {  // --scale-counts given with it wins
        if (!given(b, "--scale-counts")) o.counts = {16, 160};
        o.width = 320, o.height = 180, o.exactWidth = 32;
    }
    if (given(b, "--width")) o.width = b.bo.width;
    if (given(b, "--height")) o.height = b.bo.height;
    return runScaleBench(o);
}

int runGridArgs(const BenchArgs& b) {
    GridBenchOptions o;
    o.bench = b.common;
    if (given(b, "--frames")) o.runs = b.bo.frames;
    if (b.common.quick) o.scenes = {"single.json"}, o.runs = 1;
    return runGridBench(o);
}

int runQueryArgs(const BenchArgs& b) {
    QueryBenchOptions o;
    o.bench = b.common;
    if (b.common.quick) o.scenes = {"near_and_far.json"}, o.points = 200;
    return runQueryBench(o);
}

int runSilhouetteArgs(const BenchArgs& b) {
    SilhouetteBenchOptions o;
    o.bench = b.common;
    if (given(b, "--width")) o.width = b.bo.width;
    return runSilhouetteBench(o);
}

int runFlickerArgs(const BenchArgs& b) {
    FlickerOptions o = b.flo;
    o.bench = b.common;
    if (given(b, "--width")) o.width = b.bo.width;
    return runFlickerBench(o);
}

// The benches a flag asks for instead of the ellipsoid bench, each with what runs it.
std::vector<std::pair<bool, int (*)(const BenchArgs&)>> modes(const BenchArgs& b) {
    return {{b.accuracy, runAccuracyArgs},
            {b.layerAccuracy, runLayerAccuracyArgs},
            {b.layered, runLayeredArgs},
            {b.weather, runWeatherArgs},
            {b.cruise, runCruiseArgs},
            {b.scale, runScaleArgs},
            {b.grids, runGridArgs},
            {b.queries, runQueryArgs},
            {b.silhouette, runSilhouetteArgs},
            {b.flicker, runFlickerArgs}};
}

}  // namespace

CLI::App* addBenchCommand(CLI::App& app, BenchArgs& b) {
    const CLI::Validator path = nonEmptyPath();
    CLI::App* bench = b.cmd =
        app.add_subcommand("bench", "Time the ellipsoid compositor against its floor and baseline");
    bench
        ->add_option("--out-dir", b.common.outDir,
                     "Folder for the CSV, the chart and the markdown (the generated section for docs/benchmarks.md)")
        ->check(path)
        ->capture_default_str();
    bench
        ->add_option("--publish", b.publish,
                     "Instead: put the generated sections in --out-dir into DOCS/benchmarks.md between their markers, "
                     "and copy their CSVs and charts into DOCS (the docs/ regeneration step)")
        ->check(path);
    bench->add_option("--counts", b.bo.counts, "Ellipsoid counts")->check(within(1, 1000000))->capture_default_str();
    bench->add_option("--frames", b.bo.frames, "Measured frames per point (median)")
        ->check(within(1, 1000))
        ->capture_default_str();
    bench->add_option("--width", b.bo.width, "Frame width")->check(within(16, kMaxImageSize))->capture_default_str();
    bench->add_option("--height", b.bo.height, "Frame height")->check(within(16, kMaxImageSize))->capture_default_str();
    bench->add_flag("!--no-exact", b.bo.accuracy, "Skip the GPU-vs-gardner-exact figures on the shared scenes");
    bench->add_option("--scenes", b.common.scenesDir, "Folder of the shared scenes")
        ->check(path)
        ->capture_default_str();
    bench->add_flag(
        "--accuracy", b.accuracy,
        "Instead: speed against error vs the path-traced reference, every method and a sweep of its settings");
    bench->add_flag("--flicker", b.flicker,
                    "Instead: frame-to-frame change along camera paths against the exact model");
    bench->add_flag(
        "--silhouette", b.silhouette,
        "Instead: box-counting dimension of the cumulus silhouettes, detail off and on, from 100 m to 5 km");
    bench->add_flag(
        "--queries", b.queries,
        "Instead: microseconds per call of the host's cloud queries (densityAt, transmittance, insideCloud)");
    bench->add_flag("--layered", b.layered,
                    "Instead: the layered far field against its floor over --extents and --layer-counts (N)");
    bench->add_flag(
        "--layer-accuracy", b.layerAccuracy,
        "Instead: the layered sky and auto's hand-off against the path tracer on views of near_and_far.json's "
        "layer (its section into --out-dir, with the views' images when --out-dir is given; --width, "
        "--frames, --spp, --cache)");
    bench->add_flag(
        "--weather", b.weather,
        "Instead: frame times of a flight while the weather changes (coverage, base, thickness, wind, sun)");
    bench->add_flag(
        "--cruise", b.cruise,
        "Instead: --reuse on against off on flights (a 4000-ellipsoid cruise, a sharp turn, approach, flythrough, "
        "layer_flight): ms per frame, tiles rendered, PSNR against every tile fresh");
    bench->add_option("--flights", b.cruiseFlights,
                      "--cruise: only these flights (scene file names; cruise_detail: the cruise with the detail)");
    bench->add_flag("--scale", b.scale,
                    "Instead: load, plan and draw time and peak memory from 10^4 to 10^6 ellipsoids (--scale-counts)");
    bench->add_flag("--grids", b.grids,
                    "Instead: per cloud of the shared scenes, the ms to make its radiance grid and the MB it holds");
    bench->add_option("--scale-counts", b.sbo.counts, "--scale: ellipsoid counts")
        ->check(within(1, limits::kEllipsoids.value))
        ->capture_default_str();
    bench->add_option("--layer-counts", b.lbo.counts, "--layered: annuli per layer (N)")
        ->check(within(2, 1024))
        ->capture_default_str();
    bench->add_option("--extents", b.lbo.extents, "--layered: layer extents (m)")
        ->check(within(1000, 1e6))
        ->capture_default_str();
    bench
        ->add_option("--noise-modes", b.ao.noiseModes,
                     "--accuracy: 0 (medium.noise 0), scene (the scenes' noise), or both")
        ->check(CLI::IsMember({"0", "scene"}))
        ->capture_default_str();
    bench
        ->add_option("--reference-noise", b.ao.referenceNoise,
                     "--accuracy: trace the reference until its own noise is at most this")
        ->check(within(0.001, 0.5))
        ->capture_default_str();
    bench
        ->add_option("--spp", b.ao.referenceSpp,
                     "--accuracy: the most samples per pixel of the reference; --layer-accuracy: its sun part's (256)")
        ->check(within(1, 1 << 20))
        ->capture_default_str();
    bench->add_option("--fps", b.flo.fps, "--flicker, --weather, --cruise: frames per second of scene time")
        ->check(within(0.01, 1000))
        ->capture_default_str();
    bench
        ->add_option("--transition", b.wbo.transition,
                     "--weather: seconds each weather change ramps over (Weather::transitionSeconds; 0: at once)")
        ->check(within(0, 3600))
        ->capture_default_str();
    bench
        ->add_option(
            "--cache", b.cache,
            "--accuracy, --layer-accuracy: reference cache folder (default $NEPHELE_CACHE, else ~/.cache/nephele)")
        ->check(path);
    bench->add_flag("--no-cache", b.noCache, "--accuracy, --layer-accuracy: do not read or write the reference cache");
    bench->add_flag(
        "--quick", b.common.quick,
        "--accuracy/--layer-accuracy/--flicker/--layered/--weather/--scale/--cruise/--grids/--queries: a minimal run "
        "(one scene, defaults; --layered and --weather with a coarse layer lighting; for tests)");
    bench->add_option("--gl", b.gl, "egl or osmesa")->check(CLI::IsMember({"egl", "osmesa"}));
    return bench;
}

int runBenchCommand(BenchArgs& b) {
    b.common.backend = parseBackend(b.gl);
    b.common.cacheDir = b.noCache ? "" : defaultCacheDir(b.cache);
    const auto benches = modes(b);
    const auto asked = std::count_if(benches.begin(), benches.end(), [](const auto& m) { return m.first; });
    if (asked > 1) {
        std::cerr
            << "nephele: bench: --accuracy, --layer-accuracy, --flicker, --layered, --weather, --scale, --cruise, "
               "--grids, --silhouette and --queries are separate runs; give one\n";
        return 2;
    }
    if (!b.publish.empty()) {
        if (asked > 0) {
            std::cerr << "nephele: bench: --publish runs no bench: it publishes what --out-dir holds; give it alone\n";
            return 2;
        }
        return publishBenchSections(b.common.outDir, b.publish);
    }
    for (const auto& [ask, run] : benches)
        if (ask) return run(b);
    return runEllipsoidArgs(b);
}

}  // namespace nephele::cli
