#include "reduced_target.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace nephele {
using namespace gl;

ReducedTarget::ReducedTarget() {
    reduce_ = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "reduced_depth.frag"}});
    empty_ = VertexArray::create();
}

const Program& ReducedTarget::program(int shadowLayers, bool depth) {
    if (shadowLayers < 0 || shadowLayers > kMaxShadowLayers)
        throw std::invalid_argument("ReducedTarget: shadowLayers must be 0.." + std::to_string(kMaxShadowLayers));
    Program& p = upsample_[shadowLayers][depth ? 1 : 0];
    if (p.id() == 0)
        p = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "reduced_upsample.frag"}},
                           shadowSlotsDefine() + "#define SHADOW_LAYERS " + std::to_string(shadowLayers) + "\n" +
                               (depth ? "" : "#define NO_DEPTH 1\n"));
    return p;
}

void ReducedTarget::prepare() {
    for (int layers = 0; layers <= kMaxShadowLayers; ++layers) program(layers, true), program(layers, false);
}

glm::ivec2 ReducedTarget::begin(const DepthSource& frameDepth, const View& view, int divisor) {
    const int width = view.camera.width, height = view.camera.height;
    const glm::ivec2 size((width + divisor - 1) / divisor, (height + divisor - 1) / divisor);
    Target& t = targets_.get(size);
    if (!t.fbo) {
        // A texture of the reduced size, edge-clamped, filtered by `filter`.
        auto image = [&](GLenum format, int bytesPerTexel, GLint filter, const std::string& what) {
            Texture tex = Texture::create(GL_TEXTURE_2D);
            glTextureStorage2D(tex.id(), 1, format, size.x, size.y);
            checkAllocation(what, std::uint64_t(size.x) * std::uint64_t(size.y) * std::uint64_t(bytesPerTexel));
            glTextureParameteri(tex.id(), GL_TEXTURE_MIN_FILTER, filter);
            glTextureParameteri(tex.id(), GL_TEXTURE_MAG_FILTER, filter);
            glTextureParameteri(tex.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
            glTextureParameteri(tex.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
            return tex;
        };
        t.color = image(GL_RGBA16F, 8, GL_LINEAR, "the reduced-resolution RGBA16F target");
        t.depth = image(GL_DEPTH_COMPONENT32F, 4, GL_NEAREST, "the reduced-resolution depth");
        t.fbo = Framebuffer::create();
        glNamedFramebufferTexture(t.fbo.id(), GL_COLOR_ATTACHMENT0, t.color.id(), 0);
        glNamedFramebufferTexture(t.fbo.id(), GL_DEPTH_ATTACHMENT, t.depth.id(), 0);
        checkFramebuffer(t.fbo.id(), "the reduced-resolution target");
        t.colorOnly = Framebuffer::create();
        glNamedFramebufferTexture(t.colorOnly.id(), GL_COLOR_ATTACHMENT0, t.color.id(), 0);
        checkFramebuffer(t.colorOnly.id(), "the reduced-resolution target");
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
    check("reducing the frame's depth");
    return size;
}

void ReducedTarget::resume(const glm::ivec4& rect) {
    if (!current_) throw std::logic_error("ReducedTarget::resume before begin");
    glBindFramebuffer(GL_FRAMEBUFFER, current_->colorOnly.id());
    glViewport(0, 0, size_.x, size_.y);
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glEnable(GL_SCISSOR_TEST);
    glScissor(rect.x, rect.y, std::max(rect.z - rect.x, 0), std::max(rect.w - rect.y, 0));
    const float zero[4] = {0, 0, 0, 0};
    glClearNamedFramebufferfv(current_->colorOnly.id(), GL_COLOR, 0, zero);
}

DepthSource ReducedTarget::depth() const {
    return current_ ? DepthSource{current_->depth.id(), {0, 0}} : DepthSource{};
}

void ReducedTarget::composite(const HostFrame& frame, const DepthSource& frameDepth, const View& view, int shadowLayers,
                              const glm::ivec4* rect) {
    bindFrame(frame, view);
    if (rect) {
        glEnable(GL_SCISSOR_TEST);
        glScissor(view.origin.x + rect->x, view.origin.y + rect->y, std::max(rect->z - rect->x, 0),
                  std::max(rect->w - rect->y, 0));
    } else {
        glDisable(GL_SCISSOR_TEST);
    }
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_FALSE);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ONE, GL_SRC1_ALPHA);  // cloud + frame * keep
    const Program& p = program(shadowLayers, frameDepth.texture != 0);
    p.set("cloud", 0);
    p.set("cloudDepth", 1);
    p.set("frameDepth", 2);
    p.set("scale", glm::vec2(size_) / glm::vec2(full_));
    setViewFrameUniforms(p, view, true, frameDepth);
    glBindTextureUnit(0, current_->color.id());
    glBindTextureUnit(1, current_->depth.id());
    glBindTextureUnit(2, frameDepth.texture);
    for (int u = 0; u < 3; ++u) glBindSampler(u, 0);
    glUseProgram(p.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_SCISSOR_TEST);
    check("upsampling the reduced-resolution target");
}

}  // namespace nephele
