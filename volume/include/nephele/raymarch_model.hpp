// The ray-marcher's light model of shaders/raymarch_model.glsl, compiled as C++ with glm so
// that the CPU twin in the tests and the GPU shader share one source.
#pragma once

#include <glm/glm.hpp>

namespace nephele::rmodel {
using glm::exp;
using glm::max;
using glm::sqrt;
using glm::vec3;
#define RM_FN inline
#include "../../../shaders/raymarch_model.glsl"
#undef RM_FN
}  // namespace nephele::rmodel
