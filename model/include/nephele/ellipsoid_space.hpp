// An ellipsoid's own space, where it is the unit sphere: the frame in which every method
// evaluates the model's density (shaders/gardner_model.glsl) and its chords.
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

#include <glm/glm.hpp>

NEPHELE_API_BEGIN
namespace nephele {

// Matrices for the shaders: world -> ellipsoid unit-sphere space, M = diag(1/r) * R^T applied
// to (x - c); a world point x is inside the ellipsoid iff |M (x - c)| < 1.
glm::dmat3 ellipsoidToUnit(const Ellipsoid& e);  // diag(1/r) * R^T

}  // namespace nephele
NEPHELE_API_END
