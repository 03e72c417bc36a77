#include "flythrough_command.hpp"

#include "output_files.hpp"

#include "nephele/log.hpp"
#include "nephele/metrics.hpp"
#include "nephele/png.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace fs = std::filesystem;

namespace nephele::cli {

int frameCount(double t0, double t1, double fps) {
    const double frames = std::floor((t1 - t0) * fps + 1e-9) + 1;  // in double: no int overflow
    if (!(frames >= 1 && frames <= kMaxFrames)) {
        char text[160];
        std::snprintf(text, sizeof text, "--fps %g: the path (t from %g to %g s) makes %.6g frames; at most %d", fps,
                      t0, t1, frames, kMaxFrames);
        throw UsageError(text);
    }
    return int(frames);
}

void FrameChanges::add(const Image& frame) {
    if (!last_.empty()) changes_.push_back(meanClampedDifference(last_, frame));
    last_ = frame;
}

double FrameChanges::mean() const {
    double sum = 0;
    for (double v : changes_) sum += v;
    return changes_.empty() ? 0 : sum / double(changes_.size());
}

namespace {

// What runFlythrough checks before it renders anything: the out-dir, the scene, the reference.
struct Prepared {
    Scene scene;
    std::string outDir;  // resolved (output_files.hpp)
    nlohmann::json reference;
    int frames = 0;
};

Prepared prepare(const FlythroughOptions& o) {
    Prepared p;
    if (!(o.fps >= 0.001 && o.fps <= 1000)) throw UsageError("--fps must be in 0.001..1000");
    p.outDir = resolveOutput("--out-dir", o.outDir, /*folder=*/true);
    p.scene = loadScene(o.render.scene);
    applySize(p.scene, o.render);
    checkFrameMemory(p.scene, o.render);
    if (p.scene.path.size() < 2)
        throw UsageError(o.render.scene + ": path: a fly-through needs a `path` of at least two keyframes");
    p.frames = frameCount(p.scene.path.front().t, p.scene.path.back().t, o.fps);
    if (o.referenceDir.empty()) return p;
    const fs::path summary = fs::path(o.referenceDir) / "flythrough.json";
    std::error_code ec;
    // A regular file of a summary's size: a FIFO or a device there would block or never end.
    if (!fs::is_regular_file(summary, ec) || fs::file_size(summary, ec) > (1u << 20))
        throw UsageError("--reference-dir: no flythrough.json (a regular file of at most 1 MB) in '" + o.referenceDir +
                         "'");
    std::ifstream in(summary);
    p.reference = nlohmann::json::parse(in, nullptr, false);
    if (p.reference.is_discarded() || !p.reference.is_object() || !p.reference.contains("mean_change") ||
        !p.reference["mean_change"].is_number())
        throw UsageError("--reference-dir: '" + o.referenceDir + "/flythrough.json' is not a fly-through summary");
    if (p.reference.value("frames", -1) != p.frames || p.reference.value("width", -1) != p.scene.camera.width ||
        p.reference.value("height", -1) != p.scene.camera.height)
        throw UsageError("--reference-dir: the reference has other frames or another size");
    return p;
}

// Renders every frame into `folder` (streamed: one frame in memory at a time) and returns the summary.
nlohmann::json renderFrames(const FlythroughOptions& o, const Prepared& p, const fs::path& folder) {
    const double t0 = p.scene.path.front().t;
    FrameRenderer renderer(o.render);
    FrameChanges changes;
    nlohmann::json ms = nlohmann::json::array(), tiles = nlohmann::json::array(), tilePixels = nlohmann::json::array();
    nlohmann::json impostors = nlohmann::json::array(), impostorsMade = nlohmann::json::array();
    nlohmann::json downsampled = nlohmann::json::array();
    nlohmann::json must = nlohmann::json::array(), repacked = nlohmann::json::array(), grown = nlohmann::json::array();
    nlohmann::json planMs = nlohmann::json::array(), tilesMs = nlohmann::json::array(),
                   compositeMs = nlohmann::json::array();
    for (int k = 0; k < p.frames; ++k) {
        const Frame f = renderer.render(p.scene, t0 + k / o.fps);
        ms.push_back(std::round(f.ms * 1000) / 1000);
        if (o.timings) {
            planMs.push_back(std::round(f.stats.planMs * 1000) / 1000);
            tilesMs.push_back(std::round(f.stats.tilesMs * 1000) / 1000);
            compositeMs.push_back(std::round(f.stats.compositeMs * 1000) / 1000);
        }
        tiles.push_back(f.stats.tilesRendered);
        tilePixels.push_back(f.stats.tilePixelsRendered);
        must.push_back(f.stats.tilesMust);
        impostors.push_back(f.stats.impostors);
        impostorsMade.push_back(f.stats.impostorsRendered);
        downsampled.push_back(f.stats.tilesDownsampled);
        if (f.stats.atlasRepacked) repacked.push_back(k);
        if (f.stats.atlasGrown) grown.push_back(k);
        char name[32];
        std::snprintf(name, sizeof name, "frame_%04d.png", k);
        writePng((folder / name).string(), f.color, Encoding::Srgb);
        changes.add(f.color);
        reportProgress("flythrough", double(k + 1) / p.frames);
    }
    nlohmann::json summary = {{"scene", o.render.scene},
                              {"method", methodName(o.render.method)},
                              {"fps", o.fps},
                              {"frames", p.frames},
                              {"width", p.scene.camera.width},
                              {"height", p.scene.camera.height},
                              {"mean_change", changes.mean()},
                              {"reuse", o.render.ellipsoid.reuse},
                              {"cloud_lod", o.render.ellipsoid.cloudLod},
                              {"impostors", impostors},
                              {"impostors_made", impostorsMade},
                              {"tiles_downsampled", downsampled},
                              {"frame_ms", ms},
                              {"tiles_rendered", tiles},
                              {"tile_pixels_rendered", tilePixels},
                              {"tiles_without_image", must},
                              {"atlas_repacked_frames", repacked},
                              {"atlas_grown_frames", grown}};
    if (o.timings) {
        summary["plan_ms"] = planMs;
        summary["tiles_ms"] = tilesMs;
        summary["composite_ms"] = compositeMs;
    }
    if (!p.reference.empty()) {
        summary["reference_mean_change"] = p.reference["mean_change"];
        summary["flicker_index"] = changes.mean() - p.reference["mean_change"].get<double>();
    }
    std::ofstream out(folder / "flythrough.json");
    out << summary.dump() << "\n";
    out.close();
    if (!out) throw std::runtime_error((folder / "flythrough.json").string() + ": write failed");
    return summary;
}

}  // namespace

int runFlythrough(const FlythroughOptions& o) {
    Prepared p;
    try {
        p = prepare(o);
    } catch (const std::exception& e) {
        return reportError(e, "preparing the fly-through");
    }
    std::string temp;
    try {
        removeStalePartials(p.outDir);
        temp = makePartial(p.outDir, /*folder=*/true);
        const nlohmann::json summary = renderFrames(o, p, temp);
        renameIntoPlace(temp, p.outDir, /*folder=*/true);
        std::cout << summary.dump() << "\n";
    } catch (const std::exception& e) {
        std::error_code ec;
        if (!temp.empty()) fs::remove_all(temp, ec);
        return reportError(e, "the fly-through");
    }
    return 0;
}

}  // namespace nephele::cli
