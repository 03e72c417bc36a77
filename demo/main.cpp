// The `nephele` command-line tool.
#include "bench_command.hpp"
#include "render_command.hpp"

#include "nephele/context.hpp"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>

using namespace nephele;
using namespace nephele::cli;

int main(int argc, char** argv) {
    CLI::App app{"Nephele: cloud rendering for flight and helicopter simulators"};
    app.set_version_flag("--version", "nephele 0.1.0");
    app.require_subcommand(1);

    RenderOptions ro;
    std::string method = "auto", backend = "egl";
    int width = 0, height = 0;
    double scale = 0;
    CLI::App* render = app.add_subcommand("render", "Render a scene to a PNG (headless)");
    render->add_option("scene", ro.scene, "Scene file (cloudscene JSON, see data/scene-format.md)")->required();
    render->add_option("-o,--output", ro.output, "Output PNG (sRGB, 8-bit)")->required();
    render->add_option("--alpha", ro.alpha, "Also write the cloud opacity as an 8-bit grey PNG");
    render->add_option("--pfm", ro.pfm, "Also write linear float RGB as PFM");
    render->add_option("--density-alpha", ro.densityAlpha,
                       "Also write the exact opacity of the scene's density field (8-bit grey), to check --alpha against");
    render->add_option("--method", method, "auto|ellipsoid|layered|raymarch|pathtrace|gardner-exact")
        ->capture_default_str();
    auto* w = render->add_option("--width", width, "Image width in pixels (overrides the camera)");
    auto* h = render->add_option("--height", height, "Image height in pixels (overrides the camera)");
    render->add_option("--scale", scale, "Scale the camera's image size")->excludes(w)->excludes(h);
    render->add_option("--time", ro.time, "Time in seconds (wind, lightning, camera path)")->capture_default_str();
    render->add_option("--gl", backend, "OpenGL backend: egl (headless) or osmesa")
        ->check(CLI::IsMember({"egl", "osmesa"}))
        ->capture_default_str();

    int minTile = 8, maxTile = 512;
    std::string atlas, precision = "f16", draws = "instanced", flythrough = "fraction";
    render->add_option("--min-tile", minTile, "Ellipsoid tiles: smallest size (px, power of two)")->capture_default_str();
    render->add_option("--max-tile", maxTile, "Ellipsoid tiles: largest size (px, power of two)")->capture_default_str();
    render->add_option("--atlas", atlas, "Ellipsoid atlas size WxH (default: the image size)");
    render->add_option("--precision", precision, "Ellipsoid atlas precision: f16 or u8 (the paper's 8 bits)")
        ->check(CLI::IsMember({"f16", "u8"}))
        ->capture_default_str();
    render->add_option("--draws", draws, "instanced, or per-ellipsoid (the paper's one draw per ellipsoid)")
        ->check(CLI::IsMember({"instanced", "per-ellipsoid"}))
        ->capture_default_str();
    std::string colourMatrix = "pass";
    render->add_option("--colour-matrix", colourMatrix, "pass (the paper's copy through the matrix) or fused (in the composite)")
        ->check(CLI::IsMember({"pass", "fused"}))
        ->capture_default_str();
    render->add_option("--flythrough", flythrough, "Objects in clouds: fraction (optical depth in front) or stencil (the paper)")
        ->check(CLI::IsMember({"fraction", "stencil"}))
        ->capture_default_str();

    BenchOptions bo;
    std::string benchGl = "egl";
    CLI::App* bench = app.add_subcommand("bench", "Time the ellipsoid compositor against its floor and baseline");
    bench->add_option("--out-dir", bo.outDir, "Folder for the CSV, the markdown table and the chart")->capture_default_str();
    bench->add_option("--readme", bo.readme, "Also replace the generated bench section of this README");
    bench->add_option("--counts", bo.counts, "Ellipsoid counts")->capture_default_str();
    bench->add_option("--frames", bo.frames, "Measured frames per point (median)")->check(CLI::Range(1, 1000))->capture_default_str();
    bench->add_option("--width", bo.width, "Frame width")->check(CLI::Range(16, 16384))->capture_default_str();
    bench->add_option("--height", bo.height, "Frame height")->check(CLI::Range(16, 16384))->capture_default_str();
    bench->add_flag("!--no-accuracy", bo.accuracy, "Skip the accuracy figures on the shared scenes");
    bench->add_option("--scenes", bo.scenesDir, "Folder of the shared scenes")->capture_default_str();
    bench->add_option("--gl", benchGl, "egl or osmesa")->check(CLI::IsMember({"egl", "osmesa"}));

    CLI::App* info = app.add_subcommand("info", "Make a GL context and print what it is");
    info->add_option("--gl", backend, "egl, osmesa or glfw")->check(CLI::IsMember({"egl", "osmesa", "glfw"}));

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    }

    if (*bench) {
        for (int c : bo.counts)
            if (c < 1 || c > 1000000) {
                std::cerr << "nephele: --counts: " << c << " is out of range 1..1000000\n";
                return 2;
            }
        bo.backend = parseBackend(benchGl);
        return runBench(bo);
    }

    if (*info) {
        try {
            ContextOptions co;
            co.backend = parseBackend(backend);
            co.visible = false;
            auto ctx = Context::create(co);
            std::cout << backendName(co.backend) << ": " << ctx->description() << "\n";
            return 0;
        } catch (const std::exception& e) {
            std::cerr << "nephele: " << e.what() << "\n";
            return 1;
        }
    }

    try {
        ro.method = parseMethod(method);
        ro.backend = parseBackend(backend);
        EllipsoidSettings& es = ro.ellipsoid;
        auto pow2 = [](const char* what, int v) {
            if (v < 1 || v > 16384 || (v & (v - 1)) != 0)
                throw UsageError(std::string(what) + " must be a power of two in 1..16384, got " + std::to_string(v));
            return v;
        };
        es.minTile = pow2("--min-tile", minTile);
        es.maxTile = pow2("--max-tile", maxTile);
        if (es.minTile > es.maxTile) throw UsageError("--min-tile must not exceed --max-tile");
        if (!atlas.empty()) {
            int w = 0, h = 0;
            char x = 0, extra = 0;
            if (std::sscanf(atlas.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || w < 1 ||
                h < 1 || w > 16384 || h > 16384)
                throw UsageError("--atlas must be WxH with sizes in 1..16384, got '" + atlas + "'");
            if (w < es.minTile || h < es.minTile) throw UsageError("--atlas is smaller than --min-tile");
            es.atlasWidth = w;
            es.atlasHeight = h;
        }
        es.precision = precision == "u8" ? AtlasPrecision::Unorm8 : AtlasPrecision::Float16;
        es.instanced = draws == "instanced";
        es.colourMatrixPass = colourMatrix == "pass";
        es.flyThrough = flythrough == "stencil" ? FlyThrough::Stencil : FlyThrough::Fraction;
    } catch (const std::exception& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 2;
    }
    if (render->count("--width")) ro.width = width;
    if (render->count("--height")) ro.height = height;
    if (render->count("--scale")) ro.scale = scale;
    return runRender(ro);
}
