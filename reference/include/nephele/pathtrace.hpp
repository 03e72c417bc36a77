// The physically based reference: a spectral-free (RGB) volumetric path tracer of the
// format's density field (shared/scene-format.md), against which the fast methods are charted.
//
// What it renders, exactly as the format defines it:
// - cloud matter: sigma_t(x) = medium.extinction * sum_i rho_i(x) (1/m), per ellipsoid i
//   (cloud c, index k in it) rho_i(x) = density_i (1 - q_i)^2, with medium.noise > 0
//   rho_i(x) * max(0, 1 + noise * n(x / P + o_i)), n(uvw) = noise->sample(uvw),
//   P = medium.noise_scale * NoiseSettings{}.cells (m; the project's tileable fBm volume,
//   anchored to the world), o_i = ellipsoidNoiseOffset(c, k, NoiseSettings{}.seed): the
//   same noise coordinates as the compositor and gardner-exact read for that ellipsoid;
//   with medium.detail on, each ellipsoid's (1 - q_i)^2 eroded to max(1 - q_i (1 + e(x))^2, 0)^2,
//   e the detail field seen from the view's eye (nephele/detail.hpp);
//   sigma_s = albedo * sigma_t; Henyey-Greenstein phase (hg_g);
// - the sun, a directional light of irradiance sun.color * sun.intensity, sampled at every
//   scattering vertex (next-event estimation) through the clouds and the objects;
// - the sky: a path that leaves the medium sees skyRadiance() (ground colour below the horizon);
// - opaque objects: Lambert under the sun only, shadowed by clouds and other objects, and no
//   sky or indirect light (the format's rule); paths end at objects.
// - the scene's layers, when PathTraceSettings::layers holds them: each a volume of the layered
//   sky's density (nephele/layer_volume.hpp), with the medium's albedo and phase, lit and
//   shadowing as the clouds do.
// `generate` entries must be expanded beforehand; skylight and lightning are not part of this
// reference.
//
// One ray per sample through each pixel centre (as the fast methods sample), clipped to the
// camera's near/far planes as the GPU clips. Free flights by delta tracking under a
// piecewise-constant majorant, sun transmittance in closed form when medium.noise == 0 (ratio
// tracking otherwise; through layers ratio tracking, with Russian roulette below 1%), no
// Russian roulette of paths.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/cloud_matter.hpp"  // kMaxOpticalDepth
#include "nephele/image.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <memory>
#include <string>

