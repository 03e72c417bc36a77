#include "nephele/host_view.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace nephele {
using namespace gl;

namespace {

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument("view: " + what); }

bool finite(const glm::dmat4& m) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r])) return false;
    return true;
}

// The eye and the orthonormal axes of a rigid world -> eye matrix (rows of its rotation:
// right, up, -forward).
void readViewMatrix(const glm::dmat4& m, View& v) {
    if (!finite(m)) bad("the view matrix has a non-finite element");
    if (std::abs(m[0][3]) + std::abs(m[1][3]) + std::abs(m[2][3]) > 1e-9 || std::abs(m[3][3] - 1) > 1e-9)
        bad("the view matrix's last row must be (0, 0, 0, 1) (a rigid world -> eye transform)");
    const glm::dmat3 r(m);
    const glm::dmat3 gram = glm::transpose(r) * r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (std::abs(gram[i][j] - (i == j ? 1.0 : 0.0)) > 1e-5)
                bad("the view matrix's rotation is not orthonormal (a scale or shear?)");
    if (glm::determinant(r) < 0) bad("the view matrix mirrors (determinant < 0)");
    const glm::dmat3 rt = glm::transpose(r);  // columns: right, up, -forward in world space
    v.eye = -(rt * Vec3(m[3]));
    v.forward = glm::normalize(-rt[2]);
    v.right = glm::normalize(glm::cross(v.forward, rt[1]));
    v.up = glm::cross(v.right, v.forward);
}

}  // namespace

View makeView(const ViewDesc& d) {
    const glm::ivec4 vp = d.viewport;
    if (vp.z < 1 || vp.w < 1 || vp.z > 16384 || vp.w > 16384)
        bad("the viewport is " + std::to_string(vp.z) + "x" + std::to_string(vp.w) +
            " pixels; each side must be 1..16384");
    if (vp.x < 0 || vp.y < 0) bad("the viewport's offset must not be negative");
    View v;
    readViewMatrix(d.view, v);

    if (!finite(d.projection)) bad("the projection matrix has a non-finite element");
    const double w = -d.projection[2][3];
    if (!(w > 0)) bad("the projection must be a perspective frustum looking down -z (clip w = -z_eye)");
    const glm::dmat4 p = d.projection / w;
    const double scale = std::abs(p[0][0]) + std::abs(p[1][1]);
    const double off = std::abs(p[0][1]) + std::abs(p[1][0]) + std::abs(p[0][2]) + std::abs(p[1][2]) +
                       std::abs(p[0][3]) + std::abs(p[1][3]) + std::abs(p[3][0]) + std::abs(p[3][1]) +
                       std::abs(p[3][3]);
    if (!(p[0][0] > 0 && p[1][1] > 0) || off > 1e-9 * scale)
        bad("the projection is not a perspective frustum (expected the form of glm::frustum: no rotation, "
            "no orthographic part)");
    const Frustum f{(p[2][0] - 1) / p[0][0], (p[2][0] + 1) / p[0][0], (p[2][1] - 1) / p[1][1], (p[2][1] + 1) / p[1][1]};
    // Eye depth at clip-space depth c: p32 / (c + p22), whatever the convention.
    const DepthConvention& dc = d.depth;
    const double cNear = dc.reversedZ ? 1.0 : (dc.zeroToOne ? 0.0 : -1.0);
    const double cFar = dc.reversedZ ? (dc.zeroToOne ? 0.0 : -1.0) : 1.0;
    const double nearClip = p[3][2] / (cNear + p[2][2]);
    const double farDenominator = cFar + p[2][2];
    const double farClip = std::abs(farDenominator) < 1e-12 ? INFINITY : p[3][2] / farDenominator;
    if (!(nearClip > 0 && std::isfinite(nearClip)) || !(farClip > nearClip))
        bad("the projection's near and far planes (" + std::to_string(nearClip) + ", " + std::to_string(farClip) +
            " m in the stated depth convention) do not satisfy 0 < near < far: is the depth convention "
            "(reversedZ, zeroToOne) the projection's?");

    v.frustum = f;
    v.tanHalfX = 0.5 * (f.right - f.left);
    v.tanHalfY = 0.5 * (f.top - f.bottom);
    v.camera.position = v.eye;
    v.camera.direction = v.forward;
    v.camera.up = v.up;
    v.camera.fovYDeg = glm::degrees(2 * std::atan(v.tanHalfY));
    v.camera.nearClip = nearClip;
    v.camera.farClip = std::min(farClip, kMaxFar);
    if (!(v.camera.farClip > nearClip))
        bad("the projection's near plane lies beyond " + std::to_string(kMaxFar) + " m");
    v.camera.width = vp.z;
    v.camera.height = vp.w;
    v.viewMatrix = glm::lookAt(v.eye, v.eye + v.forward, v.up);
    v.projectionMatrix = p;
    v.depth = dc;
    v.origin = glm::ivec2(vp.x, vp.y);
    return v;
}

