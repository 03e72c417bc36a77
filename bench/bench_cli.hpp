// `nephele bench`: its flags as typed on the command line, and the one bench they run
// (bench_command.hpp). The flags every bench shares fill one BenchOptions; a bench's own
// flags fill its options struct.
#pragma once

#include "bench_command.hpp"

#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace nephele::cli {

struct BenchArgs {
    BenchOptions common;  // --out-dir, --scenes, --quick; --gl and --cache below
    std::string gl = "egl", cache;
    bool noCache = false;
    // The bench to run instead of the ellipsoid bench: at most one.
    bool accuracy = false, layerAccuracy = false, flicker = false, silhouette = false, queries = false;
    bool layered = false, weather = false, cruise = false, scale = false, grids = false;
    std::string publish;  // --publish DOCS: no bench, the sections of --out-dir into DOCS
    // Each bench's own flags, where the command line puts them.
    EllipsoidBenchOptions bo;                // --counts, --frames, --width, --height, --no-exact
    AccuracyOptions ao;                      // --noise-modes, --reference-noise, --spp
    FlickerOptions flo;                      // --fps
    LayeredBenchOptions lbo;                 // --layer-counts, --extents
    WeatherBenchOptions wbo;                 // --transition
    ScaleBenchOptions sbo;                   // --scale-counts
    std::vector<std::string> cruiseFlights;  // --flights
    CLI::App* cmd = nullptr;
};

// Adds the `bench` subcommand to `app`, its flags parsed into `args`.
CLI::App* addBenchCommand(CLI::App& app, BenchArgs& args);
// Runs what the flags ask for; returns the exit code (2 for flags that do not go together).
int runBenchCommand(BenchArgs& args);

}  // namespace nephele::cli
