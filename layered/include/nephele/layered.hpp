// The layered LOD sky (`--method layered`) after Wang, Ji & Zhang 2011, "Using instance for
// large scale volumetric clouds rendering in real-time" (shared/papers/wang-ji-zhang-2011-*).
//
// 1. Lighting precomputation (CPU, all cores; precomputeLighting()): a tileable cloud volume
//    of one layer (x, y tile `tilePeriod` metres, z the layer's thickness) holds, per texel,
//    the density A (alpha) and the optical depth of the column above it at three thresholds of
//    eq. (16) (rgb, encoded; `columns` the whole column's), and the light tables photon-traced
//    through it with the medium's extinction, albedo and phase (layered/src/layer_light.cpp).
//    The paper's recurrences (5)-(8) are replaced by this (issue #10), so that the layer is lit
//    by the model every other method uses. Saved to / loaded from a checksummed binary file
//    (LightingVolume::save/load) and cached by a hash of its parameters (lightingCached()).
// 2. Geometry: LOD1 = N instanced annuli at H_i = base + i thickness / (N - 1) (12), the eye
//    at the centre, from lod0Radius out to the layer's extent; LOD0 = billboards, vertical
//    slices facing the horizontal view direction every `lod0Spacing` m across the disc of
//    radius lod0Radius, width and height by eq. (13). Two instanced draws per scene layer,
//    whatever N is. Inside the LOD0 disc both represent the same volume: a fragment's optical
//    depth is shared between them by the ray's elevation (layers for steep rays, billboards
//    for grazing ones), so the sum is the volume's once.
// 3. Appearance: a 2D modulation texture (fBm from the layer's seed; red = the threshold r,
//    histogram-equalised so that the covered fraction follows C, green = where cities glow)
//    gives the density D * max(A - (r + 1 - C), 0), eq. (16). Beyond the paper, a fragment's
//    opacity is 1 - exp(-extinction * density * path), path = the length of the eye ray in
//    the slab the layer stands for (thickness / N / |d.z|), so that grazing rays see
//    more matter, as they do in a volume. Colour (premultiplied, alpha = opacity, "over"):
//    the source function every method shares (shaders/cloud_light.glsl, docs/light.md),
//    S = albedo [E (p(d . s) exp(-tauSun) + J_sun) + J_sky], with the layer's own statistics
//    standing in for a cloud's radiance grid (shaders/layer_light.glsl): tauSun from the
//    optical depth of the fragment's column above it (the lighting volume's rgb holds those
//    column depths at three thresholds), J_sun and J_sky from tables of the mean diffuse light
//    at a given depth above and below, photon-traced through the lighting volume with the
//    medium's physics (layered/src/layer_light.cpp); plus glow (20) and lightning (21).
//    E = colour * intensity. Wind moves the 2D and 3D texture coordinates by the integrated
//    drift (18).
//    Textures are mipmapped (the 3D one GL_LINEAR_MIPMAP_NEAREST, fewer fetches on llvmpipe),
//    so far away the GPU thresholds filtered A and r; the CPU twins below sample level 0.
// 4. Shadows (19): the frame's surfaces are multiplied by S (shaders/layered_shadow.glsl,
//    points reconstructed from a copy of the frame's depth; the ground is the plane z =
//    groundHeight, of which the sun's share is shadowed), fused into the upsampling pass at
//    reduced resolution, else a full-screen pass before the layers; sunTransmittance() is its
//    CPU twin.
// 5. The hand-off to the near field: see nearFade() and layerModulation().
// 6. Speed (`nephele bench --layered`): llvmpipe runs a fragment shader to its end whatever it
//    discards, so the layers cost covered pixels x N x the whole shader; they are drawn at
//    1/downsample of the resolution (texture gradients scaled back so the detail is that of a
//    full-resolution pixel) and upsampled with the frame's depth.
#pragma once

#include "nephele/api.hpp"
#include "nephele/background.hpp"
#include "nephele/camera.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/gl.hpp"
#include "nephele/scene.hpp"

#include <atomic>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// ---------------------------------------------------------------------------------------
// The lighting volume

