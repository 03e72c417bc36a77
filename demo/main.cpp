// The `nephele` command-line tool.
#include "render_command.hpp"

#include "nephele/context.hpp"

#include <CLI/CLI.hpp>

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
    render->add_option("--method", method, "auto|ellipsoid|layered|raymarch|pathtrace|gardner-exact")
        ->capture_default_str();
    auto* w = render->add_option("--width", width, "Image width in pixels (overrides the camera)");
    auto* h = render->add_option("--height", height, "Image height in pixels (overrides the camera)");
    render->add_option("--scale", scale, "Scale the camera's image size")->excludes(w)->excludes(h);
    render->add_option("--time", ro.time, "Time in seconds (wind, lightning, camera path)")->capture_default_str();
    render->add_option("--gl", backend, "OpenGL backend: egl (headless) or osmesa")
        ->check(CLI::IsMember({"egl", "osmesa"}))
        ->capture_default_str();

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
    } catch (const std::exception& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 2;
    }
    if (render->count("--width")) ro.width = width;
    if (render->count("--height")) ro.height = height;
    if (render->count("--scale")) ro.scale = scale;
    return runRender(ro);
}
