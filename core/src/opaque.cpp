#include "nephele/opaque.hpp"

#include "nephele/frame_depth.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/host_view.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <numbers>

namespace nephele {
using namespace gl;

FrameTarget::FrameTarget(int width, int height) : width_(width), height_(height) {
    const std::string what = "the " + std::to_string(width) + "x" + std::to_string(height) + " frame";
    checkTextureSize(what, width, height);
    GLint maxWidth = 0, maxHeight = 0;
    glGetIntegerv(GL_MAX_FRAMEBUFFER_WIDTH, &maxWidth);
    glGetIntegerv(GL_MAX_FRAMEBUFFER_HEIGHT, &maxHeight);
    if (width > maxWidth || height > maxHeight)
        throw GlError(what + " is over this driver's GL_MAX_FRAMEBUFFER_WIDTH/HEIGHT " + std::to_string(maxWidth) +
                      "x" + std::to_string(maxHeight));
    const std::uint64_t pixels = std::uint64_t(width) * std::uint64_t(height);
    color_ = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(color_.id(), 1, GL_RGBA32F, width, height);
    checkAllocation(what + "'s RGBA32F colour", pixels * 16);
    depth_ = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(depth_.id(), 1, GL_DEPTH24_STENCIL8, width, height);
    checkAllocation(what + "'s depth", pixels * 4);
    fbo_ = Framebuffer::create();
    glNamedFramebufferTexture(fbo_.id(), GL_COLOR_ATTACHMENT0, color_.id(), 0);
    glNamedFramebufferTexture(fbo_.id(), GL_DEPTH_STENCIL_ATTACHMENT, depth_.id(), 0);
    checkFramebuffer(fbo_.id(), what);
    checkAlways("creating the frame target");
}

Image FrameTarget::readColor() const {
    Image bottomUp(width_, height_, 4);
    GlStateGuard guard;
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glGetTextureImage(color_.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(bottomUp.pixels.size() * sizeof(float)),
                      bottomUp.pixels.data());
    checkAlways("reading back the frame");
    Image image(width_, height_, 4);
    const std::size_t row = std::size_t(width_) * 4;
    for (int y = 0; y < height_; ++y)
        std::copy_n(bottomUp.pixels.data() + std::size_t(height_ - 1 - y) * row, row, image.pixels.data() + y * row);
    return image;
}

namespace {

// Interleaved position (3) + normal (3) of a unit cube [-0.5, 0.5]^3, 4 vertices a face.
void cube(std::vector<float>& v, std::vector<unsigned>& idx) {
    for (int axis = 0; axis < 3; ++axis)
        for (int sign = -1; sign <= 1; sign += 2) {
            const unsigned base = unsigned(v.size() / 6);
            const int u = (axis + 1) % 3, w = (axis + 2) % 3;
            for (int k = 0; k < 4; ++k) {
                float p[3], n[3] = {0, 0, 0};
                p[axis] = 0.5f * sign;
                p[u] = (k == 1 || k == 2) ? 0.5f : -0.5f;
                p[w] = (k >= 2) ? 0.5f : -0.5f;
                n[axis] = float(sign);
                v.insert(v.end(), {p[0], p[1], p[2], n[0], n[1], n[2]});
            }
            // Counter-clockwise seen from outside.
            if (sign > 0) idx.insert(idx.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
            else idx.insert(idx.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
        }
}

glm::mat4 toFloat(const glm::dmat4& m) { return glm::mat4(m); }

}  // namespace

OpaquePass::OpaquePass() {
    sky_ = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "sky.frag"}});
    object_ = Program::build({{GL_VERTEX_SHADER, "object.vert"}, {GL_FRAGMENT_SHADER, "object.frag"}});
    sphereProgram_ =
        Program::build({{GL_VERTEX_SHADER, "object.vert"}, {GL_FRAGMENT_SHADER, "object.frag"}}, "#define SPHERE 1\n");
    empty_ = VertexArray::create();
    checkAlways("creating the opaque pass");
}

