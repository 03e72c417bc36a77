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

}  // namespace nephele
