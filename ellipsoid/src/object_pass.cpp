// Objects lit by the clouds (object_light "all", data/scene-format.md): the scene's objects,
// already drawn by OpaquePass with their depth, drawn again in place with object.frag's
// CLOUD_LIGHT variant, which reads the clouds' grids the tiles are lit from (docs/light.md,
// "Objects lit by the clouds"). Drawn before any cloud, over the objects' own depth.
#include "compositor_impl.hpp"

#include "nephele/gl_state.hpp"

namespace nephele {

void EllipsoidRenderer::Impl::drawLitObjects(const Scene& scene, const View& view, const HostFrame& frame) {
    HostStateScope scope;  // the passes after it start from the state they found
    if (!objectLight) {
        objectLight = std::make_unique<ObjectLightPass>();
        const std::string lit = "#define CLOUD_LIGHT 1\n";
        objectLight->box = Program::build({{GL_VERTEX_SHADER, "object.vert"}, {GL_FRAGMENT_SHADER, "object.frag"}}, lit);
        objectLight->sphere = Program::build({{GL_VERTEX_SHADER, "object.vert"}, {GL_FRAGMENT_SHADER, "object.frag"}},
                                             lit + "#define SPHERE 1\n");
    }
    lightTextures.setBoxes(light, view.eye);
    for (const Program* p : {&objectLight->box, &objectLight->sphere}) {
        lightTextures.bind(*p);
        p->set("cloudCount", int(light.size()));
        p->set("sunDirection", glm::vec3(scene.sun.direction));
        p->set("sunIrradiance", glm::vec3(scene.sun.color * scene.sun.intensity));
        p->set("skyZenith", glm::vec3(scene.sky.zenith));
        p->set("skyHorizon", glm::vec3(scene.sky.horizon));
        p->set("skyGround", glm::vec3(scene.sky.ground));
    }
    bindFrame(frame, view);
    glDisable(GL_BLEND);
    glDisable(GL_STENCIL_TEST);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    // The same surfaces at the same depth: the test passes where the object is the nearest.
    frameDepthTest(view);
    glDepthFunc(view.depth.reversedZ ? GL_GEQUAL : GL_LEQUAL);
    glDepthMask(GL_FALSE);
    objectLight->meshes.draw(scene, view, objectLight->box, objectLight->sphere);
}

SurfaceLight EllipsoidRenderer::lightAt(const Scene& scene, const Vec3& point, const Vec3& normal) const {
    // object.frag's objectIrradiance, per cloud from the CPU copy of its grid (sampleRadiance
    // reads it as the GPU does).
    const glm::vec3 n(normal), s(scene.sun.direction);
    const glm::vec3 invS = 1.0f / (s + glm::vec3(glm::equal(s, glm::vec3(0.0f))) * 1e-9f);
    const glm::vec3 open = model::openSkyIrradiance(glm::vec3(scene.sky.zenith), glm::vec3(scene.sky.horizon),
                                                    glm::vec3(scene.sky.ground), n);
    glm::dvec3 sky(open);
    double sunDiffuse = 0, transmittance = 1;
    for (const PlacedRadiance& c : impl_->light) {
        // Relative to the box's corner, in float as on the GPU (relative to the eye there).
        const glm::vec3 p(point - c.lo), extent(c.extent);
        const float tIn = model::boxEntry(p, invS, glm::vec3(0.0f), extent);
        if (tIn >= 0) transmittance *= std::exp(-c.sample(point + double(tIn) * Vec3(s)).skyTau.w);
        const float fade = model::gridFade(glm::length(p - glm::clamp(p, glm::vec3(0.0f), extent)),
                                           (extent.x + extent.y + extent.z) / 6);
        if (fade < 1e-3f) continue;
        const RadianceSample r = c.sample(point);
        const glm::vec2 e = model::gridIrradiance(r.sunFew, r.sunMany, r.skyTau, r.skyFlux, n);
        sunDiffuse += fade * e.x;
        sky += double(fade) * (glm::dvec3(model::skyChroma(glm::vec3(r.skyTau))) * double(e.y) - glm::dvec3(open));
    }
    const Vec3 sun = scene.sun.color * scene.sun.intensity;
    SurfaceLight out;
    out.sun = sun * (std::max(glm::dot(normal, scene.sun.direction), 0.0) * transmittance);
    out.diffuse = sun * sunDiffuse + glm::max(sky, Vec3(0.0));
    return out;
}

}  // namespace nephele
