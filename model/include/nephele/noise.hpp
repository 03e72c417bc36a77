// Procedural noise for cloud modulation: periodic improved Perlin noise, its fBm, and the
// tileable 3D volume the GPU samples (GL_R32F, GL_LINEAR, GL_REPEAT).
//
// Clouds are ellipsoids whose density is perturbed by 3D Perlin noise / fBm (Elinas &
// Stuerzlinger 2000, §3.2; Jiménez de Parga 2018 stores fBm of Perlin noise in a 64^3
// float volume). Renderers never evaluate noise per sample: they sample a NoiseVolume,
// the GPU through a 3D texture and CPU reference renderers through NoiseVolume::sample,
// which reproduces GL_LINEAR + GL_REPEAT so that both see the same field.
//
// Everything is deterministic from the seed on every platform: the lattice hash is pure
// 32-bit integer arithmetic (no std distributions, no libm beyond floor).
#pragma once

#include "nephele/api.hpp"
#include <glm/glm.hpp>

#include <cstddef>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// Improved Perlin gradient noise (Perlin 2002: quintic fade, 12 edge gradients) on a
// lattice that repeats every `period` cells in x, y and z: the gradient at lattice point
// (i,j,k) depends only on (i mod period, j mod period, k mod period) and the seed.
// Returns about [-1, 1] and exactly 0 at lattice points. Throws std::invalid_argument
// if period < 1.
float perlinNoise(const glm::vec3& p, int period, unsigned seed);

// Fractional Brownian motion: sum_{o<octaves} 0.5^o * perlin(p * 2^o) / sum_{o<octaves} 0.5^o.
// Octave o uses period `period * 2^o` (so the sum repeats every `period`, like octave 0)
// and its own seed derived from `seed` and o. Throws std::invalid_argument if
// octaves < 1, period < 1 or period * 2^(octaves-1) overflows int.
float fbm(const glm::vec3& p, int octaves, int period, unsigned seed);

// The project's noise volume: makeNoiseVolume(size, cells, octaves, seed), read with a period of
// medium.noise_scale * cells metres at ellipsoidNoiseOffset(cloud, index, seed). Every method
// that adds noise to the ellipsoids takes these defaults unless told otherwise, so that all of
// them see the same field (the path tracer always does).
struct NoiseSettings {
    int size = 64;  // texels per side of the tileable volume
    int cells = 8;  // lattice cells per period: one cell is medium.noise_scale metres
    int octaves = 4;
    unsigned seed = 7;
};

// Trilinear filtering with repeat wrap of a size^3 volume of texels (float or glm::vec3), as
// GL_LINEAR + GL_REPEAT samples it at texture coordinate uvw (texel centres at (i + 0.5) / size,
// period 1). At a texel centre it returns that texel exactly; an empty volume gives 0.
template <class T>
T sampleLinearRepeat(const std::vector<T>& texels, int size, const glm::vec3& uvw);

// A size^3 scalar volume, uploaded as a 3D texture and sampled as one.
struct NoiseVolume {
    int size = 0;               // size^3 texels
    std::vector<float> texels;  // x fastest, then y, then z: texels[i + size * (j + size * k)]

    // Trilinear filtering with repeat wrap, as GL_LINEAR + GL_REPEAT samples a size^3
    // texture at texture coordinate uvw (texel centres at (i + 0.5) / size, period 1).
    // At a texel centre it returns that texel exactly. Returns 0 for an empty volume.
    float sample(const glm::vec3& uvw) const;
};

// A tileable fBm volume: texel (i,j,k) = fbm(((i,j,k) + 0.5) * cells / size, octaves,
// period = cells, seed), then rescaled linearly so that the volume's mean is 0 and its
// largest |value| is exactly 1. Because fbm repeats every `cells`, texel size-1 and
// texel 0 are neighbours like any others, and the texture tiles seamlessly.
// Throws std::invalid_argument if size < 2, cells < 1 or octaves < 1.
NoiseVolume makeNoiseVolume(int size, int cells, int octaves, unsigned seed);
// The same of settings' size, cells, octaves and seed.
NoiseVolume makeNoiseVolume(const NoiseSettings& settings);

// Where ellipsoid `index` of cloud `cloud` reads the noise volume: every method that adds the
// project's noise to an ellipsoid (the compositor, gardner-exact, the path-traced reference)
// evaluates n(x / period + offset) for that ellipsoid, so that neighbouring ellipsoids do not
// repeat one pattern and all methods see the same field. The offset is in noise-volume
// texture coordinates (periods), each component in [0, 1); a pure hash of (cloud, index,
// seed), identical on every platform.
glm::dvec3 ellipsoidNoiseOffset(std::size_t cloud, std::size_t index, unsigned seed);

}  // namespace nephele
NEPHELE_API_END
