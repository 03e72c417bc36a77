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

glm::ivec2 ReducedTarget::begin(GLuint frameDepth, int width, int height, int divisor) {
    const glm::ivec2 size((width + divisor - 1) / divisor, (height + divisor - 1) / divisor);
    if (size != size_ || fbo_.id() == 0) {
        color_ = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(color_.id(), 1, GL_RGBA16F, size.x, size.y);
        checkAllocation("the layered sky's reduced RGBA16F target", std::uint64_t(size.x) * std::uint64_t(size.y) * 8);
        glTextureParameteri(color_.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(color_.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(color_.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(color_.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        depth_ = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(depth_.id(), 1, GL_DEPTH_COMPONENT32F, size.x, size.y);
        checkAllocation("the layered sky's reduced depth", std::uint64_t(size.x) * std::uint64_t(size.y) * 4);
        glTextureParameteri(depth_.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTextureParameteri(depth_.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glTextureParameteri(depth_.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(depth_.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        fbo_ = Framebuffer::create();
        glNamedFramebufferTexture(fbo_.id(), GL_COLOR_ATTACHMENT0, color_.id(), 0);
        glNamedFramebufferTexture(fbo_.id(), GL_DEPTH_ATTACHMENT, depth_.id(), 0);
        checkFramebuffer(fbo_.id(), "the layered sky's reduced target");
        size_ = size;
    }
    full_ = glm::ivec2(width, height);
    divisor_ = divisor;
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_.id());
    glViewport(0, 0, size.x, size.y);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_BLEND);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    const float zero[4] = {0, 0, 0, 0};
    glClearNamedFramebufferfv(fbo_.id(), GL_COLOR, 0, zero);
    glDepthMask(GL_TRUE);
    if (frameDepth == 0) {
        const float one = 1;
        glClearNamedFramebufferfv(fbo_.id(), GL_DEPTH, 0, &one);
        return size;
    }
    // Each texel's depth = the farthest of its block of the frame (written, always passing).
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_ALWAYS);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    reduce_.set("frameDepth", 0);
    reduce_.set("fullSize", glm::vec2(full_));
    reduce_.set("reducedSize", glm::vec2(size));
    glBindTextureUnit(0, frameDepth);
    glBindSampler(0, 0);
    glUseProgram(reduce_.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    check("reducing the frame's depth for the layered sky");
    return size;
}

void ReducedTarget::composite(GLuint framebuffer, GLuint frameDepth, const View& view, int shadowLayers) {
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    glViewport(0, 0, full_.x, full_.y);
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
    p.set("hasDepth", frameDepth != 0 ? 1 : 0);
    p.set("scale", glm::vec2(size_) / glm::vec2(full_));
    p.set("nearClip", float(view.camera.nearClip));
    p.set("farClip", float(view.camera.farClip));
    glBindTextureUnit(0, color_.id());
    glBindTextureUnit(1, depth_.id());
    glBindTextureUnit(2, frameDepth);
    for (int u = 0; u < 3; ++u) glBindSampler(u, 0);
    glUseProgram(p.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    check("upsampling the layered sky");
}

}  // namespace nephele
