#include "nephele/ellipsoid_space.hpp"

namespace nephele {

glm::dmat3 ellipsoidToUnit(const Ellipsoid& e) {
    const glm::dmat3 invRadii(1.0 / e.radii.x, 0, 0, 0, 1.0 / e.radii.y, 0, 0, 0, 1.0 / e.radii.z);
    return invRadii * glm::transpose(rotationFromDegrees(e.rotationDeg));
}

}  // namespace nephele
