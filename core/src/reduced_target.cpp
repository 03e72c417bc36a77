#include "reduced_target.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace nephele {
using namespace gl;

ReducedTarget::ReducedTarget() {
    reduce_ = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "reduced_depth.frag"}});
    for (int depth = 0; depth < 2; ++depth) {
        reduceReuse_[depth] =
            Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "reduced_depth.frag"}},
                           std::string("#define REUSE 1\n#define KEPT_COUNTERS ") + std::to_string(kKeptCounters) +
                               "\n" + (depth ? "" : "#define NO_DEPTH 1\n"));
        reduceReuse_[depth].bindStorageBlock("Kept", kKeptBinding);
    }
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

namespace {
// A texture of the reduced size, edge-clamped, filtered by `filter`.
Texture reducedImage(glm::ivec2 size, GLenum format, int bytesPerTexel, GLint filter, const std::string& what) {
    Texture tex = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(tex.id(), 1, format, size.x, size.y);
    checkAllocation(what, std::uint64_t(size.x) * std::uint64_t(size.y) * std::uint64_t(bytesPerTexel));
    glTextureParameteri(tex.id(), GL_TEXTURE_MIN_FILTER, filter);
    glTextureParameteri(tex.id(), GL_TEXTURE_MAG_FILTER, filter);
    glTextureParameteri(tex.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(tex.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return tex;
}
}  // namespace

// The texels the last frame kept: its counters, done by now (read without waiting).
void ReducedTarget::readKeptCount(Target& t) {
    t.lastReused = -1;
    if (t.countPending) {
        GLint status = 0;
        glGetSynciv(t.counted, GL_SYNC_STATUS, 1, nullptr, &status);
        if (status == GL_SIGNALED) {
            std::uint32_t counts[kKeptCounters];
            glGetNamedBufferSubData(t.keptCounters.id(), 0, sizeof counts, counts);
            t.lastReused = 0;
            for (std::uint32_t c : counts) t.lastReused += c;
        }
        glDeleteSync(t.counted);
        t.counted = nullptr, t.countPending = false;
    }
}

// This frame's images as the framebuffer's attachments (the moments at colour attachment 1 with history).
void ReducedTarget::attachImages(Target& t, bool history) {
    glNamedFramebufferTexture(t.fbo.id(), GL_COLOR_ATTACHMENT0, t.color().id(), 0);
    glNamedFramebufferTexture(t.fbo.id(), GL_COLOR_ATTACHMENT1, history ? t.images[t.current].moments.id() : 0, 0);
    glNamedFramebufferTexture(t.fbo.id(), GL_DEPTH_ATTACHMENT, t.depth().id(), 0);
    const GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GLenum(history ? GL_COLOR_ATTACHMENT1 : GL_NONE)};
    glNamedFramebufferDrawBuffers(t.fbo.id(), 2, buffers);
    checkFramebuffer(t.fbo.id(), "the reduced-resolution target");
    glNamedFramebufferTexture(t.colorOnly.id(), GL_COLOR_ATTACHMENT0, t.color().id(), 0);
    checkFramebuffer(t.colorOnly.id(), "the reduced-resolution target");
}

glm::ivec2 ReducedTarget::begin(const DepthSource& frameDepth, const View& view, int divisor, const ReuseFrame* reuse) {
    const int width = view.camera.width, height = view.camera.height;
    const glm::ivec2 size((width + divisor - 1) / divisor, (height + divisor - 1) / divisor);
    Target& t = targets_.get(size);
    const bool history = reuse != nullptr;
    for (int i = 0; i < (history ? 2 : 1); ++i) {
        Images& im = t.images[i];
        if (!im.color) {
            im.color = reducedImage(size, GL_RGBA16F, 8, GL_LINEAR, "the reduced-resolution RGBA16F target");
            im.depth = reducedImage(size, GL_DEPTH_COMPONENT32F, 4, GL_NEAREST, "the reduced-resolution depth");
        }
        if (history && !im.moments)  // distances in km, at most 250: d^2 within a half float's range
            im.moments = reducedImage(size, GL_RGBA16F, 8, GL_LINEAR, "the reduced-resolution distance moments");
    }
    if (!t.fbo) {
        t.fbo = Framebuffer::create();
        t.colorOnly = Framebuffer::create();
    }
    readKeptCount(t);
    const bool hadLast = history && t.drawn && !reuse->invalidate && reuse->period > 1;
    if (history && t.drawn) {  // the frame just drawn becomes the last one
        t.current = 1 - t.current;
        t.lastRotationVP = t.rotationVP;
        t.lastEye = t.eye;
    }
    t.drawn = history;
    t.rotationVP = view.rotationViewProjection();
    t.eye = view.eye;
    if (history) ++t.frames;
    reused_ = hadLast;
    attachImages(t, history);
    current_ = &t;
    size_ = size;
    full_ = glm::ivec2(width, height);
    glBindFramebuffer(GL_FRAMEBUFFER, t.fbo.id());
    glViewport(0, 0, size.x, size.y);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_BLEND);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthMask(GL_TRUE);
    if (!history) {
        const float zero[4] = {0, 0, 0, 0};
        glClearNamedFramebufferfv(t.fbo.id(), GL_COLOR, 0, zero);
        if (frameDepth.texture == 0) {
            const float far = float(view.farDepth());
            glClearNamedFramebufferfv(t.fbo.id(), GL_DEPTH, 0, &far);
            return size;
        }
    }
    // Each texel's depth = the farthest of its block of the frame (written, always passing); with
    // history its colour and moments too (every texel written: no clear), reprojected where kept.
    const Program& p = history ? reduceReuse_[frameDepth.texture != 0 ? 1 : 0] : reduce_;
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_ALWAYS);
    if (!history) glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    p.set("frameDepth", 0);
    p.set("fullSize", glm::vec2(full_));
    p.set("reducedSize", glm::vec2(size));
    setViewFrameUniforms(p, view, false, frameDepth);
    if (history) setReuseUniforms(p, t, view, *reuse, hadLast);
    glBindTextureUnit(0, frameDepth.texture);
    glBindSampler(0, 0);
    glUseProgram(p.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    if (hadLast) {
        t.counted = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
        t.countPending = t.counted != nullptr;
    }
    check(history ? "reducing the frame's depth and reusing the last frame's image" : "reducing the frame's depth");
    return size;
}

