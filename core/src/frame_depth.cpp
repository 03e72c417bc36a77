#include "nephele/frame_depth.hpp"

namespace nephele {
using namespace gl;

DepthSource FrameDepth::source(const HostFrame& frame, const View& view) {
    if (!frame.hasDepth) return {};
    if (frame.depth.texture != 0) return frame.depth;
    GLint depthBits = 0;
    glGetNamedFramebufferAttachmentParameteriv(frame.framebuffer, frame.framebuffer == 0 ? GL_DEPTH : GL_DEPTH_ATTACHMENT,
                                               GL_FRAMEBUFFER_ATTACHMENT_DEPTH_SIZE, &depthBits);
    if (depthBits == 0) return {};
    return {copy(frame.framebuffer, view.origin.x, view.origin.y, view.camera.width, view.camera.height), glm::ivec2(0)};
}

GLuint FrameDepth::copy(GLuint framebuffer, int x, int y, int width, int height) {
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
        fbo_ = Framebuffer::create();
        glNamedFramebufferTexture(fbo_.id(), stencilBits ? GL_DEPTH_STENCIL_ATTACHMENT : GL_DEPTH_ATTACHMENT,
                                  texture_.id(), 0);
        width_ = width, height_ = height, format_ = format;
    }
    glDisable(GL_SCISSOR_TEST);  // a blit obeys the scissor test
    glBlitNamedFramebuffer(framebuffer, fbo_.id(), x, y, x + width, y + height, 0, 0, width, height, GL_DEPTH_BUFFER_BIT,
                           GL_NEAREST);
    check("copying the frame's depth");
    return texture_.id();
}

void setViewFrameUniforms(const Program& p, const View& view, bool drawsIntoFrame, const DepthSource& depth) {
    p.set("viewportOrigin", drawsIntoFrame ? glm::vec2(view.origin) : glm::vec2(0));
    p.set("viewDepth", glm::vec3(view.depthParameters()));
    p.set("depthOrigin", glm::vec2(depth.origin));
}

void bindFrame(const HostFrame& frame, const View& view) {
    glBindFramebuffer(GL_FRAMEBUFFER, frame.framebuffer);
    glViewport(view.origin.x, view.origin.y, view.camera.width, view.camera.height);
    frame.srgb ? glEnable(GL_FRAMEBUFFER_SRGB) : glDisable(GL_FRAMEBUFFER_SRGB);
}

void frameDepthTest(const View& view) {
    glClipControl(GL_LOWER_LEFT, view.depth.zeroToOne ? GL_ZERO_TO_ONE : GL_NEGATIVE_ONE_TO_ONE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(view.depth.reversedZ ? GL_GREATER : GL_LESS);
}

}  // namespace nephele
