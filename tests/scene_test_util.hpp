// Scenes the tests build from a shared one, which no file holds. Header-only.
#pragma once

#include "nephele/scene.hpp"

#include <cmath>

namespace nephele::test {

// The scene's first cloud seen from 2 km back along the camera's view, through its ellipsoids'
// mean centre, with the sun `degrees` off the view axis behind the cloud (20 on cumulus27: the
// accuracy bench's back-lit case), where the phase peak magnifies every error of the sun's
// transmittance and the silver lining shows.
inline Scene backLit(Scene scene, double degrees = 20) {
    Vec3 centre(0.0);
    for (const Ellipsoid& e : scene.clouds.at(0).ellipsoids) centre += e.center;
    centre /= double(scene.clouds[0].ellipsoids.size());
    const Vec3 forward = glm::normalize(scene.camera.direction);
    scene.camera.position = centre - 2000.0 * forward;
    const Vec3 side = glm::normalize(glm::cross(forward, Vec3(0, 0, 1))), up = glm::cross(side, forward);
    const double off = glm::radians(degrees);
    scene.sun.direction = glm::normalize(std::cos(off) * forward + std::sin(off) * up);  // towards the sun
    return scene;
}

}  // namespace nephele::test
