#pragma once

#include "render_command.hpp"

#include <string>
#include <vector>

namespace nephele::cli {

struct FlythroughOptions {
    RenderOptions render;      // scene, method, size, backend, compositor settings (output fields unused)
    std::string outDir;        // must not exist yet, or be an empty folder (a symlink to one is written through)
    double fps = 10;           // frames per second of scene time, (0, 1000]
    std::string referenceDir;  // a reference run's out-dir: also report the flicker index
    bool timings = false;      // --timings: the compositor's plan, tile and composite ms per frame in
                               // flythrough.json (EllipsoidSettings::timings: a glFinish between the
                               // parts, so the frames are a little slower)
};

// At most this many frames per sequence (fly-throughs and the flicker bench).
inline constexpr int kMaxFrames = 100000;

// The frames t0 + k / fps for k = 0, 1, ... up to t1: their count. Throws UsageError naming
// --fps and the limit when the count is over kMaxFrames (or not a number).
int frameCount(double t0, double t1, double fps);

// The frame-to-frame change of a sequence, fed one frame at a time (only the last frame is
// kept): per consecutive pair, the mean absolute difference of linear RGB clamped to [0, 1].
class FrameChanges {
public:
    void add(const Image& frame);
    const std::vector<double>& changes() const { return changes_; }  // frames - 1 values
    double mean() const;                                             // 0 for fewer than two frames

private:
    Image last_;
    std::vector<double> changes_;
};

// `nephele flythrough`: renders the scene's `path` to OUT-DIR/frame_NNNN.png and writes
// OUT-DIR/flythrough.json with the mean frame-to-frame change (and, with a reference run,
// the flicker index: this method's mean change minus the reference's). Frames are streamed
// to a temporary folder beside OUT-DIR (renamed into place at the end; output_files.hpp), so
// memory does not grow with the frame count. Returns the exit code.
int runFlythrough(const FlythroughOptions& options);

}  // namespace nephele::cli