// The largest lighting volume per side: GL 4.5's least GL_MAX_3D_TEXTURE_SIZE, so every
// conforming driver can hold it (memory permitting: see lightingBytes()).
inline constexpr int kMaxLightingSize = 2048;

struct LightingSettings {
    int width = 256, height = 256, depth = 32;  // texels (the paper's 256 x 256 x 32), 2..kMaxLightingSize each
    double tilePeriod = 8000;                   // m, horizontal period of the 3D texture (the paper: 16000 units)
    int octaves = 4;                            // fBm octaves of the volume's density, 1..8
    int cells = 8;                              // fBm lattice cells per tile period, >= 1
    unsigned seed = 1;                          // of the volume's density (not the layer's modulation seed)
    int photons = 1 << 13;  // photons traced per light source and threshold for the diffuse light, 64..2^22
                            // (0: no diffuse light, single scattering alone: the accuracy bench's split)
    int tableBins = 16;     // nodes of the light tables per optical-depth axis, 4..64
};

// The layer's diffuse light (layered/src/layer_light.cpp; the model is shaders/layer_light.glsl):
// photons traced through the lighting volume's density at the thresholds theta_k with the
// medium's albedo and Henyey-Greenstein phase, scored at their collisions into the nodes of
// (tableCoord(tauAbove), tableCoord(tauBelow)) of the collision's column, over the volume's
// extinction there: the extinction-weighted mean light of the points of the layer that have
// those optical depths above and below them.
struct LayerLightTables {
    int bins = 0;              // nodes per axis; node (i, j) at above u = (i + 0.5) / bins, below (j + 0.5) / bins
    std::vector<float> sunMu;  // the sun's elevations (sines) the sun tables are for, ascending
    // Per sun elevation, bins x bins (i fastest): the sunlight scattered 1 to kFewScatterings
    // times, per unit irradiance: (phi0 fluence, phi1 net flux along the sun's horizontal
    // direction, phi1 z, 0); sunMany the same of the sunlight scattered more often (the two
    // parts of cloud_light.glsl: a forward lobe and the diffusion regime).
    std::vector<glm::vec4> sun, sunMany;
    // Per sky basis (0: radiance 1 from every direction above the horizon, 1: radiance d.z
    // there, 2: radiance 1 from below; the format's sky is horizon, zenith - horizon and ground
    // times these), bins x bins: (phi0, phi1 z, c20, 0) of its light, scattered or not.
    std::vector<glm::vec4> sky;
    std::size_t node(int i, int j) const { return std::size_t(j) * bins + i; }
};

// What the volume depends on (besides LightingSettings): the medium and the layer's thickness.
struct LightingParameters {
    double extinction = 0.04;  // 1/m at density 1 (medium.extinction)
    double albedo = 0.99;      // medium.albedo
    double csG = 0.85;         // Cornette-Shanks f (medium.hg_g)
    double thickness = 600;    // m, layer thickness
    bool operator==(const LightingParameters&) const = default;
};

class LightingFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct LightingVolume {
    LightingSettings settings;
    LightingParameters parameters;
    double precomputeMs = 0;            // CPU time it took (0 when loaded)
    std::vector<std::uint8_t> texels;   // RGBA8, x fastest, then y, then z (z = 0 the layer's bottom)
    std::vector<std::uint8_t> columns;  // RGBA8, width x height: rgb = the whole column's encoded knots (see below)
    LayerLightTables tables;            // the diffuse light

    // The density A at texel (i, j, k).
    double densityAt(int i, int j, int k) const;
    // GL_LINEAR sampling of the alpha channel (A) with repeat in x, y and clamp in z, at
    // texture coordinates (u, v) and z in [0, 1] (height fraction in the layer).
    double sampleDensity(double u, double v, double z) const;
    // GL_LINEAR sampling of all four channels (bytes / 255), as sampleDensity; and of the columns.
    glm::dvec4 sampleTexel(double u, double v, double z) const;
    glm::dvec4 sampleColumn(double u, double v) const;
    // The optical depths (above, below) of the column at (u, v, z) for the threshold theta =
    // r + 1 - C and density D of eq. (16), from the encoded knots as the shader reads them.
    glm::dvec2 columnDepths(double u, double v, double z, double theta, double density) const;