ObjectMeshes::ObjectMeshes() {
    std::vector<float> v;
    std::vector<unsigned> idx;
    cube(v, idx);
    box_ = makeIndexedMesh(v, idx, 2);  // position, normal
    checkAlways("creating the objects' meshes");
}

void ObjectMeshes::draw(const Scene& scene, const View& view, const Program& box, const Program& sphereProgram) const {
    glEnable(GL_CULL_FACE);
    glFrontFace(GL_CCW);
    glBindVertexArray(box_.vao.id());
    // Camera-relative: the eye is the origin, so float precision holds far from (0,0,0).
    const glm::dmat4 viewRotation = glm::lookAt(Vec3(0.0), view.forward, view.up);
    const glm::mat4 viewProjection = toFloat(view.projectionMatrix * viewRotation);
    for (const Program* p : {&box, &sphereProgram}) p->set("viewProjection", viewProjection);
    for (const Object& o : scene.objects) {
        const bool sphere = o.type == Object::Type::Sphere;
        const Program& p = sphere ? sphereProgram : box;
        const glm::dmat3 r = sphere ? glm::dmat3(1.0) : rotationFromDegrees(o.rotationDeg);
        const Vec3 size = sphere ? Vec3(2.0 * o.radius) : o.size;
        glm::dmat4 model = glm::translate(glm::dmat4(1.0), o.center - view.eye) * glm::dmat4(r);
        model = glm::scale(model, size);
        p.set("model", toFloat(model));
        p.set("normalMatrix", glm::mat3(r));
        p.set("albedo", glm::vec3(o.color));
        if (sphere) {
            p.set("sphereCenter", glm::vec3(o.center - view.eye));
            p.set("sphereRadius", float(o.radius));
        }
        // A sphere's box is drawn by its back faces so that it still covers the sphere
        // when the eye is inside the box.
        glCullFace(sphere ? GL_FRONT : GL_BACK);
        glUseProgram(p.id());
        glDrawElements(GL_TRIANGLES, box_.indexCount, GL_UNSIGNED_INT, nullptr);
    }
    check("drawing the opaque objects");
}

void OpaquePass::draw(const Scene& scene, const View& view, GLuint framebuffer) const {
    HostStateScope scope;
    HostFrame frame{framebuffer};
    frame.srgb = colorTargetOf(viewDescOf(view, framebuffer)) == ColorTarget::Srgb8;
    bindFrame(frame, view);
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
    glStencilMask(0xFF);
    glClearColor(0, 0, 0, 0);
    glClearDepth(view.farDepth());
    glClearStencil(0);
    // The view's viewport only: several channels may share the framebuffer.
    glEnable(GL_SCISSOR_TEST);
    glScissor(view.origin.x, view.origin.y, view.camera.width, view.camera.height);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);

    // Sky: behind everything, no depth written.
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    sky_.set("rayCentre", glm::vec3(view.rayCentre()));
    sky_.set("rightScaled", glm::vec3(view.rightScaled()));
    sky_.set("upScaled", glm::vec3(view.upScaled()));
    sky_.set("zenith", glm::vec3(scene.sky.zenith));
    sky_.set("horizon", glm::vec3(scene.sky.horizon));
    sky_.set("ground", glm::vec3(scene.sky.ground));
    glUseProgram(sky_.id());
    glBindVertexArray(empty_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    check("drawing the sky");

    if (scene.objects.empty()) return;
    frameDepthTest(view);
    glDepthMask(GL_TRUE);
    const glm::vec3 sunRadiance(scene.sun.color * scene.sun.intensity / std::numbers::pi);
    for (const Program* p : {&object_, &sphereProgram_}) {
        p->set("sunDirection", glm::vec3(scene.sun.direction));
        p->set("sunRadiance", sunRadiance);
    }
    objects_.draw(scene, view, object_, sphereProgram_);
}

}  // namespace nephele
