#include "nephele/frame_depth.hpp"

namespace nephele {
using namespace gl;

GLuint FrameDepth::copy(GLuint framebuffer, int width, int height) {
    GLint depthBits = 0, stencilBits = 0, type = 0;
    const GLenum depth = framebuffer == 0 ? GL_DEPTH : GL_DEPTH_ATTACHMENT;
    const GLenum stencil = framebuffer == 0 ? GL_STENCIL : GL_STENCIL_ATTACHMENT;
    glGetNamedFramebufferAttachmentParameteriv(framebuffer, depth, GL_FRAMEBUFFER_ATTACHMENT_DEPTH_SIZE, &depthBits);
    glGetNamedFramebufferAttachmentParameteriv(framebuffer, depth, GL_FRAMEBUFFER_ATTACHMENT_COMPONENT_TYPE, &type);
    glGetNamedFramebufferAttachmentParameteriv(framebuffer, stencil, GL_FRAMEBUFFER_ATTACHMENT_STENCIL_SIZE, &stencilBits);
    if (depthBits == 0) throw GlError("the frame has no depth buffer to copy");
    const GLenum format = type == GL_FLOAT ? (stencilBits ? GL_DEPTH32F_STENCIL8 : GL_DEPTH_COMPONENT32F)
                          : depthBits == 16 ? GL_DEPTH_COMPONENT16
                          : stencilBits     ? GL_DEPTH24_STENCIL8
                                            : GL_DEPTH_COMPONENT24;
    if (width_ != width || height_ != height || format_ != format) {
        texture_ = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(texture_.id(), 1, format, width, height);
        checkAllocation("the copy of the frame's depth", std::uint64_t(width) * std::uint64_t(height) * (depthBits + stencilBits) / 8);
        fbo_ = Framebuffer::create();
        glNamedFramebufferTexture(fbo_.id(), stencilBits ? GL_DEPTH_STENCIL_ATTACHMENT : GL_DEPTH_ATTACHMENT,
                                  texture_.id(), 0);
        checkFramebuffer(fbo_.id(), "the copy of the frame's depth");
        width_ = width, height_ = height, format_ = format;
    }
    glBlitNamedFramebuffer(framebuffer, fbo_.id(), 0, 0, width, height, 0, 0, width, height, GL_DEPTH_BUFFER_BIT,
                           GL_NEAREST);
    check("copying the frame's depth");
    return texture_.id();
}

}  // namespace nephele
