// The volumetric ray-marcher (`--method raymarch`) after Jiménez de Parga & Gómez Palomo
// 2018, "Efficient Algorithms for Real-Time GPU Volumetric Cloud Rendering with Enhanced
// Geometry" (shared/papers/jimenez-de-parga-2018-volumetric-spheroids.txt).
//
// Per pixel, in one fragment-shader pass over a full-screen triangle (shaders/raymarch.frag):
//   1. the ray against every cloud's bounding box (Smits' slab test, section 3.4; boxes in
//      a storage buffer); the clouds hit are taken front to back;
//   2. per cloud, the candidates (Algorithm 1, getCandidates): the ellipsoids the ray meets,
//      intersected in each one's unit space, with entry and exit distances, kept sorted by
//      entry with insertion sort (sortCandidates);
//   3. the sorted candidates are marched front to back with the no-duplicate-tracing rule of
//      Algorithm 2: the march position never goes back, so overlaps are marched once and
//      the gaps between candidates are skipped; the density at a sample is the sum over the
//      candidates that contain it. The march stops when the transmittance falls below 1e-4.
//   4. the step is the paper's distance-dependent LOD (Algorithm 1, line 50):
//      step * (1 + distance / lodDistance), distance = the sample's distance from the eye.
//
// The density (per ellipsoid i, p its unit-space position, q = |p|^2):
//   noise == 0: exactly the format's field, density_i * (1 - q)^2 for q < 1 — the quantity
//               exactDensityOpacity() and the path-traced reference integrate;
//   noise  > 0: the format's field times the noise's density factor, as the path tracer's:
//               (sum_i density_i (1 - q_i)^2) * max(0, 1 + kappa n(x)), kappa = medium.noise,
//               n(x) in [-1, 1] sampled from a tileable makeNoiseVolume(64, 8, octaves) texture
//               anchored to the world, one lattice cell per medium.noise_scale metres (the same
//               field as NoiseVolume::sample on the CPU, with the reference's anchoring
//               x / (noise_scale * 8); one field for the sum where the reference offsets it per
//               ellipsoid). The paper's pseudo-spheroid, eq. (2), modulates the radius instead,
//               r_eff = r (1 + kappa n(x)): it grew the cloud by the noise's spread and, against
//               the path tracer, put a back-lit cumulus at 21% error where the density factor
//               gives 17.5% (docs/light.md). Candidates are the ellipsoids themselves.
//
// Lighting (Algorithm 3): a segment of length dl adds T * (1 - exp(-sigma_t dl)) * S(x, d) and
// multiplies T by exp(-sigma_t dl) (the exact exp instead of the paper's first two Maclaurin
// terms), with S the source of Nephele's one light model (shaders/cloud_light.glsl, shared
// with the compositor and gardner-exact): the sun's single scattering and the diffuse light of
// the sun and of the sky from the cloud's radiance grid (nephele/cloud_radiance.hpp), read at
// every step. The grids are kept while the clouds only move (model/internal/light_cache.hpp). With
// noise the grid is that of the smooth field.
// Opaque objects: with opaqueDepth the march ends at the opaque surface (a copy of the
// frame's depth), so an object inside a cloud is covered only by the matter in front of it.
// Resolution: RaymarchSettings::downsample (2: one ray per 2x2 pixels, upsampled with the depth).
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/cloud_radiance.hpp"
#include "nephele/gl.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"

#include <memory>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

struct RaymarchSettings {
    double step = 25;            // m, base step along the ray, > 0
    double lodDistance = 4000;   // m: the step grows as step * (1 + distance / lodDistance) (the paper's
                                 // distance-dependent LOD); 0 = fixed step
    RadianceGridSettings light;  // each cloud's radiance grid (nephele/cloud_radiance.hpp): what lights it
    int octaves = 5;             // fBm octaves of the noise (with medium.noise > 0), 1..8 (the paper uses 5)
    int maxSteps = 2048;         // per pixel, a safety cap, 1..65536: a march that reaches it stops there
    // 1..4: march one ray per downsample x downsample pixels, into a target of 1/downsample of the
    // frame's size per side, upsampled over the frame with its depth (core's ReducedTarget, as the
    // layered sky's layers and the compositor's close tiles: the frame's depth reduced per block to
    // its farthest, the rays ended there, nearest-depth upsampling, so an object's silhouette stays
    // sharp); 1 = a ray per pixel. A cloud's light changes slowly across the screen, and the march
    // costs its pixels: 2 takes about a third of the time (docs/methods.md, "Speed against accuracy"). A
    // frame whose view comes within the sun's phase peak (model::withinSunPeak) is marched a ray
    // per pixel whatever this is: a back-lit cloud's bright rim is thinner than a block.
    int downsample = 2;
};

