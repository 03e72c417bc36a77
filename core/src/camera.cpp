#include "nephele/camera.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace nephele {

namespace {

// The camera's eye and orthonormal basis (forward, right, up).
View cameraBasis(const Camera& camera) {
    View v;
    v.camera = camera;
    v.eye = camera.position;
    const double len = glm::length(camera.direction);
    if (!(len > 0)) throw std::invalid_argument("camera direction is zero");
    v.forward = camera.direction / len;
    const Vec3 side = glm::cross(v.forward, camera.up);
    if (glm::length(side) < 1e-9 * glm::length(camera.up))
        throw std::invalid_argument("camera up is parallel to the view direction");
    v.right = glm::normalize(side);
    v.up = glm::cross(v.right, v.forward);
    return v;
}

void setFrustum(View& v, const Frustum& f) {
    v.frustum = f;
    v.tanHalfX = 0.5 * (f.right - f.left);
    v.tanHalfY = 0.5 * (f.top - f.bottom);
    v.camera.fovYDeg = glm::degrees(2 * std::atan(v.tanHalfY));
}

}  // namespace

Frustum symmetricFrustum(double fovYDeg, double aspect) {
    const double y = std::tan(glm::radians(fovYDeg) * 0.5), x = y * aspect;
    return {-x, x, -y, y};
}

View makeView(const Camera& camera) {
    View v = cameraBasis(camera);
    const double aspect = double(camera.width) / double(camera.height);
    setFrustum(v, symmetricFrustum(camera.fovYDeg, aspect));
    v.camera.fovYDeg = camera.fovYDeg;
    v.viewMatrix = glm::lookAt(v.eye, v.eye + v.forward, v.up);
    v.projectionMatrix = glm::perspective(glm::radians(camera.fovYDeg), aspect, camera.nearClip, camera.farClip);
    return v;
}

View makeView(const Camera& camera, const Frustum& f, double yawDeg, double pitchDeg) {
    if (!(std::isfinite(f.left) && std::isfinite(f.right) && std::isfinite(f.bottom) && std::isfinite(f.top) &&
          f.left < f.right && f.bottom < f.top))
        throw std::invalid_argument("frustum: the tangents must be finite with left < right and bottom < top");
    if (!(std::isfinite(yawDeg) && std::isfinite(pitchDeg)))
        throw std::invalid_argument("channel rotation: yaw and pitch must be finite");
    View v = cameraBasis(camera);
    // Yaw about the camera's up (positive to the right), then pitch about the turned right axis.
    const double yaw = glm::radians(yawDeg), pitch = glm::radians(pitchDeg);
    const Vec3 f1 = std::cos(yaw) * v.forward + std::sin(yaw) * v.right;
    const Vec3 r1 = std::cos(yaw) * v.right - std::sin(yaw) * v.forward;
    v.forward = std::cos(pitch) * f1 + std::sin(pitch) * v.up;
    v.up = std::cos(pitch) * v.up - std::sin(pitch) * f1;
    v.right = r1;
    v.camera.direction = v.forward;
    v.camera.up = v.up;
    setFrustum(v, f);
    const double n = camera.nearClip;
    v.viewMatrix = glm::lookAt(v.eye, v.eye + v.forward, v.up);
    v.projectionMatrix = glm::frustum(f.left * n, f.right * n, f.bottom * n, f.top * n, n, camera.farClip);
    return v;
}

glm::dmat4 View::rotationViewProjection() const {
    glm::dmat4 rotation = viewMatrix;
    rotation[3] = glm::dvec4(0, 0, 0, 1);
    return projectionMatrix * rotation;
}

Vec3 View::rayCentre() const {
    return forward + 0.5 * (frustum.left + frustum.right) * right + 0.5 * (frustum.bottom + frustum.top) * up;
}

double View::ndcX(double tangent) const { return (tangent - 0.5 * (frustum.left + frustum.right)) / tanHalfX; }
double View::ndcY(double tangent) const { return (tangent - 0.5 * (frustum.bottom + frustum.top)) / tanHalfY; }

Vec3 View::rayDirection(double px, double py) const {
    const double sx = (2.0 * px / camera.width - 1.0) * tanHalfX + 0.5 * (frustum.left + frustum.right);
    const double sy = (1.0 - 2.0 * py / camera.height) * tanHalfY + 0.5 * (frustum.bottom + frustum.top);
    return glm::normalize(forward + sx * right + sy * up);
}

glm::dvec3 View::depthParameters() const {
    // Clip-space depth c = s d + b; eye depth z = P32 / (c + P22) for any perspective matrix.
    const double s = depth.zeroToOne ? 1.0 : 2.0, b = depth.zeroToOne ? 0.0 : -1.0;
    const double p22 = projectionMatrix[2][2], p32 = projectionMatrix[3][2];
    return {s / p32, (b + p22) / p32, farDepth()};
}

}  // namespace nephele
