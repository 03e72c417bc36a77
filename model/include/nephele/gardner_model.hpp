// The Gardner ellipsoid model of shaders/gardner_model.glsl, compiled as C++ with glm so
// that the exact CPU model and the GPU shaders share one source.
#pragma once

#include "nephele/api.hpp"
#include <glm/glm.hpp>

#include <numbers>

NEPHELE_API_BEGIN
namespace nephele::model {
using glm::acos;
using glm::clamp;
using glm::dot;
using glm::exp;
using glm::length;
using glm::log;
using glm::max;
using glm::min;
using glm::pow;
using glm::sqrt;
using glm::vec2;
using glm::vec3;
using glm::vec4;
#define MODEL_FN inline
#include "nephele/gardner_model.glsl"  // the build's copy of shaders/gardner_model.glsl (model/CMakeLists.txt)
#undef MODEL_FN

// The sun's phase peak: where the HG phase is at least kSunPeakPhase times the isotropic one
// (g = 0.85: within about 24 degrees of the sun). There p(d . s) exp(-tauSun) magnifies every
// change of tauSun across the screen (the thin, bright rim of a back-lit cloud), so the light is
// taken per pixel: the compositor's tiles there are lit per pixel, and the ray-marcher marches a
// ray per pixel. At 2 (30 degrees) the compositor's back-lit error was the same, but the weather
// bench's tiles took 2-3x as long while the flight looked within 30 degrees of the sun.
constexpr float kSunPeakPhase = 4;
inline bool withinSunPeak(double cosAngle, double g) {
    return hgPhase(float(cosAngle), float(g)) >= kSunPeakPhase / (4 * std::numbers::pi_v<float>);
}
}  // namespace nephele::model
NEPHELE_API_END