void ReducedTarget::setReuseUniforms(const Program& p, Target& t, const View& view, const ReuseFrame& frame,
                                     bool haveLast) {
    p.set("haveLast", haveLast ? 1 : 0);
    // The world ray through NDC (x, y): rayCentre() + x rightScaled() + y upScaled().
    p.set("rayOf", glm::mat3(glm::dmat3(view.rightScaled(), view.upScaled(), view.rayCentre())));
    p.set("lastViewProjection", glm::mat4(t.lastRotationVP));
    p.set("shift", glm::vec3(t.eye - t.lastEye - frame.drift));
    p.set("period", std::max(frame.period, 1));
    p.set("phase", int(t.frames % std::max(frame.period, 1)));
    p.set("maxError", float(frame.maxError));
    p.set("weatherError", float(frame.weatherError));
    p.set("focal", float(0.5 * size_.y / view.tanHalfY));
    p.set("nearest", float(std::max(frame.nearest, 1e-3)));
    p.set("nearPlane", float(view.depth.reversedZ ? 1.0 : 0.0));
    p.set("lastColor", 1);
    p.set("lastMoments", 2);
    const Images& last = t.images[1 - t.current];
    glBindTextureUnit(1, haveLast ? last.color.id() : 0);
    glBindTextureUnit(2, haveLast ? last.moments.id() : 0);
    for (int u = 1; u < 3; ++u) glBindSampler(u, 0);
    if (!t.keptCounters) {
        t.keptCounters = Buffer::create();
        glNamedBufferStorage(t.keptCounters.id(), kKeptCounters * sizeof(std::uint32_t), nullptr,
                             GL_DYNAMIC_STORAGE_BIT);
    }
    const std::uint32_t zero = 0;
    glClearNamedBufferData(t.keptCounters.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kKeptBinding, t.keptCounters.id());
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
    return current_ ? DepthSource{current_->depth().id(), {0, 0}} : DepthSource{};
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
    glBindTextureUnit(0, current_->color().id());
    glBindTextureUnit(1, current_->depth().id());
    glBindTextureUnit(2, frameDepth.texture);
    for (int u = 0; u < 3; ++u) glBindSampler(u, 0);
    glUseProgram(p.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_SCISSOR_TEST);
    check("upsampling the reduced-resolution target");
}

}  // namespace nephele
