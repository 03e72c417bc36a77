// The benches of `nephele bench` (bench_cli.hpp parses their flags): each takes the options
// every bench shares (BenchOptions) and its own.
#pragma once

#include "nephele/context.hpp"
#include "nephele/scene.hpp"

#include <string>
#include <vector>

namespace nephele::cli {

// What every bench takes: where it writes, what it reads, how it draws. Every bench writes into
// its outDir (default bench-out/, never the repository's docs/): its CSV, its charts and STEM.md,
// its generated section; `bench --publish docs` puts the sections into docs/benchmarks.md
// (bench_util.hpp).
struct BenchOptions {
    std::string outDir = "bench-out";       // --out-dir
    std::string scenesDir = "data/scenes";  // --scenes: the shared scenes
    std::string cacheDir;                   // path-traced references and lighting volumes ("" = none)
    GlBackend backend = GlBackend::Egl;     // --gl
    bool quick = false;                     // --quick: a minimal run (for tests)
};

// `bench`: the ellipsoid compositor against its floor and baseline.
struct EllipsoidBenchOptions {
    BenchOptions bench;
    std::vector<int> counts{1, 4, 16, 64, 256, 1024, 4096};
    int frames = 5;  // measured frames per method and count (median reported)
    int width = 1280, height = 720;
    bool accuracy = true;  // also measure the accuracy figures on the shared scenes
};

// A deterministic field of `count` ellipsoids in clouds of up to 16, spread over the view
// of a width x height camera at 3 to 9 km.
Scene benchScene(int count, int width, int height);

// The `bench` command: returns the exit code.
int runBench(const EllipsoidBenchOptions& options);

// `bench --accuracy`: speed against error for every method and a sweep of its settings.
struct AccuracyOptions {
    // accuracy.csv, accuracy.md, accuracy_chart.png, accuracy_distance.png; quick: one scene, two
    // distances, defaults only.
    BenchOptions bench;
    int width = 320;               // px: every case is rendered this wide (aspect kept)
    int referenceSpp = 1024;       // at most, samples per pixel of the reference's sun part (the sky part: a quarter)
    double referenceNoise = 0.03;  // the reference is traced until its own noise is at most this (relative RMSE)
    int block = 4;                 // errors are measured on block x block pixel means (averages the
                                   // reference's noise down by `block`)
    int frames = 5;                // timed frames per GPU setting (median)
    std::vector<std::string> noiseModes{"0", "scene"};  // "0": medium.noise 0; "scene": the scenes' noise
};
int runAccuracyBench(const AccuracyOptions& options);

// `bench --flicker`: the stability of each method along camera paths (flythrough.json's path and
// approach.json's 5 km run into a cumulus): mean frame-to-frame change against the exact model's.
struct FlickerOptions {
    BenchOptions bench;  // flicker.csv, flicker.md, flicker.png; quick: approach.json only, 1 fps
    int width = 160;     // px (aspect kept)
    double fps = 4;      // frames per second of scene time
};
int runFlickerBench(const FlickerOptions& options);

// `bench --silhouette`: the box-counting dimension of the alpha > 0.5 silhouette of cumulus27 and
// dense_cumulus, detail off and on, from 100 m, 1 km and 5 km, for the compositor and the ray-marcher.
struct SilhouetteBenchOptions {
    BenchOptions bench;    // silhouette_bench.csv, silhouette_bench.md; quick: dense_cumulus from 1 km only
    int width = 640;       // px (aspect kept): the measurements were at 640 x 480
    double erosion = 1.5;  // medium.detail.erosion of the "on" column
};
int runSilhouetteBench(const SilhouetteBenchOptions& options);

// `bench --queries`: microseconds per call of SkyRenderer's cloud queries (densityAt, transmittance
// over 1 and 10 km, insideCloud) on the scenes, beside the path tracer's own field at the same points.
struct QueryBenchOptions {
    BenchOptions bench;  // query_bench.csv, query_bench.md
    std::vector<std::string> scenes{"detailed_cumulus.json", "near_and_far.json", "showcase.json"};
    int points = 2000;     // query points per scene
    double radius = 3000;  // m: the points' horizontal distance from the camera, at most
};
int runQueryBench(const QueryBenchOptions& options);

// `bench --layered`: the layered far field against its floor over the extent and the annulus
// count N, with the cloud-shadow pass's share and the renderer before its speed work.
struct LayeredBenchOptions {
    // layered_bench.csv, .md, .png; cacheDir: lighting volumes; quick: 20 km, N = 2 and 8, one frame.
    BenchOptions bench;
    std::vector<int> counts{2, 4, 8, 16, 32};   // N, annuli per layer
    std::vector<double> extents{20000, 90000};  // m, the layer's extent
    int frames = 5;                             // timed frames per variant (median)
    int width = 1280, height = 720;
};
int runLayeredBench(const LayeredBenchOptions& options);

// `bench --weather`: frame times along a flight while the weather changes (coverage, base,
// thickness, wind, the sun), SkyRenderer's update + draw against the one-call render().
struct WeatherBenchOptions {
    BenchOptions bench;     // weather_bench.csv, .md, .png; quick: 24 frames, small lighting volumes
    int frames = 240;       // frames of the flight
    double fps = 30;        // frames per second of simulated time
    double speed = 60;      // m/s along the scene camera's heading
    double transition = 2;  // s, each change's Weather::transitionSeconds (0: at once)
    int width = 1280, height = 720;
};
int runWeatherBench(const WeatherBenchOptions& options);

// `bench --scale`: load, plan and draw time and peak memory of each fast method (and the CPU
// model at a thumbnail size) from 10^4 to 10^6 ellipsoids, and the growth exponent.
struct ScaleBenchOptions {
    BenchOptions bench;  // scale_bench.csv, scale_bench.md (no scenes: it makes its own)
    std::vector<int> counts{10000, 100000, 1000000};
    int width = 1280, height = 720;
    int exactWidth = 64;  // gardner-exact's image width (px; the height keeps the aspect)
};
int runScaleBench(const ScaleBenchOptions& options);

// `bench --grids`: per cloud of the shared scenes, the time to make its radiance grid and the
// memory it holds (bench/grid_bench.cpp).
struct GridBenchOptions {
    BenchOptions bench;  // grid_bench.csv, grid_bench.md (no GL)
    std::vector<std::string> scenes{"single.json",           "two_clouds.json", "cumulus27.json", "dense_cumulus.json",
                                    "detailed_cumulus.json", "showcase.json",   "field1000.json"};
    int runs = 3;  // per cloud (median)
};
int runGridBench(const GridBenchOptions& options);

}  // namespace nephele::cli

namespace nephele::cli {

// `bench --cruise`: tiles that last (--reuse on) against every tile every frame on flights
// (cruise.json, cruise_turn.json, approach.json, flythrough.json, layer_flight.json): ms per
// frame, tiles rendered, PSNR against the fresh frame, flicker.
struct CruiseBenchOptions {
    BenchOptions bench;  // cruise_bench.csv, .md, .png; quick: approach.json's first second only
    double fps = 10;     // frames per second of scene time
    int width = 1280, height = 720;
    std::vector<std::string> flights;  // only these scene files of the five (empty: all)
};
int runCruiseBench(const CruiseBenchOptions& options);

}  // namespace nephele::cli
