#include "shadow_pass.hpp"

#include <cmath>

namespace nephele {
using namespace gl;

ShadowPass::ShadowPass() {
    program_ = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "layered_shadow.frag"}});
    empty_ = VertexArray::create();
}

int ShadowPass::draw(const Scene& scene, const View& view, GLuint framebuffer, double t,
                     const std::vector<GLuint>& modulationTextures, const ModulationSettings& ms, double groundHeight) {
    const Vec3 sun = scene.sun.direction;
    if (sun.z <= 0) return 0;  // no sun, no shadow (as sunTransmittance)
    bool any = false;
    for (const Layer& l : scene.layers) any = any || l.coverage * l.density > 0;
    if (!any) return 0;

    const int width = view.camera.width, height = view.camera.height;
    GLint depthBits = 0;
    glGetNamedFramebufferAttachmentParameteriv(framebuffer, framebuffer == 0 ? GL_DEPTH : GL_DEPTH_ATTACHMENT,
                                               GL_FRAMEBUFFER_ATTACHMENT_DEPTH_SIZE, &depthBits);
    const Program& p = program_;
    p.set("hasDepth", depthBits > 0 ? 1 : 0);
    if (depthBits > 0) glBindTextureUnit(0, depth_.copy(framebuffer, width, height));
    p.set("frameDepth", 0);
    p.set("modulation", 1);
    p.set("forward", glm::vec3(view.forward));
    p.set("rightScaled", glm::vec3(view.right * view.tanHalfX));
    p.set("upScaled", glm::vec3(view.up * view.tanHalfY));
    p.set("nearClip", float(view.camera.nearClip));
    p.set("farClip", float(view.camera.farClip));
    p.set("eyeHeight", float(view.eye.z));
    p.set("groundHeight", float(groundHeight));
    p.set("groundSunShare", float(groundSunShare(scene.sun, scene.sky)));
    p.set("sunDirection", glm::vec3(sun));
    p.set("invModPeriod", float(1 / ms.period));

    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    glViewport(0, 0, width, height);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_FALSE);
    glDisable(GL_STENCIL_TEST);
    glDisable(GL_CULL_FACE);
    glDisable(GL_FRAMEBUFFER_SRGB);
    glDisable(GL_RASTERIZER_DISCARD);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    for (int c = 0; c < 8; ++c) glDisable(GLenum(GL_CLIP_DISTANCE0 + c));
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFuncSeparate(GL_ZERO, GL_SRC_COLOR, GL_ZERO, GL_ONE);  // rgb *= S, alpha kept
    glUseProgram(p.id());
    glBindVertexArray(empty_.id());
    glBindSampler(0, 0);
    glBindSampler(1, 0);
    int draws = 0;
    for (std::size_t i = 0; i < scene.layers.size() && i < modulationTextures.size(); ++i) {
        const Layer& layer = scene.layers[i];
        if (!(layer.coverage * layer.density > 0)) continue;  // S = 1 everywhere
        const glm::dvec2 uv = (glm::dvec2(view.eye.x, view.eye.y) - t * layer.wind) / ms.period;
        p.set("uvModEye", glm::vec2(uv - glm::floor(uv)));
        p.set("middle", float(layer.base + 0.5 * layer.thickness));
        p.set("coverage", float(layer.coverage));
        p.set("density", float(layer.density));
        glBindTextureUnit(1, modulationTextures[i]);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        ++draws;
    }
    check("drawing the layered sky's cloud shadows");
    return draws;
}

}  // namespace nephele
