// `nephele bench --grids`: what a cloud's radiance grid costs to make and to keep (issue #10:
// "state its cost per cloud in ms, and its memory"). Per cloud of each shared scene, the wall
// time of computeCloudRadiance with the default settings, median of --frames runs, and the
// bytes it holds (radianceGridBytes: CPU and GPU). No GL: the grids are made on the CPU, on
// every core, as a still image or waitForLights makes them (a frame loop makes them on one
// worker thread at the lowest priority instead, beside the frames).
#include "bench_command.hpp"

#include "bench_util.hpp"

#include "nephele/cloud_radiance.hpp"
#include "nephele/scene.hpp"

#include <algorithm>
#include <iostream>
#include <map>
#include <sstream>


namespace nephele::cli {

namespace {

struct GridRow {
    std::string scene;
    int cloud = 0, ellipsoids = 0, size = 0;
    double opticalRadius = 0, ms = 0, megabytes = 0;
};

std::vector<GridRow> measureGrids(const GridBenchOptions& o) {
    std::vector<GridRow> rows;
    const RadianceGridSettings settings;
    for (const std::string& name : o.scenes) {
        const Scene scene = loadScene(o.bench.scenesDir + "/" + name);
        for (int c = 0; c < int(scene.clouds.size()); ++c) {
            const Cloud& cloud = scene.clouds[c];
            GridRow r;
            r.scene = name, r.cloud = c, r.ellipsoids = int(cloud.ellipsoids.size());
            r.opticalRadius = cloudOpticalRadius(scene, cloud);
            std::vector<double> ms;
            for (int k = 0; k < o.runs; ++k) {
                const CloudRadiance grid = computeCloudRadiance(scene, cloud, settings);
                ms.push_back(grid.computeMs);
                r.size = grid.size;
            }
            r.ms = median(ms);
            r.megabytes = double(radianceGridBytes(r.size)) / 1048576.0;
            rows.push_back(r);
        }
        std::cerr << "bench --grids: " << name << " done\n";
    }
    return rows;
}

std::string gridMarkdown(const GridBenchOptions& o, const std::vector<GridRow>& rows, const std::string& when) {
    std::ostringstream md;
    md << "Measured by `nephele bench --grids` on " << when << ", "
       << machineLine("no GL (the grids are made on the CPU)")
       << ". Per cloud: the wall time of `computeCloudRadiance` with the default `RadianceGridSettings` (the grid "
          "fitted to the cloud's optical radius, at most 32³; 2¹⁸ photons from the sun and as many from the sky at "
          "32³, in proportion to the cross-section below), median of "
       << o.runs
       << " runs, on every core; memory = `radianceGridBytes` (the CPU's floats and the GPU's half floats, "
          "the sun's transmittance on its grid twice as fine).\n\n";
    md << "| scene | clouds | grids | ms per cloud (median, largest) | ms in all | MB in all "
          "|\n|---|---:|---|---:|---:|---:|\n";
    for (const std::string& name : o.scenes) {
        std::vector<double> ms;
        std::map<int, int> sizes;
        double total = 0, megabytes = 0;
        for (const GridRow& r : rows)
            if (r.scene == name) ms.push_back(r.ms), total += r.ms, megabytes += r.megabytes, ++sizes[r.size];
        if (ms.empty()) continue;
        std::string grids;
        for (const auto& [size, n] : sizes)
            grids += (grids.empty() ? "" : ", ") + std::to_string(n) + " × " + std::to_string(size) + "³";
        md << "| `" << name << "` | " << ms.size() << " | " << grids << " | " << fmt("%.1f", median(ms)) << ", "
           << fmt("%.1f", *std::max_element(ms.begin(), ms.end())) << " | " << fmt("%.0f", total) << " | "
           << fmt("%.2f", megabytes) << " |\n";
    }
    return md.str();
}

}  // namespace

int runGridBench(const GridBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    std::vector<GridRow> rows;
    try {
        rows = measureGrids(o);
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench --grids failed: " << e.what() << "\n";
        return 1;
    }
    const std::string md = gridMarkdown(o, rows, utcNow());
    std::ostringstream csv;
    csv << "scene,cloud,ellipsoids,optical_radius,size,ms,mb\n";
    for (const GridRow& r : rows)
        csv << r.scene << "," << r.cloud << "," << r.ellipsoids << "," << fmt("%.2f", r.opticalRadius) << "," << r.size
            << "," << fmt("%.2f", r.ms) << "," << fmt("%.4f", r.megabytes) << "\n";
    return publishTextBench("bench --grids", o.bench.outDir, "grid bench", "grid_bench", csv.str(), md);
}

}  // namespace nephele::cli
