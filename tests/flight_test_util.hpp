// One compositor kept across frames (tiles that last, cloud impostors), for the GL tests that
// fly it: its frames, and how far two frames are apart.
#pragma once

#include "gl_test_util.hpp"

#include "nephele/camera.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/metrics.hpp"
#include "nephele/opaque.hpp"

#include <algorithm>
#include <string>

namespace nephele::test {

// One renderer kept across frames, drawing into its own target.
struct Flight {
    explicit Flight(const EllipsoidSettings& s, const Scene& scene)
        : clouds(s), target(scene.camera.width, scene.camera.height) {}
    Image frame(const Scene& scene, const Camera& camera) {
        const View view = makeView(camera);
        OpaquePass().draw(scene, view, target.framebuffer());
        last = clouds.render(scene, view, target.framebuffer(), false);
        return channels(target.readColor(), 0, 3);
    }
    EllipsoidRenderer clouds;
    FrameTarget target;
    EllipsoidStats last;
};

// PSNR of two frames, clamped to [0, 1] (what a display shows of them).
inline double db(const Image& a, const Image& b) { return psnr(clamped(a), clamped(b)); }

// The mean absolute change between two frames, clamped to [0, 1]: what the flicker index sums.
inline double meanChange(const Image& a, const Image& b) { return compareImages(clamped(a), clamped(b), 1).meanAbs; }

}  // namespace nephele::test
