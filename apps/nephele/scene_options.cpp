#include "scene_options.hpp"

#include "cache_dir.hpp"
#include "cli_checks.hpp"

#include "nephele/limits.hpp"
#include "nephele/resources.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>

namespace nephele::cli {

namespace {

const CLI::Validator kPath = nonEmptyPath();

// The scene, the method, the frame's size and the GL backend.
void addFrameOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option("scene", a.scene, "Scene file (cloudscene JSON, see data/scene-format.md)")
        ->required()
        ->check(kPath);
    cmd->add_option("--method", a.method, "auto|ellipsoid|layered|raymarch|pathtrace|gardner-exact")
        ->check(CLI::IsMember({"auto", "ellipsoid", "layered", "raymarch", "pathtrace", "gardner-exact"}))
        ->capture_default_str();
    a.widthOpt = cmd->add_option("--width", a.width, "Image width in pixels (overrides the camera)")
                     ->check(within(1, kMaxImageSize));
    a.heightOpt = cmd->add_option("--height", a.height, "Image height in pixels (overrides the camera)")
                      ->check(within(1, kMaxImageSize));
    a.scaleOpt = cmd->add_option("--scale", a.scale, "Scale the camera's image size (the result 1..16384 px)")
                     ->check(within(1e-4, kMaxImageSize))
                     ->excludes(a.widthOpt)
                     ->excludes(a.heightOpt);
    cmd->add_option("--gl", a.backend, "OpenGL backend: egl (headless) or osmesa")
        ->check(CLI::IsMember({"egl", "osmesa"}))
        ->capture_default_str();
}

// The compositor's tiles, atlas and composite.
void addTileOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option("--min-tile", a.minTile, "Ellipsoid tiles: smallest size (px, a power of two)")
        ->check(within(1, 16384))
        ->capture_default_str();
    cmd->add_option("--max-tile", a.maxTile, "Ellipsoid tiles: largest size (px, a power of two)")
        ->check(within(1, 16384))
        ->capture_default_str();
    cmd->add_option("--atlas", a.atlas, "Ellipsoid atlas size WxH, 1..16384 each (default: the image size)");
    cmd->add_option("--precision", a.precision, "Ellipsoid atlas precision: f16 or u8 (the paper's 8 bits)")
        ->check(CLI::IsMember({"f16", "u8"}))
        ->capture_default_str();
    cmd->add_option("--draws", a.draws, "instanced, or per-ellipsoid (the paper's one draw per ellipsoid)")
        ->check(CLI::IsMember({"instanced", "per-ellipsoid"}))
        ->capture_default_str();
    cmd->add_option("--colour-matrix", a.colourMatrix,
                    "pass (the paper's copy through the matrix) or fused (in the composite)")
        ->check(CLI::IsMember({"pass", "fused"}))
        ->capture_default_str();
    cmd->add_option(
           "--composite", a.composite,
           "back-to-front (the paper: whole tiles by centre distance, whose order flips as the eye passes between "
           "overlapping ellipsoids), weighted "
           "(order-independent, weighted by each pixel's depth) or moments (order-independent, weighted by the "
           "transmittance in front, from each pixel's moments); default back-to-front")
        ->check(CLI::IsMember({"back-to-front", "weighted", "moments"}));
    cmd->add_option("--tile-geometry", a.tileGeometry,
                    "mesh (the paper's Gouraud-lit ellipsoid meshes) or polygon (the model per pixel)")
        ->check(CLI::IsMember({"mesh", "polygon"}))
        ->capture_default_str();
}

// A display channel of the scene camera.
void addChannelOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option("--frustum", a.frustum,
                    "A display channel's off-axis frustum L,R,B,T: the tangents of its edges at unit distance, each in "
                    "-100..100, L < R, B < T (overrides the camera's fov_y)");
    cmd->add_option("--yaw-offset", a.yawOffset,
                    "A display channel's rotation about the eye: yaw, degrees, positive right")
        ->check(within(-360, 360))
        ->capture_default_str();
    cmd->add_option("--pitch-offset", a.pitchOffset,
                    "A display channel's rotation about the eye: pitch, degrees, positive up")
        ->check(within(-90, 90))
        ->capture_default_str();
}

