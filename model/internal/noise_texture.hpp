// A NoiseVolume on the GPU: an R32F 3D texture read with GL_LINEAR and GL_REPEAT, the filtering
// NoiseVolume::sample reproduces on the CPU (the density noise of the compositor and the
// ray-marcher, the detail's texture). NoiseGLTest holds the two to each other.
#pragma once

#include "nephele/api.hpp"
#include "nephele/gl.hpp"
#include "nephele/noise.hpp"

NEPHELE_API_BEGIN
namespace nephele {

gl::Texture noiseTexture(const NoiseVolume& volume);

}  // namespace nephele
NEPHELE_API_END
