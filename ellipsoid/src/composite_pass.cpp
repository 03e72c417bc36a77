// The composite (section 3.6): every tile of a frame's plan from the atlas onto the frame, by
// the settings' order: "over" back to front by centre distance (the paper), weighted and
// order-independent (McGuire & Bavoil 2013) into a target of its own and resolved over the
// frame, or, with the stencil fly-through, the paper's section 4.3 per ellipsoid.
#include "compositor_impl.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace nephele {

void EllipsoidRenderer::Impl::compositeTiles(const EllipsoidSettings& s, const FramePlan& plan, const Scene& scene,
                                             const View& view, const HostFrame& frame, EllipsoidStats& stats) {
    Impl& m = *this;
    const int frameW = view.camera.width, frameH = view.camera.height;
    const DepthSource depth = frame.hasDepth && s.flyThrough == FlyThrough::Fraction
                                  ? m.depths.get({frameW, frameH}).source(frame, view)
                                  : DepthSource{};
    const bool stencil = s.flyThrough == FlyThrough::Stencil && frame.hasDepth;
    const bool fraction = depth.texture != 0;
    const bool moments = s.order == CompositeOrder::Moments && !stencil;
    const bool weighted = (s.order == CompositeOrder::Weighted || moments) && !stencil;

    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    const Program& cp = weighted ? (fraction ? m.compositeWeightedFraction : m.compositeWeighted)
                                 : (fraction ? m.compositeFraction : m.composite);
    const Program* momentsPass = moments ? (fraction ? &m.compositeMomentsFraction : &m.compositeMoments) : nullptr;
    const glm::vec2 momentRange = moments ? momentDepthRange(plan.prepared, view) : glm::vec2(0);
    const float weightReference = float(weightReferenceDepth(plan.prepared, view));
    // (the impostors are made with the composite without fraction: the frame's depth is the
    // impostor's to test, drawImpostor)
    const Program* maker = plan.impostors.empty() || &cp == &m.composite ? nullptr : &m.composite;
    for (const Program* p : {&cp, momentsPass, maker}) {
        if (!p) continue;
        p->set("atlasTerms", 3);
        p->set("sunIrradiance", glm::vec3(scene.sun.color * scene.sun.intensity));
        p->set("albedo", float(scene.medium.albedo));
        p->set("sceneDepth", 5);
        p->set("atlasSize", glm::vec2(plan.atlasW, plan.atlasH));
        p->set("onScreen", 1);
        p->set("useOrder", 1);
        p->set("colourMatrix", nephele::colourMatrix());
        p->set("forward", glm::vec3(view.forward));
        p->set("rayCentre", glm::vec3(view.rayCentre()));
        p->set("rightScaled", glm::vec3(view.rightScaled()));
        p->set("upScaled", glm::vec3(view.upScaled()));
        p->set("nearClip", float(view.camera.nearClip));
        p->set("weightExponent", s.weightExponent);
        p->set("weightReference", weightReference);
        p->set("momentRange", momentRange);
        p->set("momentSums", 6);
        p->set("momentZero", 7);
        setViewFrameUniforms(*p, view, !weighted, depth);
    }
    if (m.impostorFraction) setViewFrameUniforms(m.impostorFraction, view, true, depth);
    glBindTextureUnit(3, m.atlas->terms.id());
    glBindTextureUnit(5, depth.texture);
    glBindSampler(3, m.linearClamp.id());
    glBindSampler(5, 0);
    glBindVertexArray(m.empty.id());
    if (stencil) stencilPass(s, plan, view, frame, cp, stats);
    else if (weighted) weightedPass(s, plan, view, frame, cp, momentsPass, stats);
    else overPass(s, plan, view, frame, cp, depth, stats);
}

namespace {

// The tiles order[first, first + n) in composite order: one instanced draw, or the paper's
// draw per ellipsoid.
void drawInOrder(const EllipsoidSettings& s, const Program& cp, int n, EllipsoidStats& stats, int first = 0) {
    glUseProgram(cp.id());
    if (s.instanced) {
        cp.set("instanceBase", first);
        glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, n);
        ++stats.drawCalls;
    } else {
        for (int k = first; k < first + n; ++k) {
            cp.set("instanceBase", k);
            glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, 1);
            ++stats.drawCalls;
        }
    }
}

}  // namespace

