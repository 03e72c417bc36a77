// The Gardner ellipsoid model of shaders/gardner_model.glsl, compiled as C++ with glm so
// that the exact CPU model and the GPU shaders share one source.
#pragma once

#include <glm/glm.hpp>

namespace nephele::model {
using glm::clamp;
using glm::dot;
using glm::exp;
using glm::log;
using glm::length;
using glm::max;
using glm::min;
using glm::pow;
using glm::sqrt;
using glm::vec2;
using glm::vec3;
using glm::vec4;
#define MODEL_FN inline
#include "nephele/gardner_model.glsl"  // the build's copy of shaders/gardner_model.glsl (core/CMakeLists.txt)
#undef MODEL_FN
}  // namespace nephele::model
