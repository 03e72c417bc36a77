// Scenes the tests build from a shared one, which no file holds. Header-only.
#pragma once

#include "nephele/scene.hpp"

#include <glm/trigonometric.hpp>

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

// A host's scene: the eye under a layer (2000-2600 m) looking 8 degrees up towards +x, an
// explicit cumulus ahead and a box inside its edge (fly-through) under the layer's shadows; the
// box's depth decides which cloud pixels are hidden, so a wrong depth copy shows.
inline Scene hostScene(int width, int height) {
    Scene s;
    s.camera.position = Vec3(0, 0, 1000);
    s.camera.direction = Vec3(std::cos(glm::radians(8.0)), 0, std::sin(glm::radians(8.0)));
    s.camera.width = width, s.camera.height = height;
    s.camera.fovYDeg = 40;
    Layer l;
    l.base = 2000, l.thickness = 600, l.coverage = 0.6, l.density = 0.8, l.seed = 5, l.extent = 30000;
    l.wind = Vec2(12, -4);
    s.layers.push_back(l);
    Cloud c;
    c.name = "cumulus";
    for (int k = 0; k < 9; ++k) {
        Ellipsoid e;
        e.center = Vec3(3000 + 120 * (k % 3), -400 + 330 * (k % 4) - 60 * k, 1150 + 70 * (k % 2));
        e.radii = Vec3(260, 200, 150);
        e.rotationDeg = Vec3(0, 0, 20.0 * k);
        c.ellipsoids.push_back(e);
    }
    s.clouds.push_back(c);
    Object box;
    box.center = Vec3(2750, 150, 1100);
    box.size = Vec3(200, 200, 200);
    box.color = Vec3(0.6, 0.3, 0.2);
    s.objects.push_back(box);
    return s;
}

}  // namespace nephele::test
