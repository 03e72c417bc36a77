// The `nephele` command-line tool.
#include "bench_cli.hpp"
#include "cache_dir.hpp"
#include "cli_checks.hpp"
#include "compare_command.hpp"
#include "export_command.hpp"
#include "flythrough_command.hpp"
#include "fly_command.hpp"
#include "ig_command.hpp"
#include "render_command.hpp"
#include "terminal_text.hpp"

#include "nephele/context.hpp"
#include "nephele/limits.hpp"
#include "nephele/log.hpp"
#include "nephele/resources.hpp"
#include "nephele/scene.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include <unistd.h>

using namespace nephele;
using namespace nephele::cli;

namespace {

const CLI::Validator kPath = nonEmptyPath();

// The options `render` and `flythrough` share, as typed on the command line.
struct SceneArgs {
    std::string scene, method = "auto", backend = "egl";
    int width = 0, height = 0;
    double scale = 0;
    int minTile = 8, maxTile = 512;
    std::string atlas, precision = "f16", draws = "instanced", flythrough = "fraction", colourMatrix = "fused";
    std::string tileGeometry = "mesh", exactOrder = "ellipsoid";
    std::string composite = EllipsoidSettings().order == CompositeOrder::Weighted ? "weighted" : "back-to-front";
    CLI::Option *widthOpt = nullptr, *heightOpt = nullptr, *scaleOpt = nullptr;
    CLI::Option *nearRadiusOpt = nullptr, *blendBandOpt = nullptr, *lod0RadiusOpt = nullptr;
    RaymarchSettings raymarch;
    RadianceGridSettings light;   // --light-grid, --photons (sky photons = sun photons)
    std::string lightGridFit = "on";  // --light-grid-fit
    std::string reuse;                // --reuse: on | off; empty: on under auto, off otherwise
    std::string cloudLod;             // --cloud-lod: on | off; empty: on under auto, off otherwise
    double reuseError = EllipsoidSettings().reuseErrorPixels, reuseBudget = EllipsoidSettings().reuseBudget;
    double cloudLodError = EllipsoidSettings().cloudLodErrorPixels;
    int closeDownsample = EllipsoidSettings().closeDownsample;
    PathTraceSettings pathtrace;
    LayeredSettings layered;
    std::string lightSize = "256x256x32";
    std::string frustum;                       // --frustum L,R,B,T
    double yawOffset = 0, pitchOffset = 0;     // --yaw-offset, --pitch-offset (degrees)
    std::string cache;
    bool noCache = false;
};

void addSceneOptions(CLI::App* cmd, SceneArgs& a) {
    cmd->add_option("scene", a.scene, "Scene file (cloudscene JSON, see data/scene-format.md)")->required()->check(kPath);
    cmd->add_option("--method", a.method, "auto|ellipsoid|layered|raymarch|pathtrace|gardner-exact")
        ->check(CLI::IsMember({"auto", "ellipsoid", "layered", "raymarch", "pathtrace", "gardner-exact"}))
        ->capture_default_str();
    a.widthOpt = cmd->add_option("--width", a.width, "Image width in pixels (overrides the camera)")->check(within(1, kMaxImageSize));
    a.heightOpt = cmd->add_option("--height", a.height, "Image height in pixels (overrides the camera)")->check(within(1, kMaxImageSize));
    a.scaleOpt = cmd->add_option("--scale", a.scale, "Scale the camera's image size (the result 1..16384 px)")
                     ->check(within(1e-4, kMaxImageSize))
                     ->excludes(a.widthOpt)
                     ->excludes(a.heightOpt);
    cmd->add_option("--gl", a.backend, "OpenGL backend: egl (headless) or osmesa")
        ->check(CLI::IsMember({"egl", "osmesa"}))
        ->capture_default_str();
    cmd->add_option("--min-tile", a.minTile, "Ellipsoid tiles: smallest size (px, a power of two)")->check(within(1, 16384))->capture_default_str();
    cmd->add_option("--max-tile", a.maxTile, "Ellipsoid tiles: largest size (px, a power of two)")->check(within(1, 16384))->capture_default_str();
    cmd->add_option("--atlas", a.atlas, "Ellipsoid atlas size WxH, 1..16384 each (default: the image size)");
    cmd->add_option("--precision", a.precision, "Ellipsoid atlas precision: f16 or u8 (the paper's 8 bits)")
        ->check(CLI::IsMember({"f16", "u8"}))
        ->capture_default_str();
    cmd->add_option("--draws", a.draws, "instanced, or per-ellipsoid (the paper's one draw per ellipsoid)")
        ->check(CLI::IsMember({"instanced", "per-ellipsoid"}))
        ->capture_default_str();
    cmd->add_option("--colour-matrix", a.colourMatrix, "pass (the paper's copy through the matrix) or fused (in the composite)")
        ->check(CLI::IsMember({"pass", "fused"}))
        ->capture_default_str();
    cmd->add_option("--composite", a.composite,
                    "back-to-front (the paper: whole tiles by centre distance, whose order flips as the eye passes between "
                    "overlapping ellipsoids), weighted "
                    "(order-independent, weighted by each pixel's depth) or moments (order-independent, weighted by the "
                    "transmittance in front, from each pixel's moments); default back-to-front")
        ->check(CLI::IsMember({"back-to-front", "weighted", "moments"}));
    cmd->add_option("--tile-geometry", a.tileGeometry, "mesh (the paper's Gouraud-lit ellipsoid meshes) or polygon (the model per pixel)")
        ->check(CLI::IsMember({"mesh", "polygon"}))
        ->capture_default_str();
    cmd->add_option("--frustum", a.frustum,
                    "A display channel's off-axis frustum L,R,B,T: the tangents of its edges at unit distance, each in "
                    "-100..100, L < R, B < T (overrides the camera's fov_y)");
    cmd->add_option("--yaw-offset", a.yawOffset, "A display channel's rotation about the eye: yaw, degrees, positive right")
        ->check(within(-360, 360))
        ->capture_default_str();
    cmd->add_option("--pitch-offset", a.pitchOffset, "A display channel's rotation about the eye: pitch, degrees, positive up")
        ->check(within(-90, 90))
        ->capture_default_str();
    cmd->add_option("--step", a.raymarch.step, "Ray-marcher: base step (m)")->check(within(0.1, 10000))->capture_default_str();
    cmd->add_option("--lod-distance", a.raymarch.lodDistance, "Ray-marcher: the step grows as step (1 + d / this) (m; 0 = fixed)")
        ->check(within(0, 1e7))
        ->capture_default_str();
    cmd->add_option("--light-grid", a.light.size,
                    "Compositor, gardner-exact, ray-marcher: voxels per side of a big cloud's radiance grid (smaller or thinner clouds get 8 or 16 unless --light-grid-fit off)")
        ->check(within(4, 128))
        ->capture_default_str();
    cmd->add_option("--light-grid-fit", a.lightGridFit,
                    "on: each cloud's grid as fine as its optical size needs, up to --light-grid; off: every grid --light-grid")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    cmd->add_option("--photons", a.light.sunPhotons,
                    "Compositor, gardner-exact, ray-marcher: photons traced from the sun for a grid of --light-grid voxels per side (as many per voxel for a smaller one), and as many from the sky")
        ->check(within(0, 1 << 24))
        ->capture_default_str();
    cmd->add_option("--octaves", a.raymarch.octaves, "Ray-marcher: fBm octaves (with medium.noise > 0)")->check(within(1, 8))->capture_default_str();
    cmd->add_option("--march-downsample", a.raymarch.downsample,
                    "Ray-marcher: one ray per DxD pixels, upsampled with the depth (1 = a ray per pixel)")
        ->check(within(1, 4))->capture_default_str();
    cmd->add_option("--layers", a.layered.layers, "Layered sky: annuli per scene layer (N)")->check(within(2, 1024))->capture_default_str();
    a.lod0RadiusOpt = cmd->add_option("--lod0-radius", a.layered.lod0Radius,
                                      "Layered sky: radius of the billboard disc (m; 0 = none; default 1500, auto "
                                      "--near-radius + --blend-band + " + std::to_string(int(kAutoLod0Margin)) +
                                      "; at most 4096 x --lod0-spacing)")
                          ->check(within(0, 1e6));
    cmd->add_option("--lod0-spacing", a.layered.lod0Spacing, "Layered sky: distance between billboard slices (m)")
        ->check(within(1, 1e5))
        ->capture_default_str();
    cmd->add_option("--layer-downsample", a.layered.downsample,
                    "Layered sky: draw the layers at 1/D of the resolution, upsampled with the depth (1 = full)")
        ->check(within(1, 4))->capture_default_str();
    cmd->add_flag("!--no-cloud-shadows", a.layered.shadows, "Layered sky: no cloud shadows on the ground and objects");
    cmd->add_option("--light-size", a.lightSize,
                    "Layered sky: lighting texture WxHxD, 2..2048 each (the paper's 256x256x32; GL 4.5 guarantees "
                    "3D textures of 2048)")
        ->capture_default_str();
    a.nearRadiusOpt = cmd->add_option("--near-radius", a.layered.nearRadius,
                                      "Layered sky: no layer within this distance of the eye (m; auto: near_lod layers are "
                                      "ellipsoid cumulus there; default 0, auto " + std::to_string(int(kAutoNearRadius)) + ")")
                          ->check(within(0, 1e5));
    a.blendBandOpt = cmd->add_option("--blend-band", a.layered.blendBand,
                                     "Layered sky: the layer fades in across this band beyond --near-radius (m; default 0, auto " +
                                         std::to_string(int(kAutoBlendBand)) + ")")
                         ->check(within(0, 1e5));
    cmd->add_option("--spp", a.pathtrace.spp, "Path tracer: samples per pixel")->check(within(1, 1 << 20))->capture_default_str();
    cmd->add_option("--bounces", a.pathtrace.maxBounces, "Path tracer: scattering events per path")->check(within(0, 10000))->capture_default_str();
    cmd->add_option("--seed", a.pathtrace.seed, "Path tracer: random seed")->check(within(0, 4294967295.0))->capture_default_str();
    cmd->add_option("--cache", a.cache, "Path tracer: cache folder (default $NEPHELE_CACHE, else ~/.cache/nephele)")->check(kPath);
    cmd->add_flag("--no-cache", a.noCache, "Path tracer: do not read or write the cache");
    cmd->add_option("--exact-order", a.exactOrder,
                    "gardner-exact: ellipsoid (whole ellipsoids back to front, as the tiles), pixel (per-pixel depth "
                    "order), weighted (the weighted composite's exact model) or moments (the moment composite's)")
        ->check(CLI::IsMember({"ellipsoid", "pixel", "weighted", "moments"}))
        ->capture_default_str();
    cmd->add_option("--flythrough", a.flythrough, "Objects in clouds: fraction (optical depth in front) or stencil (the paper)")
        ->check(CLI::IsMember({"fraction", "stencil"}))
        ->capture_default_str();
    cmd->add_option("--reuse", a.reuse,
                    "Compositor: on keeps tiles across frames (reprojected until their error passes --reuse-error), off "
                    "renders every tile every frame (default: on under auto, else off)")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--cloud-lod", a.cloudLod,
                    "Compositor: on draws each far cloud (beyond 4 of its radii and the near plane, at most 512 px) as one "
                    "impostor of its tiles, kept across frames like a tile, and renders no close tile finer than its "
                    "ellipsoid's image holds; off draws every cloud as tiles at their size on screen (default: on "
                    "under auto, else off; only with the back-to-front composite and --flythrough fraction)")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--cloud-lod-error", a.cloudLodError,
                    "Compositor with --cloud-lod on: an impostor's error in pixels that makes it again")
        ->check(within(0.01, 1000))
        ->capture_default_str();
    cmd->add_option("--close-downsample", a.closeDownsample,
                    "Compositor with --cloud-lod on: two or more consecutive close tiles each magnified this many times "
                    "on screen are composited at 1/this of the resolution and upsampled with the depth (1 = full)")
        ->check(CLI::Range(1, 4))
        ->capture_default_str();
    cmd->add_option("--reuse-error", a.reuseError, "Compositor with --reuse on: a tile's error in pixels that renders it again")
        ->check(within(0.01, 1000))
        ->capture_default_str();
    cmd->add_option("--reuse-budget", a.reuseBudget,
                    "Compositor with --reuse on: tile pixels re-rendered a frame for tiles that have an image, in frames' pixels")
        ->check(within(0, 1000))
        ->capture_default_str();
}