// The ray-marcher, and the radiance grids the compositor, gardner-exact and the ray-marcher share.
void addMarchAndLightOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option("--step", a.raymarch.step, "Ray-marcher: base step (m)")
        ->check(within(0.1, 10000))
        ->capture_default_str();
    cmd->add_option("--lod-distance", a.raymarch.lodDistance,
                    "Ray-marcher: the step grows as step (1 + d / this) (m; 0 = fixed)")
        ->check(within(0, 1e7))
        ->capture_default_str();
    cmd->add_option("--light-grid", a.light.size,
                    "Compositor, gardner-exact, ray-marcher: voxels per side of a big cloud's radiance grid (smaller "
                    "or thinner clouds get 8 or 16 unless --light-grid-fit off)")
        ->check(within(4, 128))
        ->capture_default_str();
    cmd->add_option(
           "--light-grid-fit", a.lightGridFit,
           "on: each cloud's grid as fine as its optical size needs, up to --light-grid; off: every grid --light-grid")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    cmd->add_option("--photons", a.light.sunPhotons,
                    "Compositor, gardner-exact, ray-marcher: photons traced from the sun for a grid of --light-grid "
                    "voxels per side (as many per voxel for a smaller one), and as many from the sky")
        ->check(within(0, 1 << 24))
        ->capture_default_str();
    cmd->add_option("--octaves", a.raymarch.octaves, "Ray-marcher: fBm octaves (with medium.noise > 0)")
        ->check(within(1, 8))
        ->capture_default_str();
    cmd->add_option("--march-downsample", a.raymarch.downsample,
                    "Ray-marcher: one ray per DxD pixels, upsampled with the depth (1 = a ray per pixel)")
        ->check(within(1, 4))
        ->capture_default_str();
}

// The layered sky.
void addLayeredOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option("--layers", a.layered.layers, "Layered sky: annuli per scene layer (N)")
        ->check(within(2, 1024))
        ->capture_default_str();
    a.lod0RadiusOpt = cmd->add_option("--lod0-radius", a.layered.lod0Radius,
                                      "Layered sky: radius of the billboard disc (m; 0 = none; default 1500, auto "
                                      "--near-radius + --blend-band + " +
                                          std::to_string(int(kAutoLod0Margin)) + "; at most 4096 x --lod0-spacing)")
                          ->check(within(0, 1e6));
    cmd->add_option("--lod0-spacing", a.layered.lod0Spacing, "Layered sky: distance between billboard slices (m)")
        ->check(within(1, 1e5))
        ->capture_default_str();
    cmd->add_option("--layer-downsample", a.layered.downsample,
                    "Layered sky: draw the layers at 1/D of the resolution, upsampled with the depth (1 = full)")
        ->check(within(1, 4))
        ->capture_default_str();
    cmd->add_option("--far-reuse", a.layered.reusePeriod,
                    "Layered sky: a reduced pixel is drawn afresh at least every P frames and reused between, "
                    "reprojected (1 = every frame; docs/layered.md)")
        ->check(within(1, 16))
        ->capture_default_str();
    cmd->add_option("--far-reuse-error", a.layered.reuseError,
                    "Layered sky: a reused pixel's parallax bound (reduced px) past which it is drawn afresh")
        ->check(within(0.01, 1000))
        ->capture_default_str();
    cmd->add_flag("!--no-cloud-shadows", a.layered.shadows, "Layered sky: no cloud shadows on the ground and objects");
    cmd->add_option("--light-size", a.lightSize,
                    "Layered sky: lighting texture WxHxD, 2..2048 each (the paper's 256x256x32; GL 4.5 guarantees "
                    "3D textures of 2048)")
        ->capture_default_str();
    a.nearRadiusOpt =
        cmd->add_option("--near-radius", a.layered.nearRadius,
                        "Layered sky: no layer within this distance of the eye (m; auto: near_lod layers are "
                        "ellipsoid cumulus there; default 0, auto " +
                            std::to_string(int(kAutoNearRadius)) + ")")
            ->check(within(0, 1e5));
    a.blendBandOpt =
        cmd->add_option("--blend-band", a.layered.blendBand,
                        "Layered sky: the layer fades in across this band beyond --near-radius (m; default 0, auto " +
                            std::to_string(int(kAutoBlendBand)) + ")")
            ->check(within(0, 1e5));
}

// The path tracer and its cache, gardner-exact's order, objects in clouds.
void addPathtraceOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option("--spp", a.pathtrace.spp, "Path tracer: samples per pixel")
        ->check(within(1, 1 << 20))
        ->capture_default_str();
    cmd->add_option("--bounces", a.pathtrace.maxBounces, "Path tracer: scattering events per path")
        ->check(within(0, 10000))
        ->capture_default_str();
    cmd->add_option("--seed", a.pathtrace.seed, "Path tracer: random seed")
        ->check(within(0, 4294967295.0))
        ->capture_default_str();
    cmd->add_option("--cache", a.cache, "Path tracer: cache folder (default $NEPHELE_CACHE, else ~/.cache/nephele)")
        ->check(kPath);
    cmd->add_flag("--no-cache", a.noCache, "Path tracer: do not read or write the cache");
    cmd->add_option("--exact-order", a.exactOrder,
                    "gardner-exact: ellipsoid (whole ellipsoids back to front, as the tiles), pixel (per-pixel depth "
                    "order), weighted (the weighted composite's exact model) or moments (the moment composite's)")
        ->check(CLI::IsMember({"ellipsoid", "pixel", "weighted", "moments"}))
        ->capture_default_str();
    cmd->add_option("--flythrough", a.flythrough,
                    "Objects in clouds: fraction (optical depth in front) or stencil (the paper)")
        ->check(CLI::IsMember({"fraction", "stencil"}))
        ->capture_default_str();
}

