// The light inside one cloud, precomputed on a grid over the cloud's box from the cloud's real
// shape: what every fast method (the compositor, gardner-exact, the ray-marcher and the near
// LOD) reads to light the format's density field as the path tracer does. The model that reads
// it is shaders/cloud_light.glsl.
//
// Per voxel (x fastest; texel centres at boxMin + (i + 0.5) / size * boxExtent), four vec4,
// the layout of the GPU's four RGBA16F 3D textures:
//   sunFew     = (phi1 xyz, phi0): the sunlight scattered 1 to kFewScatterings times in the
//                cloud, by its fluence phi0 (integral of the radiance over the sphere) and net
//                flux phi1 (integral of radiance times the direction it travels), per unit
//                irradiance: forward-peaked, close to the sun's direction;
//   sunMany    = (phi1 xyz, phi0): the sunlight scattered more often: broad, following the
//                cloud's shape. Two lobes fit the light's angular spread where one lobe of the
//                same mean cosine cannot (README, "The light");
//   skyTau     = (phi0 r, g, b, 0): the fluence of the sky's and the ground's light
//                (scattered or not), per colour channel (w unused: the sun's optical depth is
//                on the finer grid below; RadianceSample::skyTau.w carries it);
//   skyFlux    = (phi1 xyz, c20) of that light's luminance: its net flux and its integral
//                against the zonal spherical harmonic Y20.
// and on a grid kSunRefinement times finer per axis (texel centres at boxMin + (i + 0.5) /
// (kSunRefinement size) * boxExtent), one float, the GPU's fifth texture (R16F):
//   sunTransmittance = exp(-sunPower tauSun) = T^p, tauSun the optical depth sigma_t * m from
//                the voxel centre to the sun, closed form through the cloud's ellipsoids; T^p is
//                what is interpolated between voxel centres: a transmittance (p = 1) where a
//                voxel holds little optical depth, towards the optical depth where it holds
//                much (docs/light.md, "The sun's single scattering").
//   sunPower   = p in [0.05, 1], per grid, from the cloud's mean extinction per fine voxel.
// The diffuse light is found by tracing photons from the sun and from the sky and the ground
// through the cloud's extinction (voxelised), with the path tracer's physics (the same
// extinction, albedo and Henyey-Greenstein phase), scored by track length, then lightly
// smoothed. Only the cloud's own matter counts: other clouds neither shadow nor light it. A
// tiled cloud (a piece of a layer, Cloud::tileMin) is traced as one tile of an endless layer
// of copies of itself: the grid spans the tile across, photons enter through its top and
// bottom only and leave through one side to come back through the opposite one, and the sun's
// optical depth goes on through the tiles beyond.
//
// The grid depends on the cloud's ellipsoids relative to each other, the sun's direction, the
// sky, the medium and the settings only: a cloud that moves keeps it (see light_cache.hpp).
#pragma once

#include "nephele/api.hpp"
#include "nephele/background.hpp"
#include "nephele/scene.hpp"

#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

struct RadianceGridSettings {
    // Voxels per side of the grid of a big cloud, 4..128. 32 by the accuracy bench: with the
    // light in two parts (cloud_light.glsl) a finer grid is better everywhere it was measured,
    // most against the sun (the ray-marcher back-lit: 31% at 16^3, 17% at 32^3, 12% at 48^3),
    // at 8 times the photons and memory of 16^3 (docs/light.md). Real cumulus (dense_cumulus.json)
    // would take 64 (its back-lit error 40% at 32^3, 25% at 64^3), but a grid's light read beyond
    // its box moves with its voxel size (docs/light.md, "The grid's size and real cumulus"): not the
    // default yet.
    int size = 32;
    // Each cloud's grid as fine as its optical size needs (radianceGridSize): a small or thin
    // cloud gets 8^3 or 16^3 voxels, and photons in proportion to the grid's cross-section
    // (n^2: a photon crosses about n voxels, so each voxel's tally keeps its noise). false:
    // every grid `size`^3 with all the photons.
    bool fitToCloud = true;
    // Photons traced from the sun, and from the sky and the ground, for a grid of `size`^3,
    // 0..2^26. 2^18 at 32^3: the accuracy bench's cumulus lost under a point against 2^20.
    int sunPhotons = 1 << 18;
    int skyPhotons = 1 << 18;
    int smoothing = 1;  // passes of a [1 2 1]^3 filter over the diffuse light, 0..8
    unsigned seed = 1;  // the photons' random numbers: the same inputs give the same grid
    // Memory for the grids, CPU and GPU together (radianceGridBytes() each), 1..65536 MB. Clouds
    // past it (the smallest on screen first) are lit by a stand-in (model/internal/light_cache.hpp).
    double megabytes = 256;
    // Make missing grids on a worker thread, a stand-in lighting the cloud meanwhile, instead of
    // before the frame (a host's frame loop; SkyRenderer::update() always does).
    bool background = false;
    // How that worker runs (its priority, cores and the cores of a job; nephele/background.hpp):
    // taken from the settings that start it.
    BackgroundSettings backgroundWork;
};

// What an update of the clouds' grids did (model/internal/light_cache.hpp; EllipsoidRenderer::lightStats).
struct RadianceUpdateStats {
    int computed = 0;     // grids made in this call, or finished on the worker since the last call
    int pending = 0;      // grids queued or being made on the worker
    int standIns = 0;     // clouds lit by a stand-in in this call
    int overBudget = 0;   // of those, clouds past the memory budget (the template until they come nearer)
    double workerMs = 0;  // the worker's time for the grids it finished since the last call
};

