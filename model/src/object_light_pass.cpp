// The objects lit by the clouds (object_light_pass.hpp).
#include "object_light_pass.hpp"

#include "nephele/gardner_model.hpp"
#include "nephele/gl_state.hpp"

#include <algorithm>
#include <cmath>

namespace nephele {
namespace model {
namespace {
// A cloud's grid as shaders/object_light.glsl reads it on the CPU: at points relative to its
// box's corner, in float as on the GPU (relative to the eye there).
struct PlacedGrid {
    const PlacedRadiance& radiance;
};
RadianceSample gridSample(const PlacedGrid& g, vec3 rel) { return g.radiance.sample(g.radiance.lo + Vec3(rel)); }
float gridSunTransmittance(const PlacedGrid& g, vec3 rel) { return std::exp(-gridSample(g, rel).skyTau.w); }
using glm::equal;
#define MODEL_FN inline
#define CLOUD_GRID const PlacedGrid&
#include "nephele/object_light.glsl"  // the build's copy of shaders/object_light.glsl (model/CMakeLists.txt)
#undef CLOUD_GRID
#undef MODEL_FN
}  // namespace
}  // namespace model

using namespace gl;

struct ObjectLightPass::Programs {
    ObjectMeshes meshes;
    Program box, sphere;
};

ObjectLightPass::ObjectLightPass() = default;
ObjectLightPass::~ObjectLightPass() = default;

void ObjectLightPass::draw(const Scene& scene, const View& view, const HostFrame& frame,
                           const CloudLightTextures& textures, const std::vector<PlacedRadiance>& light) {
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
    // object.frag's objectIrradiance: the same source.
    const glm::vec3 sunIrradiance(scene.sun.color * scene.sun.intensity);
    model::ObjectIrradiance l =
        model::openSkyLight(glm::vec3(scene.sky.zenith), glm::vec3(scene.sky.horizon), glm::vec3(scene.sky.ground),
                            glm::vec3(normal), glm::vec3(scene.sun.direction));
    for (const PlacedRadiance& c : light)
        l = model::addCloudLight(l, model::PlacedGrid{c}, glm::vec3(point - c.lo), glm::vec3(0.0f),
                                 glm::vec3(c.extent));
    SurfaceLight out;
    out.sun = Vec3(model::objectSunIrradiance(l, sunIrradiance));
    out.diffuse = Vec3(model::objectDiffuseIrradiance(l, sunIrradiance));
    return out;
}

}  // namespace nephele
