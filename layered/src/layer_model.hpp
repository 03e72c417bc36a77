// The layered sky's light model of shaders/layer_light.glsl compiled as C++ with glm (after the
// shared model of gardner_model.glsl / cloud_light.glsl, whose source function it uses), so that
// the precomputation, the tests and the shader share one source.
#pragma once

#include "nephele/gardner_model.hpp"

namespace nephele::model {
#define MODEL_FN inline
#include "nephele/layer_light.glsl"  // the build's copy (layered/CMakeLists.txt)
#undef MODEL_FN
}  // namespace nephele::model