// Throws UsageError for values the parser could not judge alone.
void applySceneArgs(const SceneArgs& a, RenderOptions& ro) {
    ro.scene = a.scene;
    ro.method = parseMethod(a.method);
    ro.backend = parseBackend(a.backend);
    ro.channel = parseChannel(a.frustum, a.yawOffset, a.pitchOffset);
    if (a.widthOpt->count()) ro.width = a.width;
    if (a.heightOpt->count()) ro.height = a.height;
    if (a.scaleOpt->count()) ro.scale = a.scale;
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
    es.order = a.composite == "weighted" ? CompositeOrder::Weighted
               : a.composite == "moments"  ? CompositeOrder::Moments
                                           : CompositeOrder::PerEllipsoid;
    es.reuse = a.reuse.empty() ? ro.method == Method::Auto : a.reuse == "on";
    es.cloudLod = a.cloudLod.empty() ? ro.method == Method::Auto : a.cloudLod == "on";
    if (es.cloudLod && !cloudLodApplies(es)) {
        if (a.cloudLod == "on")
            throw UsageError("--cloud-lod on needs the back-to-front composite (--composite back-to-front) and --flythrough fraction");
        es.cloudLod = false;
    }
    es.reuseErrorPixels = a.reuseError;
    es.cloudLodErrorPixels = a.cloudLodError;
    es.closeDownsample = a.closeDownsample;
    es.reuseBudget = a.reuseBudget;
    ro.exactOrder = a.exactOrder == "pixel"      ? CompositeOrder::PerPixel
                    : a.exactOrder == "weighted" ? CompositeOrder::Weighted
                    : a.exactOrder == "moments"  ? CompositeOrder::Moments
                                                 : CompositeOrder::PerEllipsoid;
    RadianceGridSettings light = a.light;
    light.skyPhotons = light.sunPhotons;
    light.fitToCloud = a.lightGridFit == "on";
    es.light = light;
    ro.raymarch = a.raymarch;
    ro.raymarch.light = light;
    ro.pathtrace = a.pathtrace;
    if (!a.noCache) ro.cacheDir = defaultCacheDir(a.cache);
    ro.layered = a.layered;
    {
        LightingSettings& ls = ro.layered.lighting;
        char x1 = 0, x2 = 0, extra = 0;
        const int m = kMaxLightingSize;
        if (std::sscanf(a.lightSize.c_str(), "%d%c%d%c%d%c", &ls.width, &x1, &ls.height, &x2, &ls.depth, &extra) != 5 ||
            x1 != 'x' || x2 != 'x' || ls.width < 2 || ls.height < 2 || ls.depth < 2 || ls.width > m || ls.height > m ||
            ls.depth > m)
            throw UsageError("--light-size must be WxHxD with sizes 2.." + std::to_string(m) + " each, got '" + a.lightSize + "'");
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
        if (!a.lod0RadiusOpt->count()) ro.layered.lod0Radius = ro.layered.nearRadius + ro.layered.blendBand + kAutoLod0Margin;
    }
    // The one limit two flags share (the billboard slices), named by the flags that set it.
    const double slices = ro.layered.lod0Radius / ro.layered.lod0Spacing;
    if (slices > kMaxBillboardSlices)
        throw UsageError((a.lod0RadiusOpt->count() ? "--lod0-radius " : "--lod0-radius (auto: --near-radius + --blend-band + 1000 = ") +
                         rangeNumber(ro.layered.lod0Radius) + (a.lod0RadiusOpt->count() ? "" : ")") + " / --lod0-spacing " +
                         rangeNumber(ro.layered.lod0Spacing) + " makes " + rangeNumber(std::ceil(slices)) +
                         " billboard slices; at most " + std::to_string(kMaxBillboardSlices));
    // Ranges above keep these from failing; they stay as the library's own guard.
    if (ro.method == Method::Auto) validate(ro.nearLod, ro.layered);  // std::invalid_argument -> exit 2
    validate(ro.layered);
    validate(ro.raymarch);
}

}  // namespace

