// The detail field of shaders/detail.glsl, compiled as C++ (one source with the shaders), and
// the CPU side every method needs of it: the "nephele" kind's texture and the parameters of a
// view. The field (data/scene-format.md, "The detail field"): each ellipsoid's profile
// (1 - q_i)^2 (times the noise factor) becomes max(1 - q_i (1 + delta(x))^2, 0)^2, with
// delta(x) = erosion * D(x - drift; |x - eye|) and D the octave sum of detailValue.
#pragma once

#include "nephele/api.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// The nephele kind's tileable texture (kDetailTextureSize^3 texels, three channels): channel c
// holds min(F1, 1)^2, F1 the distance in cells to the nearest feature point of Worley noise with
// 4 * 2^c cells per period (one point per cell, placed by a hash of the cell and the channel),
// spread about its mean to channel 0's deviation as filtered, and rounded to a multiple of 1/255:
// the GPU holds the same bytes (GL_RGBA8). Built once, the same on every platform.
struct DetailVolume {
    int size = 0;
    std::vector<glm::vec3> texels;  // x fastest, then y, then z, as NoiseVolume's

    // Trilinear filtering with repeat wrap, as NoiseVolume::sample, in float. The GPU's filter
    // of the 8-bit texture differs from it by its own rounding (DetailGLTest.GlslTwinMatchesCpu).
    glm::vec3 sample(const glm::vec3& uvw) const;
};

}  // namespace nephele

namespace nephele::model {
using glm::abs;
using glm::floor;
using glm::log2;
using uint = std::uint32_t;
#define MODEL_FN inline
#define DETAIL_TEX const ::nephele::DetailVolume&
#define DETAIL_FETCH(tex, uvw) (tex).sample(uvw)
#include "nephele/detail.glsl"  // the build's copy of shaders/detail.glsl (model/CMakeLists.txt)
#undef DETAIL_FETCH
#undef DETAIL_TEX
#undef MODEL_FN
}  // namespace nephele::model

namespace nephele {

// The nephele kind's texture (DetailVolume): 64^3 texels of 4 bytes, 1 MB. A larger one cost more
// than it saved on llvmpipe (128^3: the detailed tiles 30% slower).
inline constexpr int kDetailTextureSize = 64;
const DetailVolume& detailVolume();
// The mean of each channel of detailVolume()'s texels, and the reference kind's mean of
// (1 - |perlin|)^8 (data/scene-format.md): what an octave faded out stands in with.
glm::vec3 detailVolumeMeans();
inline constexpr float kDetailReferenceMean = 0.284f;

// The parameters a renderer hands to the shared functions for the eye `eye` (m, world).
model::DetailParams detailParams(const Medium::Detail& detail, const Vec3& eye);

// The erosion delta = E D at the world point x, seen from `eye` (0 when the detail is off).
float detailErosionAt(const Medium::Detail& detail, const Vec3& eye, const Vec3& x);

// The finest wavelength the detail draws at `nearest` metres from the eye (m): where an
// octave's weight reaches 0, max(fadeAngle x nearest, smallest / 2) (detailOctaveCut is log2 of
// the scale over it). In the caller's precision, float or double.
template <class T>
T detailFinestWavelength(T nearest, T smallest) {
    return std::max(T(model::kDetailFadeAngle) * nearest, T(0.5) * smallest);
}

// How many pieces erodedSegmentDepth needs to follow the detail along a chord of `chord` metres
// whose nearest point is `nearest` metres from the eye: a quarter of the finest wavelength drawn
// there, at most kExactPiecesMax (gardner-exact's "exact" opacity, to that quadrature).
inline constexpr int kExactPiecesMax = 256;
int exactPieces(const model::DetailParams& p, float chord, float nearest);

// The eroded profile of one ellipsoid, in units of its density, at unit-space squared radius q.
inline double erodedProfile(double q, double delta) {
    const double f = std::max(1.0 - q * (1.0 + delta) * (1.0 + delta), 0.0);
    return f * f;
}

}  // namespace nephele
NEPHELE_API_END