std::vector<CloseRun> closeRuns(const FramePlan& plan, int first, int count, int width, int height, int divisor) {
    std::vector<CloseRun> out;
    if (divisor <= 1) return out;
    auto pixels = [&](int k) {  // the tile's screen rectangle in the view (px), and whether it is magnified enough
        const GpuTile& g = plan.gpu[std::size_t(plan.order[std::size_t(k)])];
        const double x0 = (g.screenRect[0] * 0.5 + 0.5) * width, x1 = (g.screenRect[2] * 0.5 + 0.5) * width;
        const double y0 = (g.screenRect[1] * 0.5 + 0.5) * height, y1 = (g.screenRect[3] * 0.5 + 0.5) * height;
        const bool magnified = std::max(x1 - x0, y1 - y0) >= double(divisor) * g.atlasRect[2];
        const glm::ivec4 r(std::clamp(int(std::floor(x0)), 0, width), std::clamp(int(std::floor(y0)), 0, height),
                           std::clamp(int(std::ceil(x1)), 0, width), std::clamp(int(std::ceil(y1)), 0, height));
        return std::pair(r, magnified);
    };
    for (int k = first; k < first + count;) {
        int n = 0;
        glm::ivec4 u(width, height, 0, 0);
        for (; k + n < first + count; ++n) {
            const auto [r, magnified] = pixels(k + n);
            if (!magnified) break;
            u = glm::ivec4(std::min(u.x, r.x), std::min(u.y, r.y), std::max(u.z, r.z), std::max(u.w, r.w));
        }
        if (n >= 2 && u.z > u.x && u.w > u.y) out.push_back({k, n, u});
        k += std::max(n, 1);
    }
    return out;
}

void EllipsoidRenderer::Impl::overPass(const EllipsoidSettings& s, const FramePlan& plan, const View& view,
                                       const HostFrame& frame, const Program& cp, const DepthSource& depth,
                                       EllipsoidStats& stats) {
    if (!plan.impostors.empty()) makeImpostors(s, plan, view, composite, stats);
    bindFrame(frame, view);
    const bool fraction = &cp == &compositeFraction;
    const int W = view.camera.width, H = view.camera.height, d = s.closeDownsample;
    bool reducedBegun = false;
    // Tiles order[k, end) "over" the frame, each at its size on screen.
    auto overFrame = [&](int k, int end) {
        if (end <= k) return;
        glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
        drawInOrder(s, cp, end - k, stats, k);
    };
    for (const FramePlan::Run& run : plan.runs) {
        if (run.impostor >= 0) {
            drawImpostor(plan, view, plan.impostors[std::size_t(run.impostor)], fraction, stats);
            continue;
        }
        const std::vector<CloseRun> close =
            cloudLodApplies(s) ? closeRuns(plan, run.first, run.count, W, H, d) : std::vector<CloseRun>{};
        int next = run.first;
        for (const CloseRun& c : close) {
            overFrame(next, c.first);
            // The run into the reduced target ("over" from 0: premultiplied), its depth the
            // frame's reduced; then upsampled over the frame within the run's rectangle.
            const glm::ivec4 rr(std::max(c.rect.x / d - 1, 0), std::max(c.rect.y / d - 1, 0),
                                (c.rect.z + d - 1) / d + 1, (c.rect.w + d - 1) / d + 1);
            if (!reducedBegun) reduced->begin(depth, view, d), reducedBegun = true;  // (the depth reduced once)
            reduced->resume(rr);  // (the colour alone: the tiles' fraction reads the reduced depth)
            glDisable(GL_SCISSOR_TEST);
            glEnable(GL_BLEND);
            glBlendEquation(GL_FUNC_ADD);
            glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
            glBindVertexArray(empty.id());
            if (fraction) {
                setViewFrameUniforms(cp, view, false, reduced->depth());
                glBindTextureUnit(5, reduced->depth().texture);
            }
            drawInOrder(s, cp, c.count, stats, c.first);
            if (fraction) {
                setViewFrameUniforms(cp, view, true, depth);
                glBindTextureUnit(5, depth.texture);
            }
            reduced->composite(frame, depth, view, 0, &c.rect);
            ++stats.drawCalls;
            stats.tilesDownsampled += c.count;
            glBindVertexArray(empty.id());
            next = c.first + c.count;
        }
        overFrame(next, run.first + run.count);
    }
    check("compositing the ellipsoid tiles");
}

