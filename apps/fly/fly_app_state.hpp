// The interactive window's state, shared by fly_app.cpp (events, flight, reload) and
// fly_hud.cpp (HUD, help, live controls and debug views). Internal to `nephele fly`.
#pragma once

#include "fly_app.hpp"
#include "fly_script.hpp"

#include "nephele/context.hpp"
#include "nephele/gl.hpp"
#include "nephele/scene.hpp"

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace nephele::fly {

struct FlyApp::State {
    FlyAppOptions options;
    std::unique_ptr<Context> context;
    std::unique_ptr<FlyHost> host;
    Scene scene;
    std::string sceneError, sceneStatus;
    std::filesystem::file_time_type sceneTime{};
    double lastReloadCheck = 0;
    FlyPose pose;
    FlyInput input;
    bool dragging = false;
    double cursorX = 0, cursorY = 0;
    bool followPath = false;
    std::vector<Camera> script;  // --script: the flight's cameras, one per step of 1 / scriptFps
    double scriptStart = 0, scriptFps = 0;
    bool playing = false;          // the script plays (in a loop, until R)
    double t = 0;                  // scene time
    double lastWall = -1;          // glfwGetTime of the last frame
    double fps = 0;                // smoothed
    int renderW = 0, renderH = 0;  // the last frame's size
    Camera camera;                 // the last frame's camera
    FlyViews views;
    FlyFrameStats stats;
    std::optional<InputRecorder> recorder;
    std::vector<gl::Texture> atlasViews;  // the atlas debug view: a small RGBA8 copy per layer
    gl::Framebuffer atlasRead, atlasDraw;
    int atlasViewW = 0, atlasViewH = 0;
    bool imgui = false;
    std::string capture;  // PNG to write from the next frame
    int screenshots = 0;
};

// fly_hud.cpp: all of it drawn with Dear ImGui inside one ImGui frame.
void drawOverlay(FlyApp::State& s);
// The key list the help overlay shows.
extern const char* const kHelp;

}  // namespace nephele::fly
