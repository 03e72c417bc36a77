// A copy of a frame's depth, to sample while the frame's own depth stays attached to the
// framebuffer being drawn (sampling an attached texture would be a feedback loop).
// Matches the frame's depth format, so that a blit can copy it, including the default
// framebuffer of a host's window.
#pragma once

#include "nephele/gl.hpp"

namespace nephele {

class FrameDepth {
public:
    // Copies the depth of `framebuffer` (width x height) and returns the copy's texture.
    GLuint copy(GLuint framebuffer, int width, int height);
    GLuint texture() const { return texture_.id(); }

private:
    gl::Texture texture_;
    gl::Framebuffer fbo_;
    int width_ = 0, height_ = 0;
    GLenum format_ = 0;
};

}  // namespace nephele
