// The cloud-shadow pass of the layered sky (Wang et al. eq. 19): internal to layered/.
#pragma once

#include "nephele/camera.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/layered.hpp"
#include "nephele/shader.hpp"

#include <vector>

namespace nephele {

// Why a pass over the finished frame rather than a term in the opaque pass's shaders: the
// shadow then falls on whatever the frame's depth holds (Nephele's objects, or a host
// simulator's own terrain and aircraft, whose shaders Nephele does not own), core stays free
// of any layered code, and the opaque pass and its golden images are untouched. It costs one
// full-screen pass per shadowing layer (sky pixels are discarded) and a copy of the depth.
class ShadowPass {
public:
    ShadowPass();  // builds its shader in the current context
    // Multiplies the rgb of `framebuffer` (alpha untouched) by each layer's S, eq. (19), at
    // every surface point below the layer's middle: depth < 1 pixels (whole colour) and the
    // ground plane z = groundHeight for depth-1 pixels below the horizon (the sun's share of
    // it, groundSunShare()). modulationTextures[i] is scene layer i's texture. Expects the
    // caller to hold a GlStateGuard; changes blend, depth, program, vertex array, texture
    // units 0 and 1. Returns the draw calls issued (0 when no layer can shadow).
    int draw(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds,
             const std::vector<GLuint>& modulationTextures, const ModulationSettings& modulation,
             double groundHeight);

private:
    Program program_;
    gl::VertexArray empty_;
    FrameDepth depth_;
};

}  // namespace nephele
