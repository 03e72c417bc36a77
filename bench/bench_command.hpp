#pragma once

#include "nephele/context.hpp"
#include "nephele/scene.hpp"

#include <string>
#include <vector>

namespace nephele::cli {

// Every bench writes into its outDir (default bench-out/, never the repository's docs/): its CSV,
// its charts and STEM.md, its generated section; `bench --publish docs` puts the sections into
// docs/benchmarks.md (bench_util.hpp).
struct BenchOptions {
    std::string outDir = "bench-out";  // CSV, markdown section and chart go here
    std::vector<int> counts{1, 4, 16, 64, 256, 1024, 4096};
    int frames = 5;                   // measured frames per method and count (median reported)
    int width = 1280, height = 720;
    bool accuracy = true;             // also measure the accuracy figures on the shared scenes
    std::string scenesDir = "data/scenes";
    GlBackend backend = GlBackend::Egl;
};

// A deterministic field of `count` ellipsoids in clouds of up to 16, spread over the view
// of a width x height camera at 3 to 9 km.
Scene benchScene(int count, int width, int height);

// The `bench` command: returns the exit code.
int runBench(const BenchOptions& options);

// `bench --accuracy`: speed against error for every method and a sweep of its settings.
struct AccuracyOptions {
    std::string outDir = "bench-out";  // accuracy.csv, accuracy.md, accuracy_chart.png, accuracy_distance.png
    std::string scenesDir = "data/scenes";
    std::string cacheDir;         // path-traced references are cached here ("" = none)
    int width = 320;              // px: every case is rendered this wide (aspect kept)
    int referenceSpp = 1024;      // at most, samples per pixel of the reference's sun part (the sky part: a quarter)
    double referenceNoise = 0.03; // the reference is traced until its own noise is at most this (relative RMSE)
    int block = 4;                // errors are measured on block x block pixel means (averages the
                                  // reference's noise down by `block`)
    int frames = 5;               // timed frames per GPU setting (median)
    bool quick = false;           // one scene, two distances, defaults only (for tests)
    std::vector<std::string> noiseModes{"0", "scene"};  // "0": medium.noise 0; "scene": the scenes' noise
    GlBackend backend = GlBackend::Egl;
};
int runAccuracyBench(const AccuracyOptions& options);

// `bench --flicker`: the stability of each method along camera paths (flythrough.json's path and
// approach.json's 5 km run into a cumulus): mean frame-to-frame change against the exact model's.
struct FlickerOptions {
    std::string outDir = "bench-out";  // flicker.csv, flicker.md, flicker.png
    std::string scenesDir = "data/scenes";
    int width = 160;              // px (aspect kept)
    double fps = 4;               // frames per second of scene time
    bool quick = false;           // approach.json only, 1 fps (for tests)
    GlBackend backend = GlBackend::Egl;
};
int runFlickerBench(const FlickerOptions& options);

// `bench --silhouette`: the box-counting dimension of the alpha > 0.5 silhouette of cumulus27 and
// dense_cumulus, detail off and on, from 100 m, 1 km and 5 km, for the compositor and the ray-marcher.
struct SilhouetteBenchOptions {
    std::string outDir = "bench-out";  // silhouette_bench.csv, silhouette_bench.md
    std::string scenesDir = "data/scenes";
    int width = 640;              // px (aspect kept): the measurements were at 640 x 480
    double erosion = 1.5;         // medium.detail.erosion of the "on" column
    bool quick = false;           // dense_cumulus from 1 km only (for tests)
    GlBackend backend = GlBackend::Egl;
};
int runSilhouetteBench(const SilhouetteBenchOptions& options);

// `bench --queries`: microseconds per call of SkyRenderer's cloud queries (densityAt, transmittance
// over 1 and 10 km, insideCloud) on the scenes, beside the path tracer's own field at the same points.
struct QueryBenchOptions {
    std::string outDir = "bench-out";  // query_bench.csv, query_bench.md
    std::string scenesDir = "data/scenes";
    std::vector<std::string> scenes{"detailed_cumulus.json", "near_and_far.json", "showcase.json"};
    int points = 2000;            // query points per scene
    double radius = 3000;         // m: the points' horizontal distance from the camera, at most
    GlBackend backend = GlBackend::Egl;
};
int runQueryBench(const QueryBenchOptions& options);

// `bench --layered`: the layered far field against its floor over the extent and the annulus
// count N, with the cloud-shadow pass's share and the renderer before its speed work.
struct LayeredBenchOptions {
    std::string outDir = "bench-out";  // layered_bench.csv, layered_bench.md, layered_bench.png
    std::string scenesDir = "data/scenes";
    std::string cacheDir;         // lighting volumes are cached here ("" = none)
    std::vector<int> counts{2, 4, 8, 16, 32};     // N, annuli per layer
    std::vector<double> extents{20000, 90000};    // m, the layer's extent
    int frames = 5;               // timed frames per variant (median)
    int width = 1280, height = 720;
    bool quick = false;           // 20 km, N = 2 and 8, one frame (for tests)
    GlBackend backend = GlBackend::Egl;
};
int runLayeredBench(const LayeredBenchOptions& options);

// `bench --weather`: frame times along a flight while the weather changes (coverage, base,
// thickness, wind, the sun), SkyRenderer's update + draw against the one-call render().
struct WeatherBenchOptions {
    std::string outDir = "bench-out";  // weather_bench.csv, weather_bench.md, weather_bench.png
    std::string scenesDir = "data/scenes";
    int frames = 240;             // frames of the flight
    double fps = 30;              // frames per second of simulated time
    double speed = 60;            // m/s along the scene camera's heading
    double transition = 2;        // s, each change's Weather::transitionSeconds (0: at once)
    int width = 1280, height = 720;
    bool quick = false;           // 24 frames, small lighting volumes (for tests)
    GlBackend backend = GlBackend::Egl;
};
int runWeatherBench(const WeatherBenchOptions& options);

// `bench --scale`: load, plan and draw time and peak memory of each fast method (and the CPU
// model at a thumbnail size) from 10^4 to 10^6 ellipsoids, and the growth exponent.
struct ScaleBenchOptions {
    std::string outDir = "bench-out";  // scale_bench.csv, scale_bench.md
    std::vector<int> counts{10000, 100000, 1000000};
    int width = 1280, height = 720;
    int exactWidth = 64;          // gardner-exact's image width (px; the height keeps the aspect)
    GlBackend backend = GlBackend::Egl;
};
int runScaleBench(const ScaleBenchOptions& options);

// `bench --grids`: per cloud of the shared scenes, the time to make its radiance grid and the
// memory it holds (bench/grid_bench.cpp).
struct GridBenchOptions {
    std::string outDir = "bench-out";  // grid_bench.csv, grid_bench.md
    std::string scenesDir = "data/scenes";
    std::vector<std::string> scenes{"single.json", "two_clouds.json", "cumulus27.json", "showcase.json", "field1000.json"};
    int runs = 3;                 // per cloud (median)
};
int runGridBench(const GridBenchOptions& options);

}  // namespace nephele::cli

namespace nephele::cli {

// `bench --cruise`: tiles that last (--reuse on) against every tile every frame on flights
// (cruise.json, cruise_turn.json, approach.json, flythrough.json, layer_flight.json): ms per
// frame, tiles rendered, PSNR against the fresh frame, flicker.
struct CruiseBenchOptions {
    std::string outDir = "bench-out";  // cruise_bench.csv, cruise_bench.md, cruise_bench.png
    std::string scenesDir = "data/scenes";
    double fps = 10;              // frames per second of scene time
    int width = 1280, height = 720;
    bool quick = false;           // approach.json's first second only (for tests)
    std::vector<std::string> flights;  // only these scene files of the five (empty: all)
    GlBackend backend = GlBackend::Egl;
};
int runCruiseBench(const CruiseBenchOptions& options);

}  // namespace nephele::cli