// The compositor's tiles that last and far clouds as impostors.
void addReuseOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option(
           "--reuse", a.reuse,
           "Compositor: on keeps tiles across frames (reprojected until their error passes --reuse-error), off "
           "renders every tile every frame (default: on under auto, else off)")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option(
           "--cloud-lod", a.cloudLod,
           "Compositor: on draws each far cloud (beyond 4 of its radii and the near plane, at most 512 px) as one "
           "impostor of its tiles, kept across frames like a tile, and renders no close tile finer than its "
           "ellipsoid's image holds; off draws every cloud as tiles at their size on screen (default: on "
           "under auto, else off; only with the back-to-front composite and --flythrough fraction)")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--cloud-lod-error", a.cloudLodError,
                    "Compositor with --cloud-lod on: an impostor's error in pixels that makes it again")
        ->check(within(0.01, 1000))
        ->capture_default_str();
    cmd->add_option(
           "--close-downsample", a.closeDownsample,
           "Compositor with --cloud-lod on: two or more consecutive close tiles each magnified this many times "
           "on screen are composited at 1/this of the resolution and upsampled with the depth (1 = full)")
        ->check(CLI::Range(1, 4))
        ->capture_default_str();
    cmd->add_option("--reuse-error", a.reuseError,
                    "Compositor with --reuse on: a tile's error in pixels that renders it again")
        ->check(within(0.01, 1000))
        ->capture_default_str();
    cmd->add_option("--reuse-budget", a.reuseBudget,
                    "Compositor with --reuse on: tile pixels re-rendered a frame for tiles that have an image, in "
                    "frames' pixels")
        ->check(within(0, 1000))
        ->capture_default_str();
}

