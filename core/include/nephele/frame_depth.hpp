// The frame a renderer draws into (a host's framebuffer and its depth), and reading its
// depth: a copy, to sample while the frame's own depth stays attached to the framebuffer
// being drawn (sampling an attached texture would be a feedback loop), or the host's own
// depth texture. A copy matches the frame's depth format, so that a blit can copy it,
// including the default framebuffer of a host's window.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/shader.hpp"

NEPHELE_API_BEGIN
namespace nephele {

// A depth texture to read the view's depth from, and the texel of the view's pixel (0, 0).
struct DepthSource {
    GLuint texture = 0;  // 0: no depth (every pixel is "no surface")
    glm::ivec2 origin{0};
};

// Where a renderer draws (ViewDesc's framebuffer, depth and colour, resolved).
struct HostFrame {
    GLuint framebuffer = 0;       // its draw buffer `drawBuffer`: rgb radiance "over", alpha the cloud opacity
    GLenum drawBuffer = GL_NONE;  // the colour attachment drawn into; GL_NONE: the framebuffer's draw buffer 0
    bool hasDepth = true;         // false: the frame has no depth to respect
    DepthSource depth;            // its depth when already at hand (the host's depth texture, or a copy made for
                                  // this view); texture 0: copied from the framebuffer's when a pass needs it
    bool srgb = false;            // the colour attachment is sRGB: GL_FRAMEBUFFER_SRGB on while writing it
    bool cloudShadows = true;     // the layers' cloud shadows darken the frame's surfaces and the ground below
                                  // the horizon (LayeredSettings::shadows permitting)
};

class FrameDepth {
public:
    // The depth of `frame` for `view`: frame.depth when it has a texture, else a copy of the
    // framebuffer's depth in the view's viewport, else none (hasDepth false, or no depth
    // buffer). Call inside a HostStateScope (a blit obeys the scissor test).
    DepthSource source(const HostFrame& frame, const View& view);
    // Copies the depth of `framebuffer` in the rectangle (x, y, width, height) to a texture of
    // that size and returns it. Throws GlError if the framebuffer has no depth.
    GLuint copy(GLuint framebuffer, int x, int y, int width, int height);
    GLuint texture() const { return texture_.id(); }

private:
    gl::Texture texture_;
    gl::Framebuffer fbo_;
    int width_ = 0, height_ = 0;
    GLenum format_ = 0;
};

// Sets the uniforms of shaders/view_frame.glsl in `program`: the viewport's origin (of the
// view in the frame when the pass draws into it, else 0: an internal target at the view's
// size), the depth convention and where `depth` puts the view's pixels.
void setViewFrameUniforms(const Program& program, const View& view, bool drawsIntoFrame, const DepthSource& depth = {});

// Binds `frame.framebuffer` and sets the view's viewport in it, with GL_FRAMEBUFFER_SRGB as
// the frame needs it, and its draw buffer `frame.drawBuffer` as its only draw buffer (restored
// by the HostStateScope it is called in). Throws GlError naming the framebuffer when that draw
// buffer is GL_NONE or has no image attached.
void bindFrame(const HostFrame& frame, const View& view);
// The depth test of geometry drawn with view.projectionMatrix against the frame's depth: the
// frame's clip control and GL_LESS, or GL_GREATER with reversed Z (inside a HostStateScope).
void frameDepthTest(const View& view);

}  // namespace nephele
NEPHELE_API_END