// The library never prints (nephele/log.hpp): the command line prints its messages to
// stderr, and draws its progress reports as a bar when stderr is a terminal.
void installConsoleLogging() {
    setLogCallback([](LogLevel level, std::string_view message) {
        if (level == LogLevel::Debug) return;
        const std::string text = terminalText(message);  // it may quote a path or a key
        if (level == LogLevel::Info) std::fprintf(stderr, "nephele: %s\n", text.c_str());
        else std::fprintf(stderr, "nephele: %s: %s\n", logLevelName(level), text.c_str());
    });
    if (::isatty(2) == 0) return;
    setProgressCallback([](std::string_view label, double fraction) {
        const int percent = std::clamp(int(fraction * 100), 0, 100);
        char bar[41];
        for (int i = 0; i < 40; ++i) bar[i] = i < percent * 40 / 100 ? '#' : '.';
        bar[40] = 0;
        std::fprintf(stderr, "\r%.*s [%s] %3d%%%s", int(label.size()), label.data(), bar, percent, percent == 100 ? "\n" : "");
        std::fflush(stderr);
    });
}

namespace {

// `info SCENE`: load the scene and print what it holds (no GL).
int runInfoScene(const std::string& file) {
    try {
        const Scene scene = loadScene(file);
        size_t ellipsoids = 0;
        for (const Cloud& c : scene.clouds) ellipsoids += c.ellipsoids.size();
        std::cout << scene.file << ": " << scene.clouds.size() << " clouds, " << ellipsoids << " ellipsoids\n";
        for (const GenerateStats& g : scene.generated)
            std::cout << "generate " << g.name << ": placed " << g.placed << ", pruned " << g.prunedHollow << " hollow / "
                      << g.prunedContained << " contained"
                      << (g.degenerate ? ", " + std::to_string(g.degenerate) + " degenerate skipped" : "") << ", kept "
                      << g.kept << "\n";
        return 0;
    } catch (const SceneError& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 2;
    }
}

// `info`: make a context and print what it is.
int runInfoContext(const std::string& gl) {
    try {
        ContextOptions co;
        co.backend = parseBackend(gl);
        co.visible = false;
        auto ctx = Context::create(co);
        std::cout << backendName(co.backend) << ": " << ctx->description() << "\n";
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 1;
    }
}

// Parses the command line: -1 to go on, else the exit code (help, version: 0; a bad argument:
// 2, with CLI11's message after "nephele: ").
const CLI::Option* findOption(const CLI::App& app, const std::string& name) {
    if (const CLI::Option* o = app.get_option_no_throw(name)) return o;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
        if (const CLI::Option* o = findOption(*sub, name)) return o;
    return nullptr;
}

// CLI11's "Could not convert: --width = 1e3" as "--width: '1e3' is not an integer ...": the
// flag, the value and what the flag takes (its range is checked after the conversion).
std::string conversionFault(const CLI::App& app, const std::string& what) {
    const std::string prefix = "Could not convert: ";
    const std::size_t eq = what.find(" = ");
    if (what.rfind(prefix, 0) != 0 || eq == std::string::npos) return what;
    const std::string name = what.substr(prefix.size(), eq - prefix.size()), value = what.substr(eq + 3);
    const CLI::Option* o = findOption(app, name);
    const std::string type = o ? o->get_type_name() : "";
    const bool integer = type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0;
    const std::size_t colon = type.find(':');
    const std::string range = colon == std::string::npos ? "" : " in " + type.substr(colon + 1);
    return name + ": '" + value + "' is not " + (integer ? "an integer; it takes a whole number" + range + ", written without an exponent or a fraction"
                                                         : "a value of its type (" + type + ")");
}

int parse(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
        return -1;
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ConversionError& e) {
        std::cerr << "nephele: " << conversionFault(app, e.what()) << " (--help lists every option and its range)\n";
        return 2;
    } catch (const CLI::ParseError& e) {
        std::cerr << "nephele: " << e.what() << " (--help lists every option and its range)\n";
        return 2;
    }
}

