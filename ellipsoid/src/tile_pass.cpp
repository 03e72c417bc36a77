// The tile pass (section 3.4): every fresh tile of a frame's plan drawn into its place in the
// atlas, pass by pass (an atlas layer each), then, with EllipsoidSettings::colourMatrixPass,
// the paper's colour-matrix copy. Tiles reused from an earlier frame are left as they are.
#include "compositor_impl.hpp"

#include <glm/gtc/matrix_transform.hpp>

namespace nephele {

void EllipsoidRenderer::Impl::drawTiles(const EllipsoidSettings& s, const FramePlan& plan, const Scene& scene,
                                        const View& view, EllipsoidStats& stats) {
    Impl& m = *this;
    const PreparedClouds& prepared = plan.prepared;
    const PackResult& packed = plan.packed;
    const std::vector<TilePlacement>& placements = plan.placements;
    const int atlasW = plan.atlasW, atlasH = plan.atlasH;
    glDisable(GL_DEPTH_TEST);
    glFrontFace(GL_CCW);
    const glm::vec2 atlasSize(atlasW, atlasH);

    // ---- The tile passes.
    for (const Program* tp : {&m.tile, &m.tileCut, &m.tileRay, &m.tileRayCut}) {
        if (!*tp) continue;  // not used by these settings
        tp->set("atlasSize", atlasSize);
        tp->set("forward", glm::vec3(view.forward));
        tp->set("nearClip", float(view.camera.nearClip));
        tp->set("falloff", 0);
        tp->set("noiseVolume", 1);
        m.lightTextures.bind(*tp);
        tp->set("hgG", float(scene.medium.hgG));
        tp->set("eyeNoise", glm::vec3(glm::fract(view.eye / prepared.noisePeriod)));
        tp->set("noisePeriod", float(prepared.noisePeriod));
        tp->set("noiseAmp", float(scene.medium.noise));
        tp->set("sunDirection", glm::vec3(scene.sun.direction));
        m.detail.bind(*tp, scene.medium.detail, view.eye);
        tp->set("foldAtlas", s.instanced ? 1 : 0);
    }
    glBindTextureUnit(0, m.falloff.id());
    glBindTextureUnit(1, m.noise.id());
    glBindSampler(0, 0);
    glBindSampler(1, 0);

    m.colourMatrix.set("colourMatrix", nephele::colourMatrix());
    m.colourMatrix.set("atlasTerms", 3);
    m.colourMatrix.set("atlasSize", atlasSize);
    m.colourMatrix.set("onScreen", 0);
    m.colourMatrix.set("useOrder", 0);

    for (int pass = 0, first = 0; pass < packed.passes; ++pass) {
        int count = 0;
        while (first + count < int(placements.size()) && placements[first + count].pass == pass) ++count;
        if (plan.reuse && count == 0) continue;  // the layer's tiles are all reused
        glBindFramebuffer(GL_FRAMEBUFFER, m.atlas->fbos[pass].id());
        glViewport(0, 0, atlasW, atlasH);
        glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        // T2 = D in red, T1 / D = 0 in alpha; 1 in green and blue (colour, subtracted from).
        const float terms[4] = {model::kTranslucence, 1.0f, 1.0f, 0.0f};
        if (!plan.reuse) {
            glClearNamedFramebufferfv(m.atlas->fbos[pass].id(), GL_COLOR, 0, terms);
        } else {  // the layer keeps reused tiles: only the fresh tiles' rectangles are cleared
            glDisable(GL_BLEND);
            glUseProgram(m.tileClear.id());
            m.tileClear.set("atlasSize", atlasSize);
            m.tileClear.set("onScreen", 0);
            m.tileClear.set("useOrder", 0);
            m.tileClear.set("instanceBase", first);
            m.tileClear.set("clearTerms", glm::vec4(terms[0], terms[1], terms[2], terms[3]));
            glBindVertexArray(m.empty.id());
            glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, count);
            ++stats.drawCalls;
        }

        // Ellipsoids: red = T2 - T2 g (reverse subtract), alpha = I/D - T1/D (subtract).
        const bool polygon = s.geometry == TileGeometry::Polygon;
        if (!polygon) {
            glEnable(GL_CULL_FACE);  // the mesh's back faces
            glCullFace(GL_FRONT);
        }
        glEnable(GL_BLEND);
        glBlendEquationSeparate(GL_FUNC_REVERSE_SUBTRACT, GL_FUNC_SUBTRACT);
        glBlendFunc(GL_ONE, GL_ONE);
        auto group = [&](const TilePlacement& p) {
            return drawGroup(s, prepared.ellipsoids[p.id], p.size, plan.perPixelLight[p.id] != 0);
        };
        for (int k = first; k < first + count;) {
            const int key = group(placements[k]);
            int n = 0;
            while (k + n < first + count && group(placements[k + n]) == key) ++n;
            const bool cut = key >= 1000 && key < 2000;
            const bool ray = polygon || key >= 2000;  // polygon tiles, or mesh tiles lit per pixel
            const Program& tp = ray ? (cut ? m.tileRayCut : m.tileRay) : (cut ? m.tileCut : m.tile);
            glUseProgram(tp.id());
            const IndexedMesh* mesh = ray ? nullptr : &m.mesh(key % 1000);
            glBindVertexArray(ray ? m.empty.id() : mesh->vao.id());
            if (!polygon) ray ? glDisable(GL_CULL_FACE) : glEnable(GL_CULL_FACE);
            // Clip distances keep the geometry in its tile (the polygon's whole-tile quad needs none).
            const bool clip = !(ray && cut);
            for (int c = 0; c < 4; ++c) clip ? glEnable(GL_CLIP_DISTANCE0 + c) : glDisable(GL_CLIP_DISTANCE0 + c);
            auto draw = [&](int instances) {
                if (ray) glDrawArraysInstanced(GL_TRIANGLE_FAN, 0, cut ? 4 : 8, instances);  // quad or octagon
                else glDrawElementsInstanced(GL_TRIANGLES, mesh->indexCount, GL_UNSIGNED_INT, nullptr, instances);
                ++stats.drawCalls;
            };
            if (s.instanced) {
                tp.set("instanceBase", k);
                draw(n);
            } else {
                for (int i = k; i < k + n; ++i) {  // the paper: a viewport and a draw per ellipsoid
                    glViewport(placements[i].x, placements[i].y, placements[i].size, placements[i].size);
                    tp.set("instanceBase", i);
                    draw(1);
                }
                glViewport(0, 0, atlasW, atlasH);
            }
            k += n;
        }
        for (int c = 0; c < 4; ++c) glDisable(GL_CLIP_DISTANCE0 + c);
        glDisable(GL_CULL_FACE);
        check("ellipsoid tile pass");

        // The colour-matrix copy, all tiles of the pass in one draw (or, fused, in the composite).
        if (!s.colourMatrixPass) {
            first += count;
            continue;
        }
        glTextureBarrier();
        glBindTextureUnit(3, m.atlas->terms.id());
        glBindSampler(3, 0);
        glBlendEquation(GL_FUNC_REVERSE_SUBTRACT);
        glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_TRUE);
        glBindVertexArray(m.empty.id());
        glUseProgram(m.colourMatrix.id());
        m.colourMatrix.set("instanceBase", first);
        glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, count);
        ++stats.drawCalls;
        check("colour-matrix pass");
        first += count;
    }
}

}  // namespace nephele
