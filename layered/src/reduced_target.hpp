// The layered sky drawn at a reduced resolution and upsampled with the frame's depth:
// internal to layered/ (LayeredSettings::downsample).
#pragma once

#include "nephele/camera.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/per_view.hpp"
#include "nephele/shader.hpp"

namespace nephele {

// llvmpipe runs a fragment shader to its end whatever it discards, so the layers cost their
// covered pixels times N times the whole shader: drawing them at 1/d of the resolution divides
// that by d^2. The frame's depth is reduced per d x d block to its farthest value (so that the
// layers are computed wherever any pixel of the block sees past the objects); the upsampling
// takes, per full-resolution pixel, the bilinear neighbours whose block depth matches its own
// (nearest-depth upsampling), so that an object's silhouette stays sharp.
class ReducedTarget {
public:
    ReducedTarget();  // builds its shaders in the current context
    // Binds a (width/d) x (height/d) target for the view's viewport (premultiplied RGBA16F
    // cleared to 0, depth = the frame's depth reduced per block, in the view's convention; the
    // far plane without depth) as the draw framebuffer and sets the viewport to it. Changes
    // depth, blend, colour mask, program, vertex array, texture unit 0. Returns its size.
    glm::ivec2 begin(const DepthSource& frameDepth, const View& view, int divisor);
    // Composites the target "over" the frame's viewport (premultiplied) at full resolution, the
    // frame multiplied by the cloud shadows set in program() (ShadowPass::setUniforms; none when
    // shadowLayerCount is 0) before. Changes the same state as begin() and texture units 0..2.
    // shadowLayers: how many layers program(shadowLayers) was given (0..4).
    void composite(const HostFrame& frame, const DepthSource& frameDepth, const View& view, int shadowLayers);
    // The upsampling program compiled for `shadowLayers` shadowing layers (0..4; built on first
    // use, or by prepare()).
    const Program& program(int shadowLayers);
    void prepare();  // builds every upsampling program now

private:
    struct Target {  // at one reduced size (views of several sizes each keep theirs)
        gl::Texture color, depth;
        gl::Framebuffer fbo;
    };
    Program reduce_, upsample_[5];
    gl::VertexArray empty_;
    PerViewCache<Target> targets_;
    Target* current_ = nullptr;  // begin()'s
    glm::ivec2 size_{0}, full_{0};
};

}  // namespace nephele