void EllipsoidRenderer::Impl::makeImpostors(const EllipsoidSettings& s, const FramePlan& plan, const View& view,
                                            const Program& cp, EllipsoidStats& stats) {
    // Each fresh impostor: its place cleared, then its tiles "over" it back to front (the
    // blend the frame's composite uses, from 0: premultiplied colour, and opacity), its pixels
    // of the view mapped texel for texel onto its image (tile_quad.vert's targetRect).
    const CloudImpostors& atlas = *plan.impostorAtlas;
    const int W = view.camera.width, H = view.camera.height;
    glDisable(GL_FRAMEBUFFER_SRGB);
    glEnable(GL_SCISSOR_TEST);
    const float zero[4] = {0, 0, 0, 0};
    for (std::size_t k = 0; k < plan.impostors.size(); ++k) {
        const ImpostorDraw& d = plan.impostors[k];
        if (!d.fresh) continue;
        glBindFramebuffer(GL_FRAMEBUFFER, atlas.framebuffer(d.place.pass));
        glViewport(d.place.x, d.place.y, d.w, d.h);
        glScissor(d.place.x, d.place.y, d.place.size, d.place.size);
        glClearBufferfv(GL_COLOR, 0, zero);
        glScissor(d.place.x, d.place.y, d.w, d.h);
        glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
        cp.set("targetRect", glm::vec4(2.0f * d.px / W - 1, 2.0f * d.py / H - 1, 2.0f * (d.px + d.w) / W - 1,
                                       2.0f * (d.py + d.h) / H - 1));
        drawInOrder(s, cp, plan.impostorCount[k], stats, plan.impostorFirst[k]);
    }
    cp.set("targetRect", glm::vec4(-1, -1, 1, 1));
    glDisable(GL_SCISSOR_TEST);
    check("making the cloud impostors");
}

void EllipsoidRenderer::Impl::drawImpostor(const FramePlan& plan, const View& view, const ImpostorDraw& d,
                                           bool fraction, EllipsoidStats& stats) {
    const Program& p = fraction ? impostorFraction : impostor;
    glUseProgram(p.id());
    // Premultiplied: its colour as it is, the frame behind times 1 - its opacity.
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    p.set("reproject", d.reproject);
    p.set("imageRect", glm::vec4(d.place.x, d.place.y, d.w, d.h));
    p.set("layer", float(d.place.pass));
    p.set("atlasSize", float(plan.impostorAtlas->atlasSize()));
    p.set("impostors", 4);
    if (fraction) {
        p.set("sceneDepth", 5);
        p.set("forward", glm::vec3(view.forward));
        p.set("rayCentre", glm::vec3(view.rayCentre()));
        p.set("rightScaled", glm::vec3(view.rightScaled()));
        p.set("upScaled", glm::vec3(view.upScaled()));
        p.set("cloudCentre", glm::vec3(d.centre - view.eye));
        p.set("cloudRadius", float(d.radius));
    }
    glBindTextureUnit(4, plan.impostorAtlas->texture());
    glBindSampler(4, linearClamp.id());
    glBindVertexArray(empty.id());
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    ++stats.drawCalls;
}

void EllipsoidRenderer::Impl::weightedPass(const EllipsoidSettings& s, const FramePlan& plan, const View& view,
                                           const HostFrame& frame, const Program& cp, const Program* momentsPass,
                                           EllipsoidStats& stats) {
    const int frameW = view.camera.width, frameH = view.camera.height;
    WeightedTarget& wt = momentsPass ? momentTarget(frameW, frameH) : weightedTarget(frameW, frameH);
    // Clear, accumulate and resolve only the tiles' screen area: with few or small clouds
    // the frame-sized clear and resolve were most of the weighted composite's cost.
    float lo[2] = {1, 1}, hi[2] = {-1, -1};
    for (const GpuTile& t : plan.gpu)
        for (int k = 0; k < 2; ++k)
            lo[k] = std::min(lo[k], t.screenRect[k]), hi[k] = std::max(hi[k], t.screenRect[k + 2]);
    const int x0 = std::clamp(int(std::floor((lo[0] * 0.5f + 0.5f) * frameW)) - 1, 0, frameW);
    const int y0 = std::clamp(int(std::floor((lo[1] * 0.5f + 0.5f) * frameH)) - 1, 0, frameH);
    const int x1 = std::max(std::clamp(int(std::ceil((hi[0] * 0.5f + 0.5f) * frameW)) + 1, 0, frameW), x0);
    const int y1 = std::max(std::clamp(int(std::ceil((hi[1] * 0.5f + 0.5f) * frameH)) + 1, 0, frameH), y0);
    glEnable(GL_SCISSOR_TEST);
    glScissor(x0, y0, x1 - x0, y1 - y0);
    const float zero[4] = {0, 0, 0, 0}, one[4] = {1, 1, 1, 1};
    if (momentsPass) {
        // The moment composite's first pass: every tile's absorbance and its moments, added.
        glBindFramebuffer(GL_FRAMEBUFFER, wt.moments.id());
        glViewport(0, 0, frameW, frameH);
        glClearNamedFramebufferfv(wt.moments.id(), GL_COLOR, 0, zero);
        glClearNamedFramebufferfv(wt.moments.id(), GL_COLOR, 1, zero);
        glBlendFunc(GL_ONE, GL_ONE);
        drawInOrder(s, *momentsPass, int(plan.order.size()), stats);
        check("the moment composite's first pass");
        glBindTextureUnit(6, wt.sums.id());
        glBindTextureUnit(7, wt.zero.id());
        glBindSampler(6, 0);
        glBindSampler(7, 0);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, wt.fbo.id());
    glViewport(0, 0, frameW, frameH);
    glClearNamedFramebufferfv(wt.fbo.id(), GL_COLOR, 0, zero);
    glClearNamedFramebufferfv(wt.fbo.id(), GL_COLOR, 1, one);
    glBlendFunci(0, GL_ONE, GL_ONE);                   // sums
    glBlendFunci(1, GL_ZERO, GL_ONE_MINUS_SRC_COLOR);  // product of (1 - a)
    drawInOrder(s, cp, int(plan.order.size()), stats);
    check("compositing the ellipsoid tiles");

    // The resolve: colour sum(w a c) / sum(w a), opacity 1 - prod(1 - a), "over" the frame.
    bindFrame(frame, view);  // (the scissor stays: the tiles' area, moved to the view's place)
    glScissor(view.origin.x + x0, view.origin.y + y0, x1 - x0, y1 - y0);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(resolve.id());
    resolve.set("accumTexture", 3);
    resolve.set("revealTexture", 4);
    setViewFrameUniforms(resolve, view, true);
    glBindTextureUnit(3, wt.accum.id());
    glBindTextureUnit(4, wt.reveal.id());
    glBindSampler(3, 0);
    glBindSampler(4, 0);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    ++stats.drawCalls;
    check("resolving the weighted composite");
}

