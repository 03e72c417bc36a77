// The `nephele` command-line tool: its commands, parsed with CLI11, and what runs each
// (render_command.hpp and its neighbours; `bench` in bench/, `fly` in apps/fly/).
#include "bench_cli.hpp"
#include "cache_dir.hpp"
#include "cli_checks.hpp"
#include "compare_command.hpp"
#include "export_command.hpp"
#include "flythrough_command.hpp"
#include "fly_command.hpp"
#include "ig_command.hpp"
#include "render_command.hpp"
#include "scene_options.hpp"
#include "terminal_text.hpp"

#include "nephele/cloud_matter.hpp"
#include "nephele/context.hpp"
#include "nephele/limits.hpp"
#include "nephele/log.hpp"
#include "nephele/scene.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include <unistd.h>

using namespace nephele;
using namespace nephele::cli;

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
        std::fprintf(stderr, "\r%.*s [%s] %3d%%%s", int(label.size()), label.data(), bar, percent,
                     percent == 100 ? "\n" : "");
        std::fflush(stderr);
    });
}

namespace {

const CLI::Validator kPath = nonEmptyPath();

// Where the camera's line of sight meets the ellipsoid clouds' matter (the path tracer's field,
// noise and detail included, seen from the camera; the layers left out), at the scene's time 0:
// how far a pilot is from the cloud he looks at. Midpoint steps of 0.25 m within the chords, a
// fraction of a mean free path of the densest cumulus.
std::string lineOfSight(const Scene& scene) {
    NoiseVolume noise;
    if (scene.medium.noise > 0) {
        const NoiseSettings ns;  // the path tracer's
        noise = makeNoiseVolume(ns);
    }
    const Camera cam = cameraAt(scene, 0.0);
    const CloudMatter matter(scene, &noise, cam.position, kMaxOpticalDepth, false);
    std::ostringstream out;
    out << std::fixed;
    out.precision(1);
    out << "camera: ";
    if (matter.empty()) return out << "no cloud matter in the scene", out.str();
    const Vec3 o = cam.position, d = glm::normalize(cam.direction);
    const double inside = matter.extinction(o);
    if (inside > 0)
        out << "inside cloud matter (" << std::setprecision(4) << inside << std::setprecision(1) << " /m); ";
    std::vector<CloudMatter::Chord> chords;
    matter.chords(o, d, cam.nearClip, cam.farClip, chords);
    constexpr double kStep = 0.25;
    constexpr long kMaxSteps = 4'000'000;  // 1000 km of chords: bounded for any scene
    double tau = 0, enter = -1, depth1 = -1;
    long steps = 0;
    // Runs of overlapping chords (as CloudField::cloudDepth), each marched once with its own
    // chords only: a step costs the chords at hand, not every chord of the line.
    for (size_t first = 0, end; first < chords.size() && depth1 < 0 && steps < kMaxSteps; first = end) {
        double t1;
        end = CloudMatter::runEnd(chords, first, t1);
        const std::span<const CloudMatter::Chord> run(chords.data() + first, end - first);
        for (double t = chords[first].tIn; t < t1 && depth1 < 0 && steps < kMaxSteps; t += kStep, ++steps) {
            const double h = std::min(kStep, t1 - t), sigma = matter.extinctionAlong(o, d, t + h / 2, run);
            if (sigma > 0 && enter < 0) enter = t;
            tau += sigma * h;
            if (tau >= 1) depth1 = t + h;
        }
    }
    if (enter < 0) return out << "its line of sight meets no cloud matter", out.str();
    out << "its line of sight ";
    if (inside <= 0) out << "meets cloud matter at " << enter << " m and ";
    if (depth1 >= 0) out << "reaches optical depth 1 at " << depth1 << " m";
    else out << "passes through it with optical depth " << std::setprecision(3) << tau;
    return out.str();
}

// `info SCENE`: load the scene and print what it holds (no GL).
int runInfoScene(const std::string& file) {
    try {
        const Scene scene = loadScene(file);
        size_t ellipsoids = 0;
        for (const Cloud& c : scene.clouds) ellipsoids += c.ellipsoids.size();
        std::cout << scene.file << ": " << scene.clouds.size() << " clouds, " << ellipsoids << " ellipsoids\n";
        for (const GenerateStats& g : scene.generated)
            std::cout << "generate " << g.name << ": placed " << g.placed << ", pruned " << g.prunedHollow
                      << " hollow / " << g.prunedContained << " contained"
                      << (g.degenerate ? ", " + std::to_string(g.degenerate) + " degenerate skipped" : "") << ", kept "
                      << g.kept << "\n";
        std::cout << lineOfSight(scene) << "\n";
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
    return name + ": '" + value + "' is not " +
           (integer ? "an integer; it takes a whole number" + range + ", written without an exponent or a fraction"
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

// `render`: the shared options, then its outputs.
CLI::App* addRenderCommand(CLI::App& app, RenderOptions& ro, SceneArgs& args) {
    CLI::App* render = app.add_subcommand("render", "Render a scene to a PNG (headless)");
    addSceneOptions(render, args);
    render->add_option("-o,--output", ro.output, "Output PNG (sRGB, 8-bit)")->required()->check(kPath);
    render->add_option("--alpha", ro.alpha, "Also write the cloud opacity as an 8-bit grey PNG")->check(kPath);
    render->add_option("--pfm", ro.pfm, "Also write linear float RGB as PFM")->check(kPath);
    render
        ->add_option("--density-alpha", ro.densityAlpha,
                     "Also write the exact opacity of the scene's density field (8-bit grey), to check --alpha against")
        ->check(kPath);
    render->add_flag(
        "--silhouette", ro.silhouette,
        "Print the box-counting dimension of the cloud opacity's alpha > 0.5 silhouette (boxes 2-32 px) on stdout");
    render->add_option("--time", ro.time, "Time in seconds (wind, lightning, camera path)")
        ->check(within(-1e9, 1e9))
        ->capture_default_str();
    return render;
}

// `flythrough`: the shared options, then its frames' folder and timing.
CLI::App* addFlythroughCommand(CLI::App& app, FlythroughOptions& fo, SceneArgs& args) {
    CLI::App* fly = app.add_subcommand("flythrough", "Render the scene's camera path to numbered PNG frames");
    addSceneOptions(fly, args);
    fly->add_option("--out-dir", fo.outDir, "Folder for the frames and flythrough.json (new or empty)")
        ->required()
        ->check(kPath);
    fly->add_option("--fps", fo.fps,
                    "Frames per second of scene time (at most " + std::to_string(kMaxFrames) + " frames)")
        ->check(within(0.001, 1000))
        ->capture_default_str();
    fly->add_option("--reference-dir", fo.referenceDir, "A reference run's --out-dir: also report the flicker index")
        ->check(kPath);
    fly->add_flag("--timings", fo.timings,
                  "Also record the compositor's plan, tile-pass and composite ms of every frame in flythrough.json "
                  "(a glFinish between the parts: the frames get a little slower)");
    return fly;
}

CLI::App* addCompareCommand(CLI::App& app, CompareOptions& co) {
    CLI::App* compare =
        app.add_subcommand("compare", "Compare two renders: one JSON line (exposure-fitted RMSE, PSNR, SSIM, alpha)");
    compare->add_option("a", co.a, "Image A (.png sRGB or .pfm linear)")->required()->check(kPath);
    compare->add_option("b", co.b, "Image B, the reference")->required()->check(kPath);
    compare->add_option("--alpha-a", co.alphaA, "A's cloud opacity (grey .png or .pfm)")->check(kPath);
    compare->add_option("--alpha-b", co.alphaB, "B's cloud opacity (grey .png or .pfm)")->check(kPath);
    return compare;
}

CLI::App* addExportCommand(CLI::App& app, ExportOptions& eo) {
    CLI::App* exportCmd = app.add_subcommand("export",
                                             "Write the scene's extinction field, as the path tracer renders it, "
                                             "to a file (docs/cli.md, \"export\")");
    exportCmd->add_option("scene", eo.scene, "Scene file (cloudscene JSON, see data/scene-format.md)")
        ->required()
        ->check(kPath);
    exportCmd->add_option("--vdb", eo.vdb, "Output OpenVDB file: a FloatGrid named 'density', in 1/m")
        ->required()
        ->check(kPath);
    exportCmd
        ->add_option("--voxel", eo.voxel, "Voxel edge in metres (default: the field's box shared among 256^3 voxels)")
        ->check(within(1e-3, 1e6));
    exportCmd
        ->add_option("--time", eo.time,
                     "Time in seconds (the layers' wind; the camera path, on whose eye the layers centre)")
        ->check(within(-1e9, 1e9))
        ->capture_default_str();
    return exportCmd;
}

// `info`: a context, or with a scene what the scene holds.
struct InfoArgs {
    std::string gl = "egl", scene;
};
CLI::App* addInfoCommand(CLI::App& app, InfoArgs& a) {
    CLI::App* info = app.add_subcommand("info", "Make a GL context and print what it is");
    info->add_option("--gl", a.gl, "egl, osmesa or glfw")->check(CLI::IsMember({"egl", "osmesa", "glfw"}));
    info->add_option("scene", a.scene,
                     "Instead: load this scene and print its clouds and what each `generate` entry made")
        ->check(kPath);
    return info;
}

// A command that renders: its shared options checked into `options`, then run.
template <class Options, class Run>
int runChecked(const SceneArgs& args, Options& options, RenderOptions& render, Run run) {
    try {
        applySceneArgs(args, render);
    } catch (const std::exception& e) {
        return reportError(e, "checking the settings");
    }
    return run(options);
}

int run(int argc, char** argv) {
    CLI::App app{"Nephele: cloud rendering for flight and helicopter simulators"};
    app.set_version_flag("--version", "nephele 0.1.0");
    app.footer(limitsHelp());
    app.require_subcommand(1);

    RenderOptions ro;
    SceneArgs renderArgs;
    addRenderCommand(app, ro, renderArgs);
    FlythroughOptions fo;
    SceneArgs flyArgs;
    CLI::App* fly = addFlythroughCommand(app, fo, flyArgs);
    fly::FlyOptions flyo;
    CLI::App* flyCmd = fly::addFlyCommand(app, flyo);
    BenchArgs benchArgs;
    CLI::App* bench = addBenchCommand(app, benchArgs);
    CompareOptions co;
    CLI::App* compare = addCompareCommand(app, co);
    ExportOptions eo;
    CLI::App* exportCmd = addExportCommand(app, eo);
    InfoArgs infoArgs;
    CLI::App* info = addInfoCommand(app, infoArgs);
    IgOptions igo;
    SceneArgs igArgs;
    CLI::App* ig = app.add_subcommand("ig", "Draw one display channel for a CIGI 3.3 host over UDP (docs/cigi.md)");
    addSceneOptions(ig, igArgs);
    addIgOptions(ig, igo);

    if (const int code = parse(app, argc, argv); code >= 0) return code;
    if (*ig) return runChecked(igArgs, igo, igo.render, runIg);
    if (*flyCmd) return flyo.cacheDir = defaultCacheDir(""), fly::runFly(flyo);
    if (*info) return infoArgs.scene.empty() ? runInfoContext(infoArgs.gl) : runInfoScene(infoArgs.scene);
    if (*compare) return runCompare(co);
    if (*exportCmd) return eo.cacheDir = defaultCacheDir(""), runExport(eo);
    if (*bench) return runBenchCommand(benchArgs);
    if (*fly) {
        fo.render.ellipsoid.timings = fo.timings;
        return runChecked(flyArgs, fo, fo.render, runFlythrough);
    }
    return runChecked(renderArgs, ro, ro, runRender);
}

}  // namespace

int main(int argc, char** argv) {
    installConsoleLogging();
    const auto escaped = escapeStream(std::cerr);  // every message, whatever path it quotes
    // The last word on what escaped the commands' own handling: a message and exit 1, never an abort.
    try {
        return run(argc, argv);
    } catch (const std::bad_alloc&) {
        std::fprintf(
            stderr,
            "nephele: out of memory (std::bad_alloc); lower the image size or the settings that size the work\n");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nephele: %s\n", terminalText(e.what()).c_str());
    }
    return 1;
}
