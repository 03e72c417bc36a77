// View maths shared by the GPU passes and the CPU references, so both see the same rays.
#pragma once

#include "nephele/scene.hpp"

#include <glm/glm.hpp>

namespace nephele {

struct View {
    Camera camera;
    Vec3 eye{0.0};
    Vec3 forward{0, 1, 0}, right{1, 0, 0}, up{0, 0, 1};  // orthonormal, right-handed
    double tanHalfY = 0, tanHalfX = 0;                    // of the vertical / horizontal half-angles
    glm::dmat4 viewMatrix{1.0};        // world -> eye, OpenGL convention (looks down -z)
    glm::dmat4 projectionMatrix{1.0};  // eye -> clip, perspective with the camera's near/far

    // Unit world direction through image point (px, py), in pixels from the top-left
    // corner; the centre of pixel (i, j) is (i + 0.5, j + 0.5).
    Vec3 rayDirection(double px, double py) const;
};

// Throws std::invalid_argument if the camera's direction is zero or parallel to up.
View makeView(const Camera& camera);

}  // namespace nephele
