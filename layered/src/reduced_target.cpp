#include "reduced_target.hpp"

#include <stdexcept>
#include <string>

namespace nephele {
using namespace gl;

ReducedTarget::ReducedTarget() {
    reduce_ = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "layered_depth_reduce.frag"}});
    empty_ = VertexArray::create();
}

const Program& ReducedTarget::program(int shadowLayers) {
    if (shadowLayers < 0 || shadowLayers > 4) throw std::invalid_argument("ReducedTarget: shadowLayers must be 0..4");
    Program& p = upsample_[shadowLayers];
    if (p.id() == 0)
        p = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "layered_upsample.frag"}},
                           "#define SHADOW_LAYERS " + std::to_string(shadowLayers) + "\n");
    return p;
}

void ReducedTarget::prepare() {
    for (int layers = 0; layers <= 4; ++layers) program(layers);
}

glm::ivec2 ReducedTarget::begin(const DepthSource& frameDepth, const View& view, int divisor) {
    const int width = view.camera.width, height = view.camera.height;
    const glm::ivec2 size((width + divisor - 1) / divisor, (height + divisor - 1) / divisor);
    Target& t = targets_.get(size);
    if (!t.fbo) {
        t.color = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(t.color.id(), 1, GL_RGBA16F, size.x, size.y);
        glTextureParameteri(t.color.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(t.color.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(t.color.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(t.color.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        t.depth = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(t.depth.id(), 1, GL_DEPTH_COMPONENT32F, size.x, size.y);
        glTextureParameteri(t.depth.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTextureParameteri(t.depth.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glTextureParameteri(t.depth.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(t.depth.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        t.fbo = Framebuffer::create();
        glNamedFramebufferTexture(t.fbo.id(), GL_COLOR_ATTACHMENT0, t.color.id(), 0);
        glNamedFramebufferTexture(t.fbo.id(), GL_DEPTH_ATTACHMENT, t.depth.id(), 0);
        const GLenum status = glCheckNamedFramebufferStatus(t.fbo.id(), GL_FRAMEBUFFER);
        if (status != GL_FRAMEBUFFER_COMPLETE)
            throw GlError("layered sky: reduced target incomplete (status 0x" + std::to_string(status) + ")");
    }
    current_ = &t;
    size_ = size;
    full_ = glm::ivec2(width, height);
    glBindFramebuffer(GL_FRAMEBUFFER, t.fbo.id());
    glViewport(0, 0, size.x, size.y);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_BLEND);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    const float zero[4] = {0, 0, 0, 0};
    glClearNamedFramebufferfv(t.fbo.id(), GL_COLOR, 0, zero);
    glDepthMask(GL_TRUE);
    if (frameDepth.texture == 0) {
        const float far = float(view.farDepth());
        glClearNamedFramebufferfv(t.fbo.id(), GL_DEPTH, 0, &far);
        return size;
    }
    // Each texel's depth = the farthest of its block of the frame (written, always passing).
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_ALWAYS);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    reduce_.set("frameDepth", 0);
    reduce_.set("fullSize", glm::vec2(full_));
    reduce_.set("reducedSize", glm::vec2(size));
    setViewFrameUniforms(reduce_, view, false, frameDepth);
    glBindTextureUnit(0, frameDepth.texture);
    glBindSampler(0, 0);
    glUseProgram(reduce_.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    check("reducing the frame's depth for the layered sky");
    return size;
}

void ReducedTarget::composite(const HostFrame& frame, const DepthSource& frameDepth, const View& view, int shadowLayers) {
    bindFrame(frame, view);
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_FALSE);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ONE, GL_SRC1_ALPHA);  // cloud + frame * keep
    const Program& p = program(shadowLayers);
    p.set("cloud", 0);
    p.set("cloudDepth", 1);
    p.set("frameDepth", 2);
    p.set("hasDepth", frameDepth.texture != 0 ? 1 : 0);
    p.set("scale", glm::vec2(size_) / glm::vec2(full_));
    setViewFrameUniforms(p, view, true, frameDepth);
    glBindTextureUnit(0, current_->color.id());
    glBindTextureUnit(1, current_->depth.id());
    glBindTextureUnit(2, frameDepth.texture);
    for (int u = 0; u < 3; ++u) glBindSampler(u, 0);
    glUseProgram(p.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    check("upsampling the layered sky");
}

}  // namespace nephele