    // Binary file: magic "NPHLAYR\0", version, sizes, parameters, derived values, texels, and
    // a checksum (core/internal/cache_file.hpp); load() verifies it and refuses a damaged file.
    void save(const std::string& path) const;
    // Throws LightingFileError naming the file and what is wrong (bad magic, version, a size
    // or a parameter that differs from `expected`, truncated data).
    static LightingVolume load(const std::string& path, const LightingSettings& expectedSettings,
                               const LightingParameters& expectedParameters);
};

// About the memory a volume of these settings takes while it is computed and uploaded (bytes).
std::uint64_t lightingBytes(const LightingSettings& settings);

// The density A of the volume at texel centres: an fBm cloud field shaped by a vertical
// profile (0 at the bottom and the top of the layer, 1 inside), tileable in x and y.
// Then the column knots and the light tables. Time and memory grow with the texel count and
// the photons, not with the optical depth: past extinction x thickness 1000 a layer is lit as
// one at 1000 (dark inside either way). Throws std::invalid_argument for bad
// settings, ResourceError (nephele/resources.hpp) when lightingBytes() is more than the
// memory available. With `cancel`, the photon trace stops soon after *cancel becomes true
// and LightingCancelled is thrown (nothing is returned or cached).
LightingVolume precomputeLighting(const LightingSettings& settings, const LightingParameters& parameters,
                                  const std::atomic<bool>* cancel = nullptr);
// The same through a cache folder (created if missing): loaded when a file of the same
// parameters is there, else computed and saved (a failed save only warns through the log callback, nephele/log.hpp).
// cacheDir "" = no cache.
LightingVolume lightingCached(const LightingSettings& settings, const LightingParameters& parameters,
                              const std::string& cacheDir, const std::atomic<bool>* cancel = nullptr);
// What precomputeLighting and lightingCached throw when their `cancel` was set.
class LightingCancelled : public std::runtime_error {
public:
    LightingCancelled() : std::runtime_error("the layer's lighting was cancelled") {}
};
// The layer's lighting key: the medium and its thickness (Layer::lightingThickness when set).
LightingParameters lightingParameters(const Medium& medium, const Layer& layer);

// ---------------------------------------------------------------------------------------
// The 2D modulation texture and the CPU twins of the shader

struct ModulationSettings {
    int size = 512;             // texels per side, >= 8
    double period = 30000;      // m, tile period of the 2D texture (the paper: 400000 units)
    int octaves = 5;            // fBm octaves, 1..8
    int cells = 6;              // fBm lattice cells per period, >= 1
    double maxThreshold = 0.8;  // r spans [0, maxThreshold]: with C = 1 only points where A < r are empty
    double glowPeriod = 12000;  // m, feature size of the city map in the green channel
};

struct ModulationTexture {
    int size = 0;
    std::vector<float> texels;  // RG: r = threshold in [0, maxThreshold], g = city map in [0, 1]
    // GL_LINEAR + GL_REPEAT sampling (no mipmaps) at texture coordinate uv, channel c.
    float sample(double u, double v, int c) const;
};
// Deterministic from `seed` (the layer's seed).
ModulationTexture makeModulation(const ModulationSettings& settings, unsigned seed);

// At most this many billboard slices (lod0Radius / lod0Spacing).
inline constexpr int kMaxBillboardSlices = 4096;

