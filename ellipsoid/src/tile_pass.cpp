// The tile pass (section 3.4): every fresh tile of a frame's plan drawn into its place in the
// atlas, pass by pass (an atlas layer each), then, with EllipsoidSettings::colourMatrixPass,
// the paper's colour-matrix copy. Tiles reused from an earlier frame are left as they are.
#include "compositor_impl.hpp"

#include <glm/gtc/matrix_transform.hpp>

namespace nephele {

void EllipsoidRenderer::Impl::drawTiles(const EllipsoidSettings& s, const FramePlan& plan, const Scene& scene,
                                        const View& view, EllipsoidStats& stats) {
    const std::vector<TilePlacement>& placements = plan.placements;
    glDisable(GL_DEPTH_TEST);
    glFrontFace(GL_CCW);
    setTileUniforms(s, plan, scene, view);
    if (drawnTilePrograms.empty() && !placements.empty()) stats.programsFirstDrawn += warmTilePrograms(s, plan);
    for (int pass = 0, first = 0; pass < plan.packed.passes; ++pass) {
        int count = 0;
        while (first + count < int(placements.size()) && placements[first + count].pass == pass) ++count;
        if (plan.reuse && count == 0) continue;  // the layer's tiles are all reused
        clearTilePass(plan, pass, first, count, stats);
        drawTilePass(s, plan, first, count, stats);
        // The colour-matrix copy, all tiles of the pass in one draw (or, fused, in the composite).
        if (s.colourMatrixPass) colourMatrixPass(first, count, stats);
        first += count;
    }
}

// The frame's uniforms of the tile programs and the colour-matrix program, and their textures.
void EllipsoidRenderer::Impl::setTileUniforms(const EllipsoidSettings& s, const FramePlan& plan, const Scene& scene,
                                              const View& view) {
    const PreparedClouds& prepared = plan.prepared;
    const glm::vec2 atlasSize(plan.atlasW, plan.atlasH);
    for (const Program* tp : {&tile, &tileCut, &tileRay, &tileRayCut}) {
        if (!*tp) continue;  // not used by these settings
        tp->set("atlasSize", atlasSize);
        tp->set("forward", glm::vec3(view.forward));
        tp->set("nearClip", float(view.camera.nearClip));
        tp->set("falloff", 0);
        tp->set("noiseVolume", 1);
        lightTextures.bind(*tp);
        tp->set("hgG", float(scene.medium.hgG));
        tp->set("eyeNoise", glm::vec3(glm::fract(view.eye / prepared.noisePeriod)));
        tp->set("noisePeriod", float(prepared.noisePeriod));
        tp->set("noiseAmp", float(scene.medium.noise));
        tp->set("sunDirection", glm::vec3(scene.sun.direction));
        detail.bind(*tp, scene.medium.detail, view.eye);
        tp->set("foldAtlas", s.instanced ? 1 : 0);
    }
    glBindTextureUnit(0, falloff.id());
    glBindTextureUnit(1, noise.id());
    glBindSampler(0, 0);
    glBindSampler(1, 0);

    colourMatrix.set("colourMatrix", nephele::colourMatrix());
    colourMatrix.set("atlasTerms", 3);
    colourMatrix.set("atlasSize", atlasSize);
    colourMatrix.set("onScreen", 0);
    colourMatrix.set("useOrder", 0);
}

// Pass `pass`'s layer made ready for its tiles placements[first, + count): cleared whole, or
// with reuse (the layer keeps reused tiles) only the fresh tiles' rectangles.
void EllipsoidRenderer::Impl::clearTilePass(const FramePlan& plan, int pass, int first, int count,
                                            EllipsoidStats& stats) {
    glBindFramebuffer(GL_FRAMEBUFFER, atlas->fbos[pass].id());
    glViewport(0, 0, plan.atlasW, plan.atlasH);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    // T2 = D in red, T1 / D = 0 in alpha; 1 in green and blue (colour, subtracted from).
    const float terms[4] = {model::kTranslucence, 1.0f, 1.0f, 0.0f};
    if (!plan.reuse) {
        glClearNamedFramebufferfv(atlas->fbos[pass].id(), GL_COLOR, 0, terms);
    } else {  // the layer keeps reused tiles: only the fresh tiles' rectangles are cleared
        glDisable(GL_BLEND);
        glUseProgram(tileClear.id());
        tileClear.set("atlasSize", glm::vec2(plan.atlasW, plan.atlasH));
        tileClear.set("onScreen", 0);
        tileClear.set("useOrder", 0);
        tileClear.set("instanceBase", first);
        tileClear.set("clearTerms", glm::vec4(terms[0], terms[1], terms[2], terms[3]));
        glBindVertexArray(empty.id());
        glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, count);
        ++stats.drawCalls;
    }
}

