#include "nephele/frame_depth.hpp"

#include "nephele/gl_state.hpp"

#include <cstdint>
#include <string>

namespace nephele {
using namespace gl;

namespace {

GLint attachmentParameter(GLuint framebuffer, GLenum attachment, GLenum pname) {
    GLint v = 0;
    glGetNamedFramebufferAttachmentParameteriv(framebuffer, attachment, pname, &v);
    return v;
}

// The depth (and stencil) format of `framebuffer`, GL_NONE when it has no depth. A blit of depth
// needs equal formats on both sides, so the copy takes the attachment's own internal format
// (a texture's or a renderbuffer's); the default framebuffer, and unsized formats, are read
// from the attachment's sizes. Attachments are asked for their sizes only when there is one:
// asking an empty attachment point (a depth buffer without stencil) is GL_INVALID_OPERATION.
GLenum depthFormatOf(GLuint framebuffer) {
    const GLenum depth = framebuffer == 0 ? GL_DEPTH : GL_DEPTH_ATTACHMENT;
    const GLenum stencil = framebuffer == 0 ? GL_STENCIL : GL_STENCIL_ATTACHMENT;
    const GLint type = attachmentParameter(framebuffer, depth, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE);
    if (type == GL_NONE) return GL_NONE;
    GLint format = GL_NONE;
    const auto name = [&] {
        return GLuint(attachmentParameter(framebuffer, depth, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_NAME));
    };
    if (type == GL_TEXTURE) {
        const GLint level = attachmentParameter(framebuffer, depth, GL_FRAMEBUFFER_ATTACHMENT_TEXTURE_LEVEL);
        glGetTextureLevelParameteriv(name(), level, GL_TEXTURE_INTERNAL_FORMAT, &format);
    } else if (type == GL_RENDERBUFFER) {
        glGetNamedRenderbufferParameteriv(name(), GL_RENDERBUFFER_INTERNAL_FORMAT, &format);
    }
    switch (format) {
        case GL_DEPTH_COMPONENT16:
        case GL_DEPTH_COMPONENT24:
        case GL_DEPTH_COMPONENT32:
        case GL_DEPTH_COMPONENT32F:
        case GL_DEPTH24_STENCIL8:
        case GL_DEPTH32F_STENCIL8: return GLenum(format);
        default: break;
    }
    const GLint bits = attachmentParameter(framebuffer, depth, GL_FRAMEBUFFER_ATTACHMENT_DEPTH_SIZE);
    if (bits == 0) return GL_NONE;
    const bool isFloat = attachmentParameter(framebuffer, depth, GL_FRAMEBUFFER_ATTACHMENT_COMPONENT_TYPE) == GL_FLOAT;
    const bool hasStencil =
        attachmentParameter(framebuffer, stencil, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE) != GL_NONE &&
        attachmentParameter(framebuffer, stencil, GL_FRAMEBUFFER_ATTACHMENT_STENCIL_SIZE) > 0;
    if (isFloat) return hasStencil ? GL_DEPTH32F_STENCIL8 : GL_DEPTH_COMPONENT32F;
    if (hasStencil) return GL_DEPTH24_STENCIL8;
    return bits <= 16 ? GL_DEPTH_COMPONENT16 : bits <= 24 ? GL_DEPTH_COMPONENT24 : GL_DEPTH_COMPONENT32;
}

std::uint64_t bytesPerTexel(GLenum format) {
    switch (format) {
        case GL_DEPTH_COMPONENT16: return 2;
        case GL_DEPTH32F_STENCIL8: return 8;
        default: return 4;
    }
}

}  // namespace

DepthSource FrameDepth::source(const HostFrame& frame, const View& view) {
    if (!frame.hasDepth) return {};
    if (frame.depth.texture != 0) return frame.depth;
    if (depthFormatOf(frame.framebuffer) == GL_NONE) return {};
    return {copy(frame.framebuffer, view.origin.x, view.origin.y, view.camera.width, view.camera.height),
            glm::ivec2(0)};
}

GLuint FrameDepth::copy(GLuint framebuffer, int x, int y, int width, int height) {
    const GLenum format = depthFormatOf(framebuffer);
    if (format == GL_NONE)
        throw GlError("the host's framebuffer " + std::to_string(framebuffer) + " has no depth buffer to copy");
    check("reading the depth format of the host's framebuffer");
    if (width_ != width || height_ != height || format_ != format) {
        texture_ = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(texture_.id(), 1, format, width, height);
        checkAllocation("the copy of the frame's depth",
                        std::uint64_t(width) * std::uint64_t(height) * bytesPerTexel(format));
        fbo_ = Framebuffer::create();
        const bool stencil = format == GL_DEPTH24_STENCIL8 || format == GL_DEPTH32F_STENCIL8;
        glNamedFramebufferTexture(fbo_.id(), stencil ? GL_DEPTH_STENCIL_ATTACHMENT : GL_DEPTH_ATTACHMENT, texture_.id(),
                                  0);
        checkFramebuffer(fbo_.id(), "the copy of the frame's depth");
        width_ = width, height_ = height, format_ = format;
    }
    glDisable(GL_SCISSOR_TEST);  // a blit obeys the scissor test
    glBlitNamedFramebuffer(framebuffer, fbo_.id(), x, y, x + width, y + height, 0, 0, width, height,
                           GL_DEPTH_BUFFER_BIT, GL_NEAREST);
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
    if (frame.framebuffer != 0 || frame.drawBuffer != GL_NONE) {
        GLint first = GL_NONE;
        glGetIntegerv(GL_DRAW_BUFFER0, &first);
        const GLenum target = frame.drawBuffer != GL_NONE ? frame.drawBuffer : GLenum(first);
        const std::string name = "the host's framebuffer " + std::to_string(frame.framebuffer);
        if (target == GL_NONE)
            throw GlError(name +
                          ": its draw buffer 0 is GL_NONE; name the colour attachment to draw into "
                          "(ViewDesc::drawBuffer)");
        if (frame.framebuffer != 0) {
            if (target < GL_COLOR_ATTACHMENT0 || target >= GL_COLOR_ATTACHMENT0 + 32)
                throw GlError(name + ": draw buffer " + std::to_string(target) + " is not a GL_COLOR_ATTACHMENTi");
            GLint type = GL_NONE;
            glGetNamedFramebufferAttachmentParameteriv(frame.framebuffer, target, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE,
                                                       &type);
            if (type == GL_NONE)
                throw GlError(name + ": GL_COLOR_ATTACHMENT" + std::to_string(target - GL_COLOR_ATTACHMENT0) +
                              ", its draw buffer, has no image attached");
        }
        HostStateScope::selectDrawBuffer(frame.framebuffer, target);
    }
    glViewport(view.origin.x, view.origin.y, view.camera.width, view.camera.height);
    frame.srgb ? glEnable(GL_FRAMEBUFFER_SRGB) : glDisable(GL_FRAMEBUFFER_SRGB);
}

void frameDepthTest(const View& view) {
    glClipControl(GL_LOWER_LEFT, view.depth.zeroToOne ? GL_ZERO_TO_ONE : GL_NEGATIVE_ONE_TO_ONE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(view.depth.reversedZ ? GL_GREATER : GL_LESS);
}

}  // namespace nephele