struct LayeredSettings {
    int layers = 8;  // N, annuli per scene layer (LOD1), >= 2; 8 keeps grazing-view gaps < 2% (layered_gl_test)
    double lod0Radius = 1500;  // m, radius of the billboard disc (LOD0); 0 = no billboards
    double lod0Spacing = 100;  // m, p_s of eq. (13): distance between billboard slices, > 0
    double extentFade = 0.1;   // fraction of the extent over which the layer fades out at its rim
    double nearRadius = 0;     // m: within this horizontal distance from the eye the layer adds nothing
    double blendBand = 0;      // m: across [nearRadius, nearRadius + blendBand] it fades in (smoothstep)
    double glowHeight = 1;     // f_c of eq. (20)
    int segments = 96;         // angular segments of the annulus mesh, >= 8
    bool shadows = true;       // cloud shadows, eq. (19), on the frame's surfaces and the ground
    int downsample = 2;        // the layers are drawn at 1/downsample of the frame's resolution (1..4) and
                               // upsampled with the frame's depth (nearest-depth); 1 = full resolution
    double groundHeight = 0;   // m, z of the ground plane the shadows fall on (the format's ground)
    // The far field reused across frames (with downsample > 1): a reduced pixel is drawn afresh
    // at least every reusePeriod frames (1..16; 1 = every frame, no reuse), and sooner when its
    // parallax bound passes reuseError reduced pixels, when a surface of the frame is in it, or
    // when the weather changed more than a ramp does in a frame; else it is the last frame's,
    // reprojected by its mean distance (docs/layered.md, "The far field reused").
    int reusePeriod = 8;
    double reuseError = 2.0;
    LightingSettings lighting;
    ModulationSettings modulation;
    std::string cacheDir;           // lighting volumes are cached here ("" = not cached)
    int resourceMegabytes = 1024;   // memory for the layers' lighting volumes and modulation textures (CPU and
                                    // GL): layers of the same thickness (and medium) share a volume, of the same
                                    // seed a modulation; a scene whose distinct ones need more is refused
                                    // (ResourceError) before anything is made. 1..65536
    BackgroundSettings background;  // how the worker that makes them in the background runs (SkySettings::background)
};
// Throws std::invalid_argument naming the setting.
void validate(const LayeredSettings& settings);

// How far the wind has moved the layer's pattern at time t (m): windOffset + t * wind, eq. (18).
inline Vec2 layerDrift(const Layer& layer, double t) { return layer.windOffset + t * layer.wind; }

// The near-LOD hook. Weight in [0, 1] of the layer at horizontal distance `horizontal` (m)
// from the eye: 0 within nearRadius, smoothstep across the blend band, 1 beyond (the shader
// multiplies every fragment's optical depth by it).
double nearFade(const LayeredSettings& settings, double horizontal);
// The layer's fade at its rim, at horizontal distance `horizontal` (m) from the eye: 1 -
// smoothstep(extent (1 - extentFade), extent, horizontal) (LayeredSettings::extentFade), as the
// shader fades the layer's fragments; 0 beyond the extent.
double rimFade(const Layer& layer, double extentFade, double horizontal);
// The layer's modulation at world (x, y) (m) and time t (s): eq. (16) with the 3D texture's
// alpha at its peak (1), i.e. D * max(C - r, 0), with r read as the shader reads it (wind
// included). > 0 where the layer has cloud; the near LOD spawns ellipsoid clouds there.
double layerModulation(const Layer& layer, const ModulationTexture& modulation, const ModulationSettings& ms, double x,
                       double y, double t);
// The shader's density at a world point inside the layer: D * max(A - (r + 1 - C), 0), eq. (16),
// A from the lighting volume at that point. 0 outside [base, base + thickness].
double layerDensity(const Layer& layer, const ModulationTexture& modulation, const ModulationSettings& ms,
                    const LightingVolume& light, const Vec3& point, double t);
// The integral of layerDensity() (m; times medium.extinction it is the optical depth) along
// o + s d (unit d, s >= 0) over the part of the ray inside the layer's slab within horizontal
// distance `reach` (m) of o, by the midpoint rule in steps of at most `step` m (at most
// `maxSteps` of them): the CPU twin of the opacity the layered sky stands for.
double layerDensityIntegral(const Layer& layer, const ModulationTexture& modulation, const ModulationSettings& ms,
                            const LightingVolume& light, const Vec3& o, const Vec3& d, double reach, double t,
                            double step = 10, int maxSteps = 4000);
