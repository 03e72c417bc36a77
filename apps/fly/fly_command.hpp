// `nephele fly [SCENE.json]`: the interactive window (fly_app.hpp), and scripted or
// path-following flights recorded to a folder (`--record DIR`).
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace nephele::fly {

struct FlyOptions {
    std::string scene;            // default: data/scenes/showcase.json of the source tree
    std::string method = "auto";  // auto | ellipsoid | raymarch | layered
    int width = 0, height = 0;    // window (default 1280x720) or recorded frame (default the camera's) size
    double renderScale = 1;       // interactive: frames drawn at this fraction of the window, (0, 1]
    std::string script;           // FLIGHT.json (fly_script.hpp)
    std::string record;           // DIR: PNG frames, frames.csv, flight.json, flight.mp4
    std::string recordInput;      // FILE: the interactive flight's inputs, for --script
    double fps = 10;              // recording the scene's path (no --script): frames per second
    bool headless = false;        // record with EGL, no window
    bool video = true;            // flight.mp4 when ffmpeg is on PATH
    std::string cacheDir;         // the layered sky's lighting cache
};

// Adds the `fly` subcommand to `app`, its options parsed into `options`.
CLI::App* addFlyCommand(CLI::App& app, FlyOptions& options);
// Returns the exit code: 0, 2 for bad input (scene, script, options), 1 for runtime failures.
int runFly(const FlyOptions& options);
// `--record`: plays the flight at its fixed step and writes DIR all or nothing.
int runFlyRecord(const FlyOptions& options);

}  // namespace nephele::fly