// The tiles placements[first, + count) of one pass, one instanced draw per group (drawGroup).
void EllipsoidRenderer::Impl::drawTilePass(const EllipsoidSettings& s, const FramePlan& plan, int first, int count,
                                           EllipsoidStats& stats) {
    const std::vector<TilePlacement>& placements = plan.placements;
    tileDrawState(s);
    auto group = [&](const TilePlacement& p) {
        return drawGroup(s, plan.prepared.ellipsoids[p.id], p.size, plan.perPixelLight[p.id] != 0);
    };
    for (int k = first; k < first + count;) {
        const int key = group(placements[k]);
        int n = 0;
        while (k + n < first + count && group(placements[k + n]) == key) ++n;
        if (s.instanced) {
            stats.programsFirstDrawn += drawGroupInstances(s, key, k, n);
            ++stats.drawCalls;
        } else {
            for (int i = k; i < k + n; ++i) {  // the paper: a viewport and a draw per ellipsoid
                glViewport(placements[i].x, placements[i].y, placements[i].size, placements[i].size);
                stats.programsFirstDrawn += drawGroupInstances(s, key, i, 1);
                ++stats.drawCalls;
            }
            glViewport(0, 0, plan.atlasW, plan.atlasH);
        }
        k += n;
    }
    for (int c = 0; c < 4; ++c) glDisable(GL_CLIP_DISTANCE0 + c);
    glDisable(GL_CULL_FACE);
    check("ellipsoid tile pass");
}

// The blending of every tile draw: red = T2 - T2 g (reverse subtract), alpha = I/D - T1/D
// (subtract); meshes cull their front faces (a tile is drawn from the mesh's back faces).
void EllipsoidRenderer::Impl::tileDrawState(const EllipsoidSettings& s) {
    if (s.geometry == TileGeometry::Mesh) {
        glEnable(GL_CULL_FACE);
        glCullFace(GL_FRONT);
    }
    glEnable(GL_BLEND);
    glBlendEquationSeparate(GL_FUNC_REVERSE_SUBTRACT, GL_FUNC_SUBTRACT);
    glBlendFunc(GL_ONE, GL_ONE);
}

// The tiles [base, + instances) of one draw group (drawGroup's key): its program, geometry,
// culling and clip distances, and one instanced draw. true: the program's first draw.
bool EllipsoidRenderer::Impl::drawGroupInstances(const EllipsoidSettings& s, int key, int base, int instances) {
    const bool polygon = s.geometry == TileGeometry::Polygon;
    const bool cut = key >= 1000 && key < 2000;
    const bool ray = polygon || key >= 2000;  // polygon tiles, or mesh tiles lit per pixel
    const Program& tp = ray ? (cut ? tileRayCut : tileRay) : (cut ? tileCut : tile);
    glUseProgram(tp.id());
    const IndexedMesh* sphere = ray ? nullptr : &mesh(key % 1000);
    glBindVertexArray(ray ? empty.id() : sphere->vao.id());
    if (!polygon) ray ? glDisable(GL_CULL_FACE) : glEnable(GL_CULL_FACE);
    // Clip distances keep the geometry in its tile (the polygon's whole-tile quad needs none).
    const bool clip = !(ray && cut);
    for (int c = 0; c < 4; ++c) clip ? glEnable(GL_CLIP_DISTANCE0 + c) : glDisable(GL_CLIP_DISTANCE0 + c);
    tp.set("instanceBase", base);
    if (ray) glDrawArraysInstanced(GL_TRIANGLE_FAN, 0, cut ? 4 : 8, instances);  // quad or octagon
    else glDrawElementsInstanced(GL_TRIANGLES, sphere->indexCount, GL_UNSIGNED_INT, nullptr, instances);
    return drawnTilePrograms.insert(tp.id()).second;
}

// Every tile program these settings may draw with, drawn once into one texel of the first fresh
// tile (cleared and drawn again by its pass). llvmpipe compiles a program's machine code at its
// first draw: 0.4-0.5 s for each tile program on a cold shader cache, which a flight met in
// whichever frame first had a tile cut by the near plane or lit per pixel (near the sun).
// Here it is paid in the first frame, which makes every tile anyway.
// Returns how many were drawn for the first time.
int EllipsoidRenderer::Impl::warmTilePrograms(const EllipsoidSettings& s, const FramePlan& plan) {
    const TilePlacement& at = plan.placements.front();
    glBindFramebuffer(GL_FRAMEBUFFER, atlas->fbos[at.pass].id());
    glViewport(0, 0, plan.atlasW, plan.atlasH);
    glEnable(GL_SCISSOR_TEST);
    glScissor(at.x, at.y, 1, 1);
    tileDrawState(s);
    const int slices = meshSlices(s, s.minTile, false);
    const std::vector<int> keys =
        s.geometry == TileGeometry::Mesh ? std::vector<int>{slices, 1000 + slices, 2000} : std::vector<int>{0, 1000};
    int first = 0;
    for (int key : keys) first += drawGroupInstances(s, key, 0, 1);
    for (int c = 0; c < 4; ++c) glDisable(GL_CLIP_DISTANCE0 + c);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    check("tile programs' first draw");
    return first;
}

// The paper's colour-matrix copy of one pass's tiles placements[first, + count), in one draw.
void EllipsoidRenderer::Impl::colourMatrixPass(int first, int count, EllipsoidStats& stats) {
    glTextureBarrier();
    glBindTextureUnit(3, atlas->terms.id());
    glBindSampler(3, 0);
    glBlendEquation(GL_FUNC_REVERSE_SUBTRACT);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_TRUE);
    glBindVertexArray(empty.id());
    glUseProgram(colourMatrix.id());
    colourMatrix.set("instanceBase", first);
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, count);
    ++stats.drawCalls;
    check("colour-matrix pass");
}

}  // namespace nephele
