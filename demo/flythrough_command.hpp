#pragma once

#include "render_command.hpp"

#include <string>

namespace nephele::cli {

struct FlythroughOptions {
    RenderOptions render;       // scene, method, size, backend, compositor settings (output fields unused)
    std::string outDir;         // must not exist yet, or be empty
    double fps = 10;            // frames per second of scene time
    std::string referenceDir;   // a reference run's out-dir: also report the flicker index
};

// Frame-to-frame changes of a sequence: per consecutive pair, the mean absolute difference
// of linear RGB clamped to [0, 1] (size frames - 1).
std::vector<double> frameChanges(const std::vector<Image>& frames);
// Their mean (0 for fewer than two frames).
double meanFrameChange(const std::vector<Image>& frames);

// `nephele flythrough`: renders the scene's `path` to OUT-DIR/frame_NNNN.png and writes
// OUT-DIR/flythrough.json with the mean frame-to-frame change (and, with a reference run,
// the flicker index: this method's mean change minus the reference's). Returns the exit code.
int runFlythrough(const FlythroughOptions& options);

}  // namespace nephele::cli