void checkHostObjects(const ViewDesc& d) {
    if (d.framebuffer != 0) {
        const std::string name = "ViewDesc::framebuffer " + std::to_string(d.framebuffer);
        if (!glIsFramebuffer(d.framebuffer))
            throw std::invalid_argument(name + " is not a framebuffer object of the current context");
        const GLenum status = glCheckNamedFramebufferStatus(d.framebuffer, GL_DRAW_FRAMEBUFFER);
        if (status != GL_FRAMEBUFFER_COMPLETE)
            throw std::invalid_argument(name + " is incomplete: " + gl::framebufferStatusName(status));
    }
    if (d.hasDepth && d.depthTexture != 0) {
        const std::string name = "ViewDesc::depthTexture " + std::to_string(d.depthTexture);
        if (!glIsTexture(d.depthTexture))
            throw std::invalid_argument(name + " is not a texture object of the current context");
        GLint target = 0, format = 0, width = 0, height = 0;
        glGetTextureParameteriv(d.depthTexture, GL_TEXTURE_TARGET, &target);
        if (target != GL_TEXTURE_2D)
            throw std::invalid_argument(name +
                                        " is not a GL_TEXTURE_2D (a multisampled depth is copied from the "
                                        "framebuffer instead: leave depthTexture 0)");
        glGetTextureLevelParameteriv(d.depthTexture, 0, GL_TEXTURE_INTERNAL_FORMAT, &format);
        glGetTextureLevelParameteriv(d.depthTexture, 0, GL_TEXTURE_WIDTH, &width);
        glGetTextureLevelParameteriv(d.depthTexture, 0, GL_TEXTURE_HEIGHT, &height);
        switch (format) {
            case GL_DEPTH_COMPONENT:
            case GL_DEPTH_STENCIL:
            case GL_DEPTH_COMPONENT16:
            case GL_DEPTH_COMPONENT24:
            case GL_DEPTH_COMPONENT32:
            case GL_DEPTH_COMPONENT32F:
            case GL_DEPTH24_STENCIL8:
            case GL_DEPTH32F_STENCIL8: break;
            default:
                throw std::invalid_argument(name + " is not of a depth format (internal format " +
                                            std::to_string(format) + ")");
        }
        if (width < d.viewport.x + d.viewport.z || height < d.viewport.y + d.viewport.w)
            throw std::invalid_argument(name + " is " + std::to_string(width) + "x" + std::to_string(height) +
                                        ", smaller than the viewport's extent " +
                                        std::to_string(d.viewport.x + d.viewport.z) + "x" +
                                        std::to_string(d.viewport.y + d.viewport.w));
    }
}

ColorTarget colorTargetOf(const ViewDesc& d) {
    if (d.color != ColorTarget::Auto) return d.color;
    // A window's framebuffer: drivers report sRGB-capable visuals as GL_SRGB whatever the window
    // asked for (Mesa), so linear unless the host says Srgb8.
    if (d.framebuffer == 0) return ColorTarget::Unorm8;
    if (!glIsFramebuffer(d.framebuffer))
        throw std::invalid_argument("ViewDesc::framebuffer " + std::to_string(d.framebuffer) +
                                    " is not a framebuffer object of the current context");
    GLint type = GL_NONE, encoding = GL_LINEAR, component = GL_UNSIGNED_NORMALIZED;
    GLint attachment = GLint(d.drawBuffer);
    if (attachment == GL_NONE) {  // the host's draw buffer 0: a draw buffer is asked of the bound framebuffer
        GLint bound = 0;
        glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &bound);
        glBindFramebuffer(GL_DRAW_FRAMEBUFFER, d.framebuffer);
        glGetIntegerv(GL_DRAW_BUFFER0, &attachment);
        glBindFramebuffer(GL_DRAW_FRAMEBUFFER, GLuint(bound));
        if (attachment == GL_NONE) return ColorTarget::Unorm8;  // bindFrame reports it
    }
    glGetNamedFramebufferAttachmentParameteriv(d.framebuffer, GLenum(attachment), GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE,
                                               &type);
    if (type == GL_NONE) return ColorTarget::Unorm8;  // no colour attachment: bindFrame names it
    glGetNamedFramebufferAttachmentParameteriv(d.framebuffer, GLenum(attachment),
                                               GL_FRAMEBUFFER_ATTACHMENT_COLOR_ENCODING, &encoding);
    glGetNamedFramebufferAttachmentParameteriv(d.framebuffer, GLenum(attachment),
                                               GL_FRAMEBUFFER_ATTACHMENT_COMPONENT_TYPE, &component);
    if (encoding == GL_SRGB) return ColorTarget::Srgb8;
    return component == GL_FLOAT ? ColorTarget::Float : ColorTarget::Unorm8;
}

ViewDesc viewDescOf(const View& view, GLuint framebuffer, bool hasDepth) {
    ViewDesc d;
    d.view = view.viewMatrix;
    d.projection = view.projectionMatrix;
    d.depth = view.depth;
    d.viewport = glm::ivec4(view.origin, view.camera.width, view.camera.height);
    d.framebuffer = framebuffer;
    d.hasDepth = hasDepth;
    d.cloudShadows = true;
    return d;
}

}  // namespace nephele