NEPHELE_API_BEGIN
namespace nephele {

class LayerVolumes;  // nephele/layer_volume.hpp

// What it takes as given, whatever Scene it is handed (a host may build one in code, past the
// loader's limits), so that a render ends in bounded time:
// - each ellipsoid's extinction is capped so that its optical depth through the centre along
//   its shortest axis is at most kMaxOpticalDepth (opaque in double precision; the capped rim
//   is under 2e-5 of the radius, below a pixel up to 50000 pixels across);
// - medium.noise must be at most kMaxPathTraceNoise (above 1, max(0, 1 + noise n) cuts empty
//   holes into the matter whose crossing costs majorant x length tentative collisions);
// - free flights use majorants graded towards the ends of optically deep chords, and a step too
//   short to move the distance in double precision collides where it stands.
inline constexpr double kMaxPathTraceNoise = 1;

struct PathTraceSettings {
    int spp = 64;  // samples per pixel, >= 1
    // Scattering events (new directions) per path, >= 0; 0 = single scattering via NEE only. Past
    // 32 the orders left out carried 4% of the light 100 m under a
    // deck of optical depth about 15 (albedo 0.99, g 0.85); by 128 none is left there to float
    // precision. A path dies when it leaves the matter, so a higher cap costs only the paths that
    // would have been cut (6% more time under that deck).
    int maxBounces = 1024;
    // Only the orders firstBounce..maxBounces (0..maxBounces; 0 = all): a contribution's order is
    // the number of new directions its path took before it. With the same seed, the orders
    // 0..k plus the orders k+1..n are the image with maxBounces n, to float round-off.
    int firstBounce = 0;
    unsigned seed = 1;      // same seed, scene and settings -> bit-identical image, whatever the thread count
    bool progress = false;  // report progress through nephele::reportProgress (nephele/log.hpp)
    // The scene's layers as volumes (made for this scene and time); null: layers are left out.
    std::shared_ptr<const LayerVolumes> layers;
};

// Seconds renderPathTraced would take here for these settings on an otherwise idle machine
// (all cores): a pilot render of every 8th pixel of every 8th row at up to 2 spp, its CPU
// time scaled (about 1/64 of a 2-spp render's cost). renderPathTraced logs this estimate (LogLevel::Info) before
// renders of at least 10^6 samples that it expects to take 2 s or more. Throws as renderPathTraced.
double estimatePathTraceSeconds(const Scene& scene, const View& view, const PathTraceSettings& s,
                                const NoiseVolume* noise);

// RGBA: rgb linear radiance, a = cloud opacity along the primary ray (1 - transmittance of
// cloud matter between the near plane and the first opaque surface or the far plane; exact
// closed form when medium.noise == 0 and no layers are rendered, the mean of ratio-tracking
// estimates otherwise).
// `noise` may be null only when scene.medium.noise == 0. Throws std::invalid_argument on bad
// settings or a scene it cannot render (non-finite numbers, medium.noise over
// kMaxPathTraceNoise), ResourceError (nephele/resources.hpp) when the image does not fit in
// memory. Progress goes to nephele::reportProgress when settings.progress is set.
Image renderPathTraced(const Scene& scene, const View& view, const PathTraceSettings& s, const NoiseVolume* noise);

// The same, cached under cacheDir (created if missing): the file name is a hash of every
// input that affects the image (the view's camera, sun, sky, medium, clouds, objects, the
// noise volume when medium.noise > 0, the layers with their textures and time when rendered,
// spp, maxBounces, firstBounce, seed and a version constant), and the
// file holds the whole key, so a hash collision is a miss. Files are written atomically
// (temporary name, then rename) and end with a checksum (core/internal/cache_file.hpp); a damaged
// file (checksum, length, a NaN, a negative radiance, an opacity over 1) or something other
// than a regular file there (read without blocking) is rendered again with a warning through
// the log callback (nephele/log.hpp), never used.
Image renderPathTracedCached(const Scene& scene, const View& view, const PathTraceSettings& s, const NoiseVolume* noise,
                             const std::string& cacheDir);

// The extinction field (1/m) that renderPathTraced renders, at a point: the ellipsoids' matter
// as the path tracer holds it (each ellipsoid's sigma capped as above, the noise factor with
// the same offsets), plus the layers' extinction when `layers` is given (centred on `eye`, as
// PathTraceSettings::layers with View::eye). For exports of the field (nephele export --vdb)
// and for tests. Throws std::invalid_argument as renderPathTraced for a scene it cannot render.
class ExtinctionField {
public:
    ExtinctionField(const Scene& scene, const NoiseVolume* noise, std::shared_ptr<const LayerVolumes> layers = nullptr,
                    const Vec3& eye = Vec3(0.0));
    ~ExtinctionField();
    ExtinctionField(const ExtinctionField&) = delete;
    ExtinctionField& operator=(const ExtinctionField&) = delete;

    double operator()(const Vec3& p) const;  // thread-safe
    // The world box outside which the field is 0: the ellipsoids' boxes and the layers' slabs
    // (their extent about the eye). lo > hi on some axis when the scene holds no matter.
    const Vec3& lo() const { return lo_; }
    const Vec3& hi() const { return hi_; }
    bool empty() const { return !(lo_.x <= hi_.x && lo_.y <= hi_.y && lo_.z <= hi_.z); }

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    Vec3 lo_{0.0}, hi_{0.0};
};

}  // namespace nephele
NEPHELE_API_END
