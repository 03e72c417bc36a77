// The compositor's and gardner-exact's shared preparation of a frame's ellipsoids (projection,
// culling, Ac, noise offsets) and the chord light both evaluate: private to Nephele::ellipsoid
// (the public face is nephele/gardner.hpp).
#pragma once

#include "nephele/detail.hpp"
#include "nephele/gardner.hpp"
#include "nephele/projection.hpp"

#include <algorithm>
#include <limits>
#include <vector>

namespace nephele {

struct PreparedEllipsoid {
    int cloud = 0, index = 0;  // where it is in scene.clouds
    Ellipsoid shape;
    glm::dmat3 unit{1.0};   // M = diag(1/r) R^T: world offset -> unit sphere
    glm::dmat3 axes{1.0};   // R diag(r): unit sphere -> world offset
    double sigma = 0;       // extinction * density, 1/m
    double ac = 0;          // largest opacity (centre ray, or a bound when cut by the near plane)
    Vec3 noiseOffset{0.0};  // in noise-volume texture coordinates, deterministic per ellipsoid
    EllipsoidProjection projection;
    // The close LOD (EllipsoidSettings::cloudLod, closeTileTexels): the texels across its tile
    // that the ellipsoid's image holds; infinity: as many as it covers on screen (the paper).
    double contentTexels = std::numeric_limits<double>::infinity();
};

// The extent a tile is sized by (tileSizeFor): the ellipsoid's on screen, px, at most what its
// image holds (contentTexels).
inline double tileExtent(const PreparedEllipsoid& e) {
    return std::min(std::max(e.projection.pixelWidth, e.projection.pixelHeight), e.contentTexels);
}

// A sphere holding every ellipsoid of a cloud: centred on their axis-aligned bounding box (each
// ellipsoid's bounding sphere's), its radius the farthest of those spheres from there. A cloud
// without ellipsoids: centre 0, radius 0.
struct CloudSphere {
    Vec3 centre{0.0};
    double radius = 0;
};
CloudSphere cloudBoundingSphere(const Cloud& cloud);

struct PreparedClouds {
    std::vector<PreparedEllipsoid> ellipsoids;  // visible ones, back to front
    std::vector<CloudSphere> spheres;           // per scene cloud: cloudBoundingSphere
    int culled = 0;                             // ellipsoids culled by the projection
    double noisePeriod = 1;                     // m: medium.noise_scale * cells
};

// The close LOD: the texels across the tile of an ellipsoid whose largest radius is `rMax` (m)
// that hold its whole image: kSmoothTileTexels for its smooth part (the falloff, its light from
// the cloud's radiance grid, a few voxels across an ellipsoid), or two tile texels per texel of
// the noise volume (`noiseTexel` m, medium.noise_scale * cells / size; infinity without noise)
// across its diameter, whichever is more. A tile larger than that is magnified on screen with
// nothing lost: a close ellipsoid, or one with the eye inside, seen across the whole view.
constexpr double kSmoothTileTexels = 128;
inline double closeTileTexels(double rMax, double noiseTexel) {
    return std::max(kSmoothTileTexels, 2.0 * (2.0 * rMax) / noiseTexel);
}

// The close LOD with the detail on: the texels across the tile of an ellipsoid of largest radius
// `rMax` (m) whose nearest matter is `nearest` m from the eye that hold the finest octave the
// detail draws there: a texel across its cut r (detailFinestWavelength, where an octave's weight
// reaches 0), so two across the finest octave drawn whole (2r: its Nyquist rate). Farther
// matter's octaves are coarser still.
inline double detailTileTexels(double rMax, double nearest, double smallest) {
    return 2.0 * rMax / detailFinestWavelength(nearest, smallest);
}

// Projects and culls every ellipsoid for `view`, computes Ac and the noise offsets.
PreparedClouds prepareClouds(const Scene& scene, const View& view, const NoiseSettings& noise);

// The weighted composite's reference depth tRef (m), one for the whole frame: the nearest
// visible ellipsoid's centre distance minus its largest radius, at least the near plane and
// model::kWeightNearDepth (matter nearer than that weighs alike). The weights
// (tRef / max(tShade, tRef))^k are at most 1; only their ratios reach the image; tRef keeps
// them within float range (model::compositeWeight).
double weightReferenceDepth(const PreparedClouds& prepared, const View& view);
// The moment composite's depth range [tNear, tFar] (m), warped to [-1, 1] by model::momentDepth:
// tRef as above, and the farthest visible ellipsoid's centre distance plus its largest radius.
// Both continuous in the eye's position.
glm::vec2 momentDepthRange(const PreparedClouds& prepared, const View& view);
// The light an ellipsoid's chord sends to the eye, per unit of the sun's irradiance and of the
// sky's chroma (model::lightScalars at the model::kChordSamples Gauss-Legendre points of the
// chord beyond tStart, in the opacity the eye sees of it): x = sun, y = sky. The ray is
// o' + t d' in the ellipsoid's unit space from the eye at `eye`, d its unit world direction.
glm::vec2 chordLight(const CloudRadiance& grid, const Scene& scene, const Vec3& eye, const Vec3& d,
                     const glm::vec3& oUnit, const glm::vec3& dUnit, float tStart, float sigma);

// The sky light's colour at an ellipsoid (model::skyChroma of the grid's fluence at its centre):
// one per ellipsoid, as the compositor's tiles carry it.
glm::vec3 ellipsoidSkyChroma(const CloudRadiance& grid, const Ellipsoid& e);

}  // namespace nephele
