// Drawing at a reduced resolution, upsampled over the frame with the frame's depth: the layered
// sky's layers (LayeredSettings::downsample) and the compositor's close tiles magnified on
// screen (EllipsoidSettings::closeDownsample). For the libraries' use, not a host's.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/per_view.hpp"
#include "nephele/shader.hpp"

#include <string>

NEPHELE_API_BEGIN
namespace nephele {

// llvmpipe runs a fragment shader to its end whatever it discards, so the layers cost their
// covered pixels times N times the whole shader: drawing them at 1/d of the resolution divides
// that by d^2. The frame's depth is reduced per d x d block to its farthest value (so that the
// layers are computed wherever any pixel of the block sees past the objects); the upsampling
// takes, per full-resolution pixel, the bilinear neighbours whose block depth matches its own
// (nearest-depth upsampling), so that an object's silhouette stays sharp.
// The layers one shadow pass (or one fused upsampling) shadows at most: the size of the sampler
// and uniform arrays of shaders/layered_shadow.glsl, given to it as SHADOW_SLOTS.
inline constexpr int kMaxShadowLayers = 4;
inline std::string shadowSlotsDefine() { return "#define SHADOW_SLOTS " + std::to_string(kMaxShadowLayers) + "\n"; }

class ReducedTarget {
public:
    ReducedTarget();  // builds its shaders in the current context
    // Binds a (width/d) x (height/d) target for the view's viewport (premultiplied RGBA16F
    // cleared to 0, depth = the frame's depth reduced per block, in the view's convention; the
    // far plane without depth) as the draw framebuffer and sets the viewport to it. Changes
    // depth, blend, colour mask, scissor, program, vertex array, texture unit 0. Returns its size.
    glm::ivec2 begin(const DepthSource& frameDepth, const View& view, int divisor);
    // After begin() (and composite()): binds the target's colour again (without its depth, which
    // a pass may then read through depth()) cleared to 0 within `rect` (reduced px: x0, y0, x1,
    // y1), the scissor left on that rectangle, depth test off. Changes the same state as begin().
    void resume(const glm::ivec4& rect);
    // The reduced depth (the target's, at its own origin): what a pass drawing into the target
    // reads as the frame's depth (setViewFrameUniforms with a viewport at 0).
    DepthSource depth() const;
    // Composites the target "over" the frame's viewport (premultiplied) at full resolution, the
    // frame multiplied by the cloud shadows set in program(shadowLayers, frameDepth.texture != 0)
    // (the layered sky's ShadowPass::
    // setUniforms; none when shadowLayers is 0) before; within `rect` (px of the view: x0, y0,
    // x1, y1) when given. Changes the same state as begin() and texture units 0..2.
    // shadowLayers: how many layers program(shadowLayers) was given (0..4).
    void composite(const HostFrame& frame, const DepthSource& frameDepth, const View& view, int shadowLayers,
                   const glm::ivec4* rect = nullptr);
    // The upsampling program compiled for `shadowLayers` shadowing layers (0..4) and a frame with
    // depth or without (built on first use, or by prepare()).
    const Program& program(int shadowLayers, bool depth);
    void prepare();  // builds every upsampling program now

private:
    struct Target {  // at one reduced size (views of several sizes each keep theirs)
        gl::Texture color, depth;
        gl::Framebuffer fbo;
        gl::Framebuffer colorOnly;  // resume()'s: the colour alone
    };
    Program reduce_, upsample_[kMaxShadowLayers + 1][2];
    gl::VertexArray empty_;
    PerViewCache<Target> targets_;
    Target* current_ = nullptr;  // begin()'s
    glm::ivec2 size_{0}, full_{0};
};

}  // namespace nephele
NEPHELE_API_END
