#include "nephele/camera.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <stdexcept>

namespace nephele {

View makeView(const Camera& camera) {
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
    const double aspect = double(camera.width) / double(camera.height);
    v.tanHalfY = std::tan(glm::radians(camera.fovYDeg) * 0.5);
    v.tanHalfX = v.tanHalfY * aspect;
    v.viewMatrix = glm::lookAt(v.eye, v.eye + v.forward, v.up);
    v.projectionMatrix = glm::perspective(glm::radians(camera.fovYDeg), aspect, camera.nearClip, camera.farClip);
    return v;
}

Vec3 View::rayDirection(double px, double py) const {
    const double sx = (2.0 * px / camera.width - 1.0) * tanHalfX;
    const double sy = (1.0 - 2.0 * py / camera.height) * tanHalfY;
    return glm::normalize(forward + sx * right + sy * up);
}

}  // namespace nephele
