// The layered sky's model compiled as C++ with glm from its GLSL sources, so that the
// precomputation, the CPU twins and the tests share one source with the shaders: the light of
// shaders/layer_light.glsl (after the shared model of gardner_model.glsl / cloud_light.glsl, whose
// source function it uses) and the shadow of shaders/layer_shadow.glsl.
#pragma once

#include "nephele/gardner_model.hpp"

namespace nephele::model {
#define MODEL_FN inline
#include "nephele/layer_light.glsl"  // the build's copies (layered/CMakeLists.txt)
#include "nephele/layer_shadow.glsl"
#undef MODEL_FN
}  // namespace nephele::model
