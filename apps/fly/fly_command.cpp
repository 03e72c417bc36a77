#include "fly_command.hpp"
#include "fly_app.hpp"
#include "cli_checks.hpp"
#include "output_files.hpp"

#include "nephele/context.hpp"

#include <CLI/CLI.hpp>

#include <iostream>

namespace nephele::fly {

CLI::App* addFlyCommand(CLI::App& app, FlyOptions& o) {
    CLI::App* cmd = app.add_subcommand("fly", "Fly through a scene in a window, or record a scripted flight");
    cmd->add_option("scene", o.scene, "Scene file (default: data/scenes/showcase.json)")->check(cli::nonEmptyPath());
    cmd->add_option("--method", o.method, "auto|ellipsoid|raymarch|layered (switch live with M)")
        ->capture_default_str();
    cmd->add_option("--width", o.width, "Window width (default 1280), or recorded frame width (default the camera's)")
        ->check(cli::within(1, 16384));
    cmd->add_option("--height", o.height,
                    "Window height (default 720), or recorded frame height (default the camera's)")
        ->check(cli::within(1, 16384));
    cmd->add_option("--render-scale", o.renderScale, "Draw frames at this fraction of the window (faster), (0, 1]")
        ->check(cli::within(0.05, 1.0))
        ->capture_default_str();
    cmd->add_option("--script", o.script,
                    "Flight to play (keyframes or recorded inputs, JSON): recorded with --record, else in the window")
        ->check(cli::nonEmptyPath());
    cmd->add_option("--record", o.record,
                    "Folder (new or empty) for the frames, frames.csv, flight.json and flight.mp4")
        ->check(cli::nonEmptyPath());
    cmd->add_option("--record-input", o.recordInput, "Write the interactive flight's inputs to this file (a --script)")
        ->check(cli::nonEmptyPath());
    cmd->add_option("--fps", o.fps, "Recording the scene's path (no --script): frames per second")
        ->check(cli::within(0.001, 1000))
        ->capture_default_str();
    cmd->add_flag("--headless", o.headless, "Record without a window (EGL)");
    cmd->add_flag("!--no-video", o.video, "Do not write flight.mp4 (written when ffmpeg is installed)");
    return cmd;
}

int runFly(const FlyOptions& given) {
    FlyOptions o = given;
    if (o.scene.empty()) o.scene = NEPHELE_SOURCE_DIR "/data/scenes/showcase.json";
    if (!o.record.empty() && !o.recordInput.empty()) {
        std::cerr << "nephele: --record-input records the window's flight; it does not go with --record\n";
        return 2;
    }
    if (!o.record.empty()) return runFlyRecord(o);
    if (o.headless) {
        std::cerr << "nephele: --headless needs --record DIR (without it, fly opens a window)\n";
        return 2;
    }
    if (!o.script.empty() && !o.recordInput.empty()) {
        std::cerr << "nephele: --record-input records a flight flown by hand; it does not go with --script\n";
        return 2;
    }
    const auto method = parseFlyMethod(o.method);
    if (!method) {
        std::cerr << "nephele: --method: unknown method '" << o.method
                  << "' (expected auto, ellipsoid, raymarch or layered)\n";
        return 2;
    }
    try {
        cli::OutputFiles check;
        if (!o.recordInput.empty()) {
            check.add(o.recordInput, nullptr, "--record-input");
            check.checkPaths();
            check.refuseInput(o.scene, "scene file");
        }
        FlyAppOptions ao;
        ao.scene = o.scene, ao.method = *method, ao.renderScale = o.renderScale, ao.recordInput = o.recordInput;
        ao.script = o.script;
        ao.cacheDir = o.cacheDir;
        if (o.width > 0) ao.width = o.width;
        if (o.height > 0) ao.height = o.height;
        FlyApp app(ao);
        return app.run();
    } catch (const SceneError& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 2;
    } catch (const std::invalid_argument& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 2;
    } catch (const ContextError& e) {
        std::cerr << "nephele: fly failed: " << e.what() << " (no display? run it under a desktop or xvfb-run)\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "nephele: fly failed: " << e.what() << "\n";
        return 1;
    }
}

}  // namespace nephele::fly
