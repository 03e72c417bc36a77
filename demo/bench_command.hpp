#pragma once

#include "nephele/context.hpp"
#include "nephele/scene.hpp"

#include <string>
#include <vector>

namespace nephele::cli {

struct BenchOptions {
    std::string outDir = "docs";      // CSV, markdown table and chart go here
    std::string readme;               // when set, the generated section of this README is replaced
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

}  // namespace nephele::cli