// Cloud shadows, eq. (19): the sun's transmittance through the layer at a world point below
// it, S = 1 - D max(T_S - (r + 1 - C), 0) with T_S = 1 (the column's peak alpha) and r read
// where the ray towards the sun crosses the layer's middle. 1 at or above the layer's middle
// or with the sun at or below the horizon.
double sunTransmittance(const Layer& layer, const ModulationTexture& modulation, const ModulationSettings& ms,
                        const Vec3& sunDirection, const Vec3& point, double t);
// The sun's share in [0, 1] of the irradiance of a horizontal ground plane under the format's
// sky (horizon + (zenith - horizon) d.z over the upper hemisphere, E_sky = pi horizon +
// 2 pi / 3 (zenith - horizon)) and sun (E_sun = colour intensity sun.z), by luminance: the
// part of the ground colour that the layers' shadows darken (0 with the sun at or below the
// horizon).
double groundSunShare(const Sun& sun, const Sky& sky);

// ---------------------------------------------------------------------------------------
// The renderer

struct LayeredStats {
    int sceneLayers = 0;        // layers in the scene
    int drawCalls = 0;          // the layers' instanced draws this frame (two per scene layer)
    int instances = 0;          // annuli + billboards drawn
    int shadowLayers = 0;       // layers casting cloud shadows this frame
    int shadowDrawCalls = 0;    // full-screen cloud-shadow passes of their own (0 when fused into the upsampling)
    int upsampleDrawCalls = 0;  // full-screen passes that upsample the layers (1 with downsample > 1)
    double precomputeMs = 0;    // lighting computed in this call (0 when cached or loaded; in the background:
                                // what the worker finished since the last call)
    int pendingLayers = 0;      // layers whose lighting is being computed in the background (drawn with the
                                // last volume they had meanwhile; not drawn when they had none)
    int uploads = 0;            // textures made in this call (new lighting or modulation data; layers with
                                // the same data share one)
    bool reusedFrame = false;   // the last frame's far field was reused where it holds (LayeredSettings::reusePeriod)
    // Of the last frame before this one that reused: the reduced pixels it kept (-1 when not
    // known without waiting for the GPU), of reducedPixels.
    long long reusedPixels = -1, reducedPixels = 0;
};

class LayerAssets;  // internal (layered/internal/layer_assets.hpp): the layers' lighting and modulation data

// Needs a current OpenGL 4.5 context; leaves the GL state as it found it.
class LayeredRenderer {
public:
    explicit LayeredRenderer(LayeredSettings settings = {});
    ~LayeredRenderer();
    LayeredRenderer(const LayeredRenderer&) = delete;
    LayeredRenderer& operator=(const LayeredRenderer&) = delete;
    const LayeredSettings& settings() const { return settings_; }

    // Draws the scene's layers over `framebuffer` (colour attachment 0: rgb = radiance, a =
    // cloud opacity; with a depth buffer holding the opaque objects, which are depth-tested),
    // premultiplied "over", in the view's viewport and depth convention. timeSeconds drives wind
    // (layerDrift) and lightning.
    LayeredStats render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds);
    LayeredStats render(const Scene& scene, const View& view, const HostFrame& frame, double timeSeconds);
    // Builds every shader variant now (the upsampling per shadowing-layer count) and the
    // driver's mipmap generation for the layers' textures, so that no frame builds one.
    void prepare();
    // Takes its lighting volumes and modulation textures from `assets` (SkyRenderer's, shared
    // with the near LOD and computed in the background) instead of its own (synchronous).
    void shareAssets(std::shared_ptr<LayerAssets> assets);

    // The lighting volume and modulation texture used for scene layer `index` at the last
    // render (nullptr before, or while a background job makes the first).
    const LightingVolume* lighting(int index) const;
    const ModulationTexture* modulation(int index) const;

private:
    friend struct LayeredBenchHooks;  // the bench's entry point (layered/src/layered_hooks.hpp), not a host's
    struct Impl;
    LayeredSettings settings_;
    std::unique_ptr<Impl> impl_;
};

}  // namespace nephele
NEPHELE_API_END
