// `nephele fly [SCENE.json]`: the interactive window. A GLFW window with helicopter controls
// (fly_controls.hpp), a HUD and debug views drawn with Dear ImGui (Debian's libimgui-dev, its
// GLFW and OpenGL 3 backends), live controls, and the scene file reloaded when it changes.
#pragma once

#include "fly_controls.hpp"
#include "fly_host.hpp"

#include <memory>
#include <string>

struct GLFWwindow;

namespace nephele::fly {

struct FlyAppOptions {
    std::string scene;
    FlyMethod method = FlyMethod::Auto;
    int width = 1280, height = 720;  // window size (resizable)
    double renderScale = 1;          // frames drawn at this fraction of the window's size, (0, 1]
    std::string recordInput;         // written by finish(): the inputs, for --script
    std::string script;              // a flight to play in the window (fly_script.hpp), in a loop until R
    std::string cacheDir;
    bool visible = true;
};

// What is shown; each toggles on a key (see kHelp in fly_hud.cpp).
struct FlyViews {
    bool hud = true, help = false, controls = false;
    bool atlas = false, tiles = false, cells = false;
};

class FlyApp {
public:
    // Opens the window and loads the scene: throws SceneError (bad scene) or ContextError.
    explicit FlyApp(const FlyAppOptions& options);
    ~FlyApp();
    FlyApp(const FlyApp&) = delete;
    FlyApp& operator=(const FlyApp&) = delete;

    // One frame: events, flight by dt seconds (dt < 0: the wall time since the last frame,
    // at most 0.5 s), draw, HUD, swap. False once the window was asked to close.
    bool frame(double dt = -1);
    // frame() until the window closes, then finish(). Returns the exit code.
    int run();
    // Writes --record-input (all or nothing); throws on failure.
    void finish();

    // Writes the window as the next frame shows it (HUD and views included) to a PNG (F12
    // writes nephele_fly_N.png in the working folder).
    void captureNextFrame(const std::string& png);

    GLFWwindow* window() const;
    const FlyPose& pose() const;
    FlyViews& views();
    const FlyFrameStats& stats() const;
    const std::string& sceneError() const;  // the last reload's error ("" when the scene is good)
    double time() const;                    // scene time (s)
    int renderWidth() const;
    int renderHeight() const;

    struct State;

private:
    std::unique_ptr<State> s_;
};

// The current context's window back buffer, w x h, as it shows (its 8-bit values / 255: sRGB
// when presented as FlyHost::present does), row 0 at the top.
Image readWindow(int w, int h);

}  // namespace nephele::fly
