#include "shadow_pass.hpp"

#include "nephele/gl_state.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace nephele {
using namespace gl;

ShadowPass::ShadowPass() {
    program_ = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "layered_shadow.frag"}},
                              shadowSlotsDefine());
    empty_ = VertexArray::create();
}

std::vector<int> ShadowPass::shadowingLayers(const Scene& scene) {
    std::vector<int> out;
    if (!(scene.sun.direction.z > 0)) return out;  // no sun, no shadow (as sunTransmittance)
    for (std::size_t i = 0; i < scene.layers.size(); ++i)
        if (scene.layers[i].coverage * scene.layers[i].density > 0) out.push_back(int(i));  // else S = 1
    return out;
}

int ShadowPass::setUniforms(const Program& p, const Scene& scene, const View& view, double t,
                            const std::vector<int>& layers, int first, const std::vector<GLuint>& modulationTextures,
                            const ModulationSettings& ms, double groundHeight) {
    const int count = std::clamp(int(layers.size()) - first, 0, kLayersPerPass);
    p.set("shadowLayerCount", count);
    p.set("shadowRayCentre", glm::vec3(view.rayCentre()));
    p.set("shadowRightScaled", glm::vec3(view.rightScaled()));
    p.set("shadowUpScaled", glm::vec3(view.upScaled()));
    p.set("shadowFar", float(view.camera.farClip));
    p.set("shadowEyeHeight", float(view.eye.z));
    p.set("groundHeight", float(groundHeight));
    p.set("groundSunShare", float(groundSunShare(scene.sun, scene.sky)));
    p.set("shadowSun", glm::vec3(scene.sun.direction));
    p.set("shadowInvModPeriod", float(1 / ms.period));
    for (int k = 0; k < kLayersPerPass; ++k) {
        std::string i = "[";  // appended: "[" + to_string(k) trips a GCC 12 -Wrestrict false positive
        i += std::to_string(k);
        i += ']';
        p.set(("shadowModulation" + i).c_str(), kFirstUnit + k);
        glBindSampler(kFirstUnit + k, 0);
        if (k >= count) continue;
        const int li = layers[first + k];
        const Layer& layer = scene.layers[li];
        const glm::dvec2 uv = (glm::dvec2(view.eye.x, view.eye.y) - layerDrift(layer, t)) / ms.period;
        p.set(("shadowUvModEye" + i).c_str(), glm::vec2(uv - glm::floor(uv)));
        p.set(("shadowMiddle" + i).c_str(), float(layer.base + 0.5 * layer.thickness));
        p.set(("shadowCoverage" + i).c_str(), float(layer.coverage));
        p.set(("shadowDensity" + i).c_str(), float(layer.density));
        glBindTextureUnit(kFirstUnit + k, modulationTextures[li]);
    }
    return count;
}

int ShadowPass::draw(const Scene& scene, const View& view, const HostFrame& frame, const DepthSource& frameDepth,
                     double t, const std::vector<int>& layers, const std::vector<GLuint>& modulationTextures,
                     const ModulationSettings& ms, double groundHeight) {
    if (layers.empty()) return 0;
    const Program& p = program_;
    p.set("hasDepth", frameDepth.texture != 0 ? 1 : 0);
    p.set("frameDepth", 0);
    setViewFrameUniforms(p, view, true, frameDepth);
    glBindTextureUnit(0, frameDepth.texture);
    glBindSampler(0, 0);
    resetPassState();
    bindFrame(frame, view);
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFuncSeparate(GL_ZERO, GL_SRC_COLOR, GL_ZERO, GL_ONE);  // rgb *= S, alpha kept
    glUseProgram(p.id());
    glBindVertexArray(empty_.id());
    int draws = 0;
    for (int first = 0; first < int(layers.size()); first += kLayersPerPass) {
        setUniforms(p, scene, view, t, layers, first, modulationTextures, ms, groundHeight);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        ++draws;
    }
    check("drawing the layered sky's cloud shadows");
    return draws;
}

}  // namespace nephele
