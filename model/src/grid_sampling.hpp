// Reading a grid of n^3 values held at voxel centres over a box (x fastest), as the GPU's
// GL_LINEAR, clamp-to-edge 3D textures read them: the radiance grids (cloud_radiance.cpp) and
// the detail's erosion over a grid (grid_erosion.cpp).
#pragma once

#include "nephele/scene.hpp"

#include <cstddef>

namespace nephele {

// The trilinear weights at a world point of a grid of n^3 voxel centres over the box, clamped
// to the outermost centres: f(index, weight) per corner. n >= 2.
template <class F>
void trilinear(const Vec3& boxMin, const Vec3& boxExtent, int n, const Vec3& world, F&& f) {
    const Vec3 p = glm::clamp((world - boxMin) / boxExtent * double(n) - 0.5, Vec3(0.0), Vec3(n - 1));
    const glm::ivec3 i0 = glm::min(glm::ivec3(p), glm::ivec3(n - 2));
    const glm::vec3 fr = glm::vec3(p - Vec3(i0));
    for (int c = 0; c < 8; ++c) {
        const glm::ivec3 o(c & 1, (c >> 1) & 1, c >> 2);
        const glm::ivec3 at = i0 + o;
        const glm::vec3 t = glm::mix(glm::vec3(1.0f) - fr, fr, glm::vec3(o));
        f((std::size_t(at.z) * n + at.y) * n + at.x, t.x * t.y * t.z);
    }
}

}  // namespace nephele