// The compositor's settings (after ro.method: --reuse and --cloud-lod follow auto).
void applyEllipsoidArgs(const SceneArgs& a, RenderOptions& ro) {
    EllipsoidSettings& es = ro.ellipsoid;
    auto pow2 = [](const char* what, int v) {
        if (v < 1 || v > 16384 || (v & (v - 1)) != 0)
            throw UsageError(std::string(what) + " must be a power of two in 1..16384, got " + std::to_string(v));
        return v;
    };
    es.minTile = pow2("--min-tile", a.minTile);
    es.maxTile = pow2("--max-tile", a.maxTile);
    if (es.minTile > es.maxTile) throw UsageError("--min-tile must not exceed --max-tile");
    if (!a.atlas.empty()) {
        int w = 0, h = 0;
        char x = 0, extra = 0;
        if (std::sscanf(a.atlas.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || w < 1 ||
            h < 1 || w > 16384 || h > 16384)
            throw UsageError("--atlas must be WxH with sizes in 1..16384, got '" + a.atlas + "'");
        if (w < es.minTile || h < es.minTile) throw UsageError("--atlas is smaller than --min-tile");
        es.atlasWidth = w;
        es.atlasHeight = h;
    }
    es.precision = a.precision == "u8" ? AtlasPrecision::Unorm8 : AtlasPrecision::Float16;
    es.instanced = a.draws == "instanced";
    es.colourMatrixPass = a.colourMatrix == "pass";
    es.geometry = a.tileGeometry == "polygon" ? TileGeometry::Polygon : TileGeometry::Mesh;
    es.flyThrough = a.flythrough == "stencil" ? FlyThrough::Stencil : FlyThrough::Fraction;
    es.order = a.composite == "weighted"  ? CompositeOrder::Weighted
               : a.composite == "moments" ? CompositeOrder::Moments
                                          : CompositeOrder::PerEllipsoid;
    es.reuse = a.reuse.empty() ? ro.method == Method::Auto : a.reuse == "on";
    es.cloudLod = a.cloudLod.empty() ? ro.method == Method::Auto : a.cloudLod == "on";
    if (es.cloudLod && !cloudLodApplies(es)) {
        if (a.cloudLod == "on")
            throw UsageError(
                "--cloud-lod on needs the back-to-front composite (--composite back-to-front) and --flythrough "
                "fraction");
        es.cloudLod = false;
    }
    es.reuseErrorPixels = a.reuseError;
    es.cloudLodErrorPixels = a.cloudLodError;
    es.closeDownsample = a.closeDownsample;
    es.reuseBudget = a.reuseBudget;
}

// The layered sky's settings, its lighting volume's size and memory, auto's hand-off radii.
void applyLayeredArgs(const SceneArgs& a, RenderOptions& ro) {
    ro.layered = a.layered;
    {
        LightingSettings& ls = ro.layered.lighting;
        char x1 = 0, x2 = 0, extra = 0;
        const int m = kMaxLightingSize;
        if (std::sscanf(a.lightSize.c_str(), "%d%c%d%c%d%c", &ls.width, &x1, &ls.height, &x2, &ls.depth, &extra) != 5 ||
            x1 != 'x' || x2 != 'x' || ls.width < 2 || ls.height < 2 || ls.depth < 2 || ls.width > m || ls.height > m ||
            ls.depth > m)
            throw UsageError("--light-size must be WxHxD with sizes 2.." + std::to_string(m) + " each, got '" +
                             a.lightSize + "'");
        if (ro.method == Method::Auto || ro.method == Method::Layered) {
            const std::uint64_t need = lightingBytes(ls), have = availableMemoryBytes();
            if (need > have)
                throw ResourceError("--light-size " + a.lightSize + ": the lighting volume needs " + formatBytes(need) +
                                    " of memory, more than the " + formatBytes(have) + " available");
        }
    }
    ro.layered.cacheDir = ro.cacheDir;
    if (ro.method == Method::Auto) {
        if (!a.nearRadiusOpt->count()) ro.layered.nearRadius = kAutoNearRadius;
        if (!a.blendBandOpt->count()) ro.layered.blendBand = kAutoBlendBand;
        if (!a.lod0RadiusOpt->count())
            ro.layered.lod0Radius = ro.layered.nearRadius + ro.layered.blendBand + kAutoLod0Margin;
    }
    // The one limit two flags share (the billboard slices), named by the flags that set it.
    const double slices = ro.layered.lod0Radius / ro.layered.lod0Spacing;
    if (slices > kMaxBillboardSlices)
        throw UsageError((a.lod0RadiusOpt->count() ? "--lod0-radius "
                                                   : "--lod0-radius (auto: --near-radius + --blend-band + 1000 = ") +
                         rangeNumber(ro.layered.lod0Radius) + (a.lod0RadiusOpt->count() ? "" : ")") +
                         " / --lod0-spacing " + rangeNumber(ro.layered.lod0Spacing) + " makes " +
                         rangeNumber(std::ceil(slices)) + " billboard slices; at most " +
                         std::to_string(kMaxBillboardSlices));
}

}  // namespace

void applySceneArgs(const SceneArgs& a, RenderOptions& ro) {
    ro.scene = a.scene;
    ro.method = parseMethod(a.method);
    ro.backend = parseBackend(a.backend);
    ro.channel = parseChannel(a.frustum, a.yawOffset, a.pitchOffset);
    if (a.widthOpt->count()) ro.width = a.width;
    if (a.heightOpt->count()) ro.height = a.height;
    if (a.scaleOpt->count()) ro.scale = a.scale;
    applyEllipsoidArgs(a, ro);
    ro.exactOrder = a.exactOrder == "pixel"      ? CompositeOrder::PerPixel
                    : a.exactOrder == "weighted" ? CompositeOrder::Weighted
                    : a.exactOrder == "moments"  ? CompositeOrder::Moments
                                                 : CompositeOrder::PerEllipsoid;
    RadianceGridSettings light = a.light;
    light.skyPhotons = light.sunPhotons;
    light.fitToCloud = a.lightGridFit == "on";
    ro.ellipsoid.light = light;
    ro.raymarch = a.raymarch;
    ro.raymarch.light = light;
    ro.pathtrace = a.pathtrace;
    if (!a.noCache) ro.cacheDir = defaultCacheDir(a.cache);
    applyLayeredArgs(a, ro);
    // Ranges above keep these from failing; they stay as the library's own guard.
    if (ro.method == Method::Auto) validate(ro.nearLod, ro.layered);  // std::invalid_argument -> exit 2
    validate(ro.layered);
    validate(ro.raymarch);
}

void addSceneOptions(CLI::App* cmd, SceneArgs& a) {
    addFrameOptions(cmd, a);
    addTileOptions(cmd, a);
    addChannelOptions(cmd, a);
    addMarchAndLightOptions(cmd, a);
    addLayeredOptions(cmd, a);
    addPathtraceOptions(cmd, a);
    addReuseOptions(cmd, a);
}

}  // namespace nephele::cli