int run(int argc, char** argv) {
    CLI::App app{"Nephele: cloud rendering for flight and helicopter simulators"};
    app.set_version_flag("--version", "nephele 0.1.0");
    app.footer(limitsHelp());
    app.require_subcommand(1);

    RenderOptions ro;
    SceneArgs renderArgs;
    CLI::App* render = app.add_subcommand("render", "Render a scene to a PNG (headless)");
    addSceneOptions(render, renderArgs);
    render->add_option("-o,--output", ro.output, "Output PNG (sRGB, 8-bit)")->required()->check(kPath);
    render->add_option("--alpha", ro.alpha, "Also write the cloud opacity as an 8-bit grey PNG")->check(kPath);
    render->add_option("--pfm", ro.pfm, "Also write linear float RGB as PFM")->check(kPath);
    render->add_option("--density-alpha", ro.densityAlpha,
                       "Also write the exact opacity of the scene's density field (8-bit grey), to check --alpha against")
        ->check(kPath);
    render->add_flag("--silhouette", ro.silhouette,
                     "Print the box-counting dimension of the cloud opacity's alpha > 0.5 silhouette (boxes 2-32 px) on stdout");
    render->add_option("--time", ro.time, "Time in seconds (wind, lightning, camera path)")
        ->check(within(-1e9, 1e9))
        ->capture_default_str();

    FlythroughOptions fo;
    SceneArgs flyArgs;
    CLI::App* fly = app.add_subcommand("flythrough", "Render the scene's camera path to numbered PNG frames");
    addSceneOptions(fly, flyArgs);
    fly->add_option("--out-dir", fo.outDir, "Folder for the frames and flythrough.json (new or empty)")->required()->check(kPath);
    fly->add_option("--fps", fo.fps, "Frames per second of scene time (at most " + std::to_string(kMaxFrames) + " frames)")
        ->check(within(0.001, 1000))
        ->capture_default_str();
    fly->add_option("--reference-dir", fo.referenceDir, "A reference run's --out-dir: also report the flicker index")->check(kPath);
    fly->add_flag("--timings", fo.timings,
                  "Also record the compositor's plan, tile-pass and composite ms of every frame in flythrough.json "
                  "(a glFinish between the parts: the frames get a little slower)");

    fly::FlyOptions flyo;
    CLI::App* flyCmd = fly::addFlyCommand(app, flyo);

    BenchArgs benchArgs;
    CLI::App* bench = addBenchCommand(app, benchArgs);

    CompareOptions co;
    CLI::App* compare = app.add_subcommand("compare", "Compare two renders: one JSON line (exposure-fitted RMSE, PSNR, SSIM, alpha)");
    compare->add_option("a", co.a, "Image A (.png sRGB or .pfm linear)")->required()->check(kPath);
    compare->add_option("b", co.b, "Image B, the reference")->required()->check(kPath);
    compare->add_option("--alpha-a", co.alphaA, "A's cloud opacity (grey .png or .pfm)")->check(kPath);
    compare->add_option("--alpha-b", co.alphaB, "B's cloud opacity (grey .png or .pfm)")->check(kPath);

    ExportOptions eo;
    CLI::App* exportCmd = app.add_subcommand("export", "Write the scene's extinction field, as the path tracer renders it, "
                                                       "to a file (docs/cli.md, \"export\")");
    exportCmd->add_option("scene", eo.scene, "Scene file (cloudscene JSON, see data/scene-format.md)")->required()->check(kPath);
    exportCmd->add_option("--vdb", eo.vdb, "Output OpenVDB file: a FloatGrid named 'density', in 1/m")->required()->check(kPath);
    exportCmd->add_option("--voxel", eo.voxel, "Voxel edge in metres (default: the field's box shared among 256^3 voxels)")
        ->check(within(1e-3, 1e6));
    exportCmd->add_option("--time", eo.time, "Time in seconds (the layers' wind; the camera path, on whose eye the layers centre)")
        ->check(within(-1e9, 1e9))
        ->capture_default_str();

    std::string infoGl = "egl";
    CLI::App* info = app.add_subcommand("info", "Make a GL context and print what it is");
    info->add_option("--gl", infoGl, "egl, osmesa or glfw")->check(CLI::IsMember({"egl", "osmesa", "glfw"}));
    std::string infoScene;
    info->add_option("scene", infoScene, "Instead: load this scene and print its clouds and what each `generate` entry made")
        ->check(kPath);

    IgOptions igo;
    SceneArgs igArgs;
    CLI::App* ig = app.add_subcommand("ig", "Draw one display channel for a CIGI 3.3 host over UDP (docs/cigi.md)");
    addSceneOptions(ig, igArgs);
    addIgOptions(ig, igo);

    if (const int code = parse(app, argc, argv); code >= 0) return code;
    if (*ig) {
        try {
            applySceneArgs(igArgs, igo.render);
        } catch (const std::exception& e) {
            return reportError(e, "checking the settings");
        }
        return runIg(igo);
    }
    if (*flyCmd) return flyo.cacheDir = defaultCacheDir(""), fly::runFly(flyo);
    if (*info) return infoScene.empty() ? runInfoContext(infoGl) : runInfoScene(infoScene);
    if (*compare) return runCompare(co);
    if (*exportCmd) return eo.cacheDir = defaultCacheDir(""), runExport(eo);
    if (*bench) return runBenchCommand(benchArgs);
    try {
        if (*fly) {
            applySceneArgs(flyArgs, fo.render);
            fo.render.ellipsoid.timings = fo.timings;
        } else {
            applySceneArgs(renderArgs, ro);
        }
    } catch (const std::exception& e) {
        return reportError(e, "checking the settings");
    }
    if (*fly) return runFlythrough(fo);
    return runRender(ro);
}

}  // namespace

int main(int argc, char** argv) {
    installConsoleLogging();
    const auto escaped = escapeStream(std::cerr);  // every message, whatever path it quotes
    // The last word on what escaped the commands' own handling: a message and exit 1, never an abort.
    try {
        return run(argc, argv);
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "nephele: out of memory (std::bad_alloc); lower the image size or the settings that size the work\n");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nephele: %s\n", terminalText(e.what()).c_str());
    }
    return 1;
}
