// The layered sky drawn at a reduced resolution and upsampled with the frame's depth:
// internal to layered/ (LayeredSettings::downsample).
#pragma once

#include "nephele/camera.hpp"
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
    // Binds a (width/d) x (height/d) target (premultiplied RGBA16F cleared to 0, depth = the
    // frame's depth reduced per block; 1 when frameDepth is 0) as the draw framebuffer and
    // sets the viewport to it. Changes depth, blend, colour mask, program, vertex array,
    // texture unit 0. Returns the target's size.
    glm::ivec2 begin(GLuint frameDepth, int width, int height, int divisor);
    // Composites the target "over" `framebuffer` (premultiplied) at full resolution, the frame
    // multiplied by the cloud shadows set in program() (ShadowPass::setUniforms; none when
    // shadowLayerCount is 0) before. Changes the same state as begin() and texture units 0..2.
    // shadowLayers: how many layers program(shadowLayers) was given (0..4).
    void composite(GLuint framebuffer, GLuint frameDepth, const View& view, int shadowLayers);
    // The upsampling program compiled for `shadowLayers` shadowing layers (0..4; built on first use).
    const Program& program(int shadowLayers);

private:
    Program reduce_, upsample_[5];
    gl::VertexArray empty_;
    gl::Texture color_, depth_;
    gl::Framebuffer fbo_;
    glm::ivec2 size_{0}, full_{0};
    int divisor_ = 0;
};

}  // namespace nephele