void EllipsoidRenderer::Impl::stencilPass(const EllipsoidSettings& s, const FramePlan& plan, const View& view,
                                          const HostFrame& frame, const Program& cp, EllipsoidStats& stats) {
    // Section 4.3: per ellipsoid, its front faces set the stencil where they are in front
    // of the opaque depth; the tile is composited there, and the stencil reset.
    bindFrame(frame, view);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    const int frameW = view.camera.width, frameH = view.camera.height;
    const glm::dmat4 viewRotation = glm::lookAt(Vec3(0.0), view.forward, view.up);
    const glm::mat4 viewProjection(view.projectionMatrix * viewRotation);
    screenDepth.set("viewProjection", viewProjection);
    glEnable(GL_STENCIL_TEST);
    glStencilMask(0xFF);
    glClearStencil(0);
    auto clearStencil = [&] {  // the view's viewport only: other channels share the framebuffer
        glEnable(GL_SCISSOR_TEST);
        glScissor(view.origin.x, view.origin.y, frameW, frameH);
        glClear(GL_STENCIL_BUFFER_BIT);
        glDisable(GL_SCISSOR_TEST);
    };
    clearStencil();
    frameDepthTest(view);
    const int n = int(plan.order.size());
    for (int k = 0; k < n; ++k) {
        // A reference value of its own per ellipsoid, so that no stale stencil is reused.
        const int ref = k % 255 + 1;
        if (ref == 1 && k > 0) clearStencil();
        const int t = plan.order[k];
        const IndexedMesh& sphere = mesh(meshSlices(s, int(plan.gpu[t].atlasRect[2])));
        glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
        glEnable(GL_DEPTH_TEST);
        glEnable(GL_CULL_FACE);
        glCullFace(GL_BACK);
        glStencilFunc(GL_ALWAYS, ref, 0xFF);
        glStencilOp(GL_KEEP, GL_KEEP, GL_REPLACE);
        glUseProgram(screenDepth.id());
        screenDepth.set("instanceBase", t);
        glBindVertexArray(sphere.vao.id());
        glDrawElementsInstanced(GL_TRIANGLES, sphere.indexCount, GL_UNSIGNED_INT, nullptr, 1);
        glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        glDisable(GL_DEPTH_TEST);
        glDisable(GL_CULL_FACE);
        glStencilFunc(GL_EQUAL, ref, 0xFF);
        glStencilOp(GL_KEEP, GL_KEEP, GL_KEEP);
        glUseProgram(cp.id());
        cp.set("instanceBase", k);
        glBindVertexArray(empty.id());
        glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, 1);
        stats.drawCalls += 2;
    }
    check("compositing the ellipsoid tiles");
}

}  // namespace nephele