struct RaymarchStats {
    int ellipsoids = 0, clouds = 0;  // in the scene
    int lightGridsComputed = 0;      // radiance grids computed in this call (0 when all were kept)
    int lightStandIns = 0;           // clouds lit by a stand-in (light_cache.hpp): grids pending or past the budget
    double planMs = 0;               // wall ms of this call before its draw (light grids included)
    int downsample = 1;  // the frame's: RaymarchSettings::downsample, or 1 looking within the sun's phase peak
};

// ---- The CPU side (the paper's host code), also what the tests check the GPU against.

// The noise the marcher samples: the project's tileable fBm volume (64^3, 8 lattice cells per
// period, seed 7, as NoiseSettings{}) with settings.octaves octaves.
NoiseSettings raymarchNoiseSettings(const RaymarchSettings& settings);
// The noise period in metres: medium.noise_scale * cells; n(x) = noise.sample(x / period).
double raymarchNoisePeriod(const Medium& medium, const NoiseSettings& noise);

// The box that holds every point of `cloud` the marcher can see: cloudBox(), the ellipsoids'
// exact axis-aligned boxes (the noise scales the density, not the shape). False for a cloud
// without ellipsoids.
bool raymarchCloudBox(const Cloud& cloud, Vec3& lo, Vec3& hi);

// The extinction the marcher integrates at world point x, 1/m: medium.extinction times the
// sum over the cloud's ellipsoids of density_i (1 - q_i)^2 where q_i < 1, times
// max(0, 1 + medium.noise * n(x)) (1, the format's field exactly, when medium.noise == 0;
// `noise` may then be null).
double raymarchExtinction(const Medium& medium, const Cloud& cloud, const Vec3& x, const NoiseVolume* noise,
                          double noisePeriod);

// The optical depth / extinction (density x metres) along o + l dir, l in [0, infinity), through
// the density of `cloud`, marched with Algorithm 2's no-duplicate tracing at step
// `step`: the sorted candidates' union is marched once, overlaps and gaps are not. Stops early
// once the depth exceeds `stopDepth`. At most 1024 steps whatever the step and the clouds'
// size: the step is at least the candidates' span / 1024, and always moves the distance.
double marchDensityNdt(const Medium& medium, const Cloud& cloud, const Vec3& o, const Vec3& dir, double step,
                       const NoiseVolume* noise, double noisePeriod, double stopDepth = 1e300);

// ---- The GPU renderer.
// Needs a current OpenGL 4.5 context; leaves the GL state as it found it.
// Throws std::invalid_argument naming the setting that is out of range.
void validate(const RaymarchSettings& settings);

class RaymarchRenderer {
public:
    // Throws std::invalid_argument on settings out of range.
    explicit RaymarchRenderer(const RaymarchSettings& settings = {});
    ~RaymarchRenderer();
    RaymarchRenderer(const RaymarchRenderer&) = delete;
    RaymarchRenderer& operator=(const RaymarchRenderer&) = delete;

    const RaymarchSettings& settings() const { return settings_; }

    // Same contract as EllipsoidRenderer::render: draws the scene's clouds "over" `framebuffer`
    // (width x height of view.camera; colour attachment 0 with rgb = linear radiance and
    // a = cloud opacity, accumulated: a' = a_cloud + (1 - a_cloud) a). With `opaqueDepth` the
    // rays end at the depth in the framebuffer's depth attachment (read from a copy).
    // Pixels whose rays meet no cloud matter are left untouched.
    RaymarchStats render(const Scene& scene, const View& view, GLuint framebuffer, bool opaqueDepth);

private:
    struct Impl;
    RaymarchSettings settings_;
    std::unique_ptr<Impl> impl_;
};

}  // namespace nephele
NEPHELE_API_END
