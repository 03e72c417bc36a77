// A NoiseVolume on the GPU: an R32F 3D texture read with GL_LINEAR and GL_REPEAT, the filtering
// NoiseVolume::sample reproduces on the CPU (the density noise of the compositor and the
// ray-marcher). NoiseGLTest holds the two to each other.
#pragma once

#include "nephele/api.hpp"
#include "nephele/gl.hpp"
#include "nephele/noise.hpp"

NEPHELE_API_BEGIN
namespace nephele {

gl::Texture noiseTexture(const NoiseVolume& volume);

// A size^3 texture of `internalFormat` from `texels` (`format`, `type`), one level, sampled with
// GL_LINEAR and GL_REPEAT as sampleLinearRepeat (nephele/noise.hpp) reproduces: noiseTexture's
// and the detail's (model/src/detail_texture.cpp).
gl::Texture linearRepeatTexture3D(int size, GLenum internalFormat, GLenum format, GLenum type, const void* texels);

}  // namespace nephele
NEPHELE_API_END
