#include "flythrough_command.hpp"

#include "nephele/metrics.hpp"
#include "nephele/png.hpp"

#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace fs = std::filesystem;

namespace nephele::cli {

std::vector<double> frameChanges(const std::vector<Image>& frames) {
    std::vector<double> out;
    for (std::size_t k = 1; k < frames.size(); ++k) out.push_back(meanClampedDifference(frames[k - 1], frames[k]));
    return out;
}

double meanFrameChange(const std::vector<Image>& frames) {
    const std::vector<double> c = frameChanges(frames);
    double sum = 0;
    for (double v : c) sum += v;
    return c.empty() ? 0 : sum / double(c.size());
}

int runFlythrough(const FlythroughOptions& o) {
    Scene scene;
    nlohmann::json reference;
    std::error_code ec;
    try {
        if (!(std::isfinite(o.fps) && o.fps > 0 && o.fps <= 1000)) throw UsageError("--fps must be in (0, 1000]");
        if (fs::exists(o.outDir) && !(fs::is_directory(o.outDir) && fs::is_empty(o.outDir, ec)))
            throw UsageError("--out-dir '" + o.outDir + "' exists and is not an empty folder");
        const fs::path parent = fs::absolute(o.outDir).parent_path();
        if (!fs::is_directory(parent)) throw UsageError("--out-dir: folder '" + parent.string() + "' does not exist");
        scene = loadScene(o.render.scene);
        applySize(scene, o.render);
        if (scene.path.size() < 2)
            throw UsageError(o.render.scene + ": path: a fly-through needs a `path` of at least two keyframes");
        if (!o.referenceDir.empty()) {
            std::ifstream in(fs::path(o.referenceDir) / "flythrough.json");
            if (!in) throw UsageError("--reference-dir: no flythrough.json in '" + o.referenceDir + "'");
            reference = nlohmann::json::parse(in, nullptr, false);
            if (reference.is_discarded() || !reference.contains("mean_change"))
                throw UsageError("--reference-dir: '" + o.referenceDir + "/flythrough.json' is not a fly-through summary");
        }
    } catch (const std::exception& e) {
        return reportError(e, "preparing the fly-through");
    }

    const double t0 = scene.path.front().t, t1 = scene.path.back().t;
    const int count = int(std::floor((t1 - t0) * o.fps + 1e-9)) + 1;
    if (count > 100000) {
        std::cerr << "nephele: the path at --fps " << o.fps << " makes " << count << " frames (at most 100000)\n";
        return 2;
    }
    if (!reference.empty() && (reference.value("frames", -1) != count || reference.value("width", -1) != scene.camera.width ||
                               reference.value("height", -1) != scene.camera.height)) {
        std::cerr << "nephele: --reference-dir: the reference has other frames or another size\n";
        return 2;
    }
    // Frames go to a temporary folder beside the target, renamed into place at the end.
    const fs::path out = fs::absolute(o.outDir);
    const fs::path temp = out.string() + ".partial-" + std::to_string(::getpid());
    std::vector<Image> frames;
    try {
        fs::create_directories(temp);
        FrameRenderer renderer(o.render);
        for (int k = 0; k < count; ++k) {
            const Frame f = renderer.render(scene, t0 + k / o.fps);
            char name[32];
            std::snprintf(name, sizeof name, "frame_%04d.png", k);
            writePng((temp / name).string(), f.color, Encoding::Srgb);
            frames.push_back(f.color);
            std::cerr << "\rnephele: frame " << k + 1 << "/" << count << std::flush;
        }
        std::cerr << "\n";
        nlohmann::json summary = {{"scene", o.render.scene}, {"method", methodName(o.render.method)},
                                  {"fps", o.fps},           {"frames", count},
                                  {"width", scene.camera.width}, {"height", scene.camera.height},
                                  {"mean_change", meanFrameChange(frames)}};
        if (!reference.empty()) {
            summary["reference_mean_change"] = reference["mean_change"];
            summary["flicker_index"] = summary["mean_change"].get<double>() - reference["mean_change"].get<double>();
        }
        std::ofstream(temp / "flythrough.json") << summary.dump() << "\n";
        if (fs::exists(out)) fs::remove(out);
        fs::rename(temp, out);
        std::cout << summary.dump() << "\n";
    } catch (const std::exception& e) {
        fs::remove_all(temp, ec);
        std::cerr << "\nnephele: fly-through failed: " << e.what() << "\n";
        return 1;
    }
    return 0;
}

}  // namespace nephele::cli