// Mean radiance of the environment over the whole sphere of directions: the format's sky over
// the upper hemisphere ((zenith + horizon) / 2 there), the ground colour over the lower one.
Vec3 environmentMean(const Sky& sky);

// The layered sky's ambient term: environmentMean(sky). Skylight enters a cloud from every
// side and, the cloud absorbing little, leaves it nearly as bright: about the mean of what
// surrounds it.
Vec3 cloudAmbient(const Sky& sky);

// Scatterings in the cloud that the sunFew lobe holds; the sunMany lobe holds the rest.
inline constexpr int kFewScatterings = 3;

// How much finer per axis the sun's transmittance is held than the diffuse light. It is closed
// form (no photons to share out), and across a lit rim it falls from 1 to almost 0 within a
// voxel of the diffuse light's grid, where interpolation between voxel centres brightens what
// the eye sees: cumulus27 back-lit, its single scattering was 1.077 of the path tracer's with
// the transmittance at 32^3, 1.034 at 48^3 and 1.014 at 64^3 (tests/light_components_test.cpp).
inline constexpr int kSunRefinement = 2;

// Bytes one grid of `size`^3 voxels holds: 4 vec4 of floats on the CPU and 4 RGBA16F on the
// GPU, and (kSunRefinement size)^3 of the sun's transmittance, a float and an R16F.
inline std::size_t radianceGridBytes(int size) {
    const std::size_t n = std::size_t(size) * size * size;
    return n * (4 * 16 + 4 * 8) + n * kSunRefinement * kSunRefinement * kSunRefinement * (4 + 2);
}

struct CloudRadiance {
    Vec3 boxMin{0.0}, boxExtent{1.0};  // m, world (the cloud's axis-aligned box)
    int size = 0;
    std::vector<glm::vec4> sunFew, sunMany, skyTau, skyFlux;  // size^3 each, see above
    std::vector<float> sunTransmittance;                      // sunSize()^3, see above
    float sunPower = 1;                                       // p of sunTransmittance's T^p, see above
    double computeMs = 0;                                     // wall time it took

    std::size_t voxels() const { return std::size_t(size) * size * size; }
    int sunSize() const { return kSunRefinement * size; }
    // The sun's transmittance at the finer grid's voxel i (sunTransmittance holds T^sunPower).
    double sunTransmittanceAt(std::size_t i) const { return std::pow(double(sunTransmittance[i]), 1.0 / sunPower); }
};

// A cloud's optical radius: its volume-weighted extinction times half its box's mean side.
double cloudOpticalRadius(const Scene& scene, const Cloud& cloud);

// The voxels per side of `cloud`'s grid: settings.size, or with fitToCloud the power of two at
// or above its optical radius, between 8 and settings.size (a voxel then spans at most about
// two optical depths; cumulus27.json's cloud gets 32, a puff of optical radius 3 gets 8).
int radianceGridSize(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& settings);

// Throws std::invalid_argument naming the setting that is out of range.
void validate(const RadianceGridSettings& settings);

// The axis-aligned box of the cloud's ellipsoids (m, world); the point 0 for an empty cloud.
void cloudBox(const Cloud& cloud, Vec3& lo, Vec3& hi);

// The box the cloud's radiance grid covers (m, world): cloudBox(), for a tiled cloud
// (Cloud::tiled) its tile across.
void radianceBox(const Cloud& cloud, Vec3& lo, Vec3& hi);

// The sun, sky and medium a cloud's grid is lit by: the scene's own, with Scene::lighting's sun
// direction and sky when it is set (no clouds, layers or objects).
Scene lightSources(const Scene& scene);

// The grid of `cloud` for the scene's sun, sky and medium, radianceGridSize() voxels per side
// with the photons scaled to its cross-section. Deterministic for a seed, whatever
// the thread count. An empty cloud gives a 1 m box with no light. With `cancel`, the work
// stops soon after *cancel becomes true and the grid returned is incomplete (size 0).
CloudRadiance computeCloudRadiance(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& settings = {},
                                   const std::atomic<bool>* cancel = nullptr);

// The four texels at a world point, trilinear between voxel centres and clamped to the
// outermost ones, as the GPU's GL_LINEAR, clamp-to-edge 3D textures read them; skyTau.w the
// sun's optical depth, from the finer grid's T^p interpolated so (floored at
// model::kMinSunTransmittance before its logarithm, over p).
struct RadianceSample {
    glm::vec4 sunFew{0.0f}, sunMany{0.0f}, skyTau{0.0f}, skyFlux{0.0f};
};
RadianceSample sampleRadiance(const CloudRadiance& grid, const Vec3& world);

// The light falling on a surface (W/m^2 per unit of the scene's radiance scale, linear RGB): what
// a host lights its own aircraft by. A Lambertian surface of albedo a sends a / pi * (sun +
// diffuse) (data/scene-format.md, object_light "all"; docs/light.md, "Objects lit by the clouds").
struct SurfaceLight {
    Vec3 sun{0.0};      // the sun's irradiance through the clouds: E_sun max(n.s, 0) T_sun
    Vec3 diffuse{0.0};  // the sky's, the ground's and the clouds' light, from the clouds' grids
};

}  // namespace nephele
NEPHELE_API_END
