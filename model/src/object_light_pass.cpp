// The objects lit by the clouds (object_light_pass.hpp).
#include "object_light_pass.hpp"

#include "nephele/gardner_model.hpp"
#include "nephele/gl_state.hpp"

#include <algorithm>
#include <cmath>

namespace nephele {
using namespace gl;

struct ObjectLightPass::Programs {
    ObjectMeshes meshes;
    Program box, sphere;
};

ObjectLightPass::ObjectLightPass() = default;
ObjectLightPass::~ObjectLightPass() = default;

void ObjectLightPass::draw(const Scene& scene, const View& view, const HostFrame& frame, const CloudLightTextures& textures,
                           const std::vector<PlacedRadiance>& light) {
    HostStateScope scope;  // the passes after it start from the state they found
    if (!programs_) {
        programs_ = std::make_unique<Programs>();
        const std::string lit = "#define CLOUD_LIGHT 1\n";
        programs_->box = Program::build({{GL_VERTEX_SHADER, "object.vert"}, {GL_FRAGMENT_SHADER, "object.frag"}}, lit);
        programs_->sphere = Program::build({{GL_VERTEX_SHADER, "object.vert"}, {GL_FRAGMENT_SHADER, "object.frag"}},
                                           lit + "#define SPHERE 1\n");
    }
    for (const Program* p : {&programs_->box, &programs_->sphere}) {
        textures.bind(*p);
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
    programs_->meshes.draw(scene, view, programs_->box, programs_->sphere);
}

SurfaceLight ObjectLightPass::lightAt(const Scene& scene, const std::vector<PlacedRadiance>& light, const Vec3& point,
                                      const Vec3& normal) {
    // object.frag's objectIrradiance, per cloud.
    const glm::vec3 n(normal), s(scene.sun.direction);
    const glm::vec3 invS = 1.0f / (s + glm::vec3(glm::equal(s, glm::vec3(0.0f))) * 1e-9f);
    const glm::vec3 open = model::openSkyIrradiance(glm::vec3(scene.sky.zenith), glm::vec3(scene.sky.horizon),
                                                    glm::vec3(scene.sky.ground), n);
    glm::dvec3 sky(open);
    double sunDiffuse = 0, transmittance = 1;
    for (const PlacedRadiance& c : light) {
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
