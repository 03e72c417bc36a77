#include "fly_app.hpp"
#include "fly_app_state.hpp"
#include "output_files.hpp"

#include "nephele/camera.hpp"
#include "nephele/image.hpp"
#include "nephele/png.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <fstream>

namespace nephele::fly {

Image readWindow(int w, int h) {
    Image bottomUp(w, h, 3), image(w, h, 3);
    gl::glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    gl::glPixelStorei(GL_PACK_ALIGNMENT, 4);
    gl::glReadPixels(0, 0, w, h, GL_RGB, GL_FLOAT, bottomUp.pixels.data());
    gl::checkAlways("reading the window");
    const std::size_t row = std::size_t(w) * 3;
    for (int y = 0; y < h; ++y)
        std::copy_n(bottomUp.pixels.data() + std::size_t(h - 1 - y) * row, row, image.pixels.data() + y * row);
    return image;
}

namespace {
FlyApp::State& stateOf(GLFWwindow* w) { return *static_cast<FlyApp::State*>(glfwGetWindowUserPointer(w)); }

void resetToScene(FlyApp::State& s) {
    s.pose = poseFromCamera(s.scene.path.size() >= 2 ? cameraAt(s.scene, s.scene.path.front().t) : s.scene.camera);
    s.t = s.scene.path.empty() ? 0 : s.scene.path.front().t;
    s.followPath = false;
    s.playing = false;
}

// --script: plays the flight from its first frame, at its own time.
void startScript(FlyApp::State& s, const Flight& flight) {
    s.script = flightCameras(flight, s.scene);
    s.scriptStart = flight.firstTime(), s.scriptFps = flight.fps;
    s.t = s.scriptStart;
    s.playing = true;
}

// The script's camera at scene time t: the frame of the step it is in.
const Camera& scriptCamera(const FlyApp::State& s) {
    const auto k = std::size_t(std::clamp((s.t - s.scriptStart) * s.scriptFps, 0.0, double(s.script.size() - 1)));
    return s.script[k];
}

// The keys that are not flight controls (those are applyKey's).
void commandKey(FlyApp::State& s, int key) {
    FlyViews& v = s.views;
    switch (key) {
        case GLFW_KEY_H: v.help = !v.help; break;
        case GLFW_KEY_TAB: v.controls = !v.controls; break;
        case GLFW_KEY_F1: v.hud = !v.hud; break;
        case GLFW_KEY_F2: v.atlas = !v.atlas; break;
        case GLFW_KEY_F3: v.tiles = !v.tiles; break;
        case GLFW_KEY_F4: v.cells = !v.cells; break;
        case GLFW_KEY_M: s.host->setMethod(kFlyMethods[(int(s.host->settings().method) + 1) % 4]); break;
        case GLFW_KEY_O:
            s.host->setOrder(s.host->order() == CompositeOrder::Weighted ? CompositeOrder::PerEllipsoid
                                                                         : CompositeOrder::Weighted);
            break;
        case GLFW_KEY_P: s.followPath = !s.followPath && s.scene.path.size() >= 2; break;
        case GLFW_KEY_R: resetToScene(s); break;
        case GLFW_KEY_F12: s.capture = "nephele_fly_" + std::to_string(++s.screenshots) + ".png"; break;
        case GLFW_KEY_ESCAPE: glfwSetWindowShouldClose(s.context->window(), GLFW_TRUE); break;
        default: break;
    }
}

void onKey(GLFWwindow* w, int key, int scancode, int action, int mods) {
    FlyApp::State& s = stateOf(w);
    if (s.imgui) ImGui_ImplGlfw_KeyCallback(w, key, scancode, action, mods);
    if (action == GLFW_REPEAT || (s.imgui && ImGui::GetIO().WantTextInput)) return;
    const bool down = action == GLFW_PRESS;
    if (!applyKey(s.input, key, down) && down) commandKey(s, key);
}

void onMouseButton(GLFWwindow* w, int button, int action, int mods) {
    FlyApp::State& s = stateOf(w);
    if (s.imgui) ImGui_ImplGlfw_MouseButtonCallback(w, button, action, mods);
    if (button != GLFW_MOUSE_BUTTON_LEFT) return;
    const bool overUi = s.imgui && ImGui::GetIO().WantCaptureMouse;
    s.dragging = action == GLFW_PRESS && !overUi;  // from the cursor's last position (onCursor)
}

void onCursor(GLFWwindow* w, double x, double y) {
    FlyApp::State& s = stateOf(w);
    if (s.dragging) s.input.mouseDx += x - s.cursorX, s.input.mouseDy += y - s.cursorY;
    s.cursorX = x, s.cursorY = y;
}

void onScroll(GLFWwindow* w, double dx, double dy) {
    if (stateOf(w).imgui) ImGui_ImplGlfw_ScrollCallback(w, dx, dy);
}

void onChar(GLFWwindow* w, unsigned c) {
    if (stateOf(w).imgui) ImGui_ImplGlfw_CharCallback(w, c);
}

// Reloads the scene when its file changed (checked twice a second); a bad edit keeps the
// last good scene and shows its error.
void pollReload(FlyApp::State& s, double wall) {
    if (wall - s.lastReloadCheck < 0.5) return;
    s.lastReloadCheck = wall;
    std::error_code ec;
    const auto mtime = std::filesystem::last_write_time(s.options.scene, ec);
    if (ec || mtime == s.sceneTime) return;
    s.sceneTime = mtime;
    try {
        s.scene = loadScene(s.options.scene);
        s.host->sceneChanged();
        s.sceneError.clear();
        const std::time_t now = std::time(nullptr);
        char when[16];
        std::strftime(when, sizeof when, "%H:%M:%S", std::localtime(&now));
        s.sceneStatus = std::string("reloaded at ") + when;
    } catch (const std::exception& e) {
        s.sceneError = e.what();
    }
}

// Moves the eye by dt: along the scene's path when following it, else by the controls.
void fly(FlyApp::State& s, double dt) {
    if (s.recorder) s.recorder->add(s.t, s.input);  // held from the step's start, as a script replays it
    s.t += dt;
    if (s.playing) {
        if (s.t >= s.scriptStart + double(s.script.size()) / s.scriptFps) s.t = s.scriptStart;  // loop
        s.pose = poseFromCamera(scriptCamera(s));
    } else if (s.followPath && s.scene.path.size() >= 2) {
        if (s.t > s.scene.path.back().t) s.t = s.scene.path.front().t;  // loop
        s.pose = poseFromCamera(cameraAt(s.scene, s.t));
    } else {
        s.pose = stepFlight(s.pose, s.input, dt);
    }
    s.input.mouseDx = s.input.mouseDy = 0;
}

// The window's back buffer (already sRGB-encoded) to a PNG.
void writeWindow(const std::string& png, int w, int h) { writePng(png, readWindow(w, h), Encoding::Linear); }

Camera frameCamera(const FlyApp::State& s, int fw, int fh) {
    Camera c = s.playing                                  ? scriptCamera(s)
               : s.followPath && s.scene.path.size() >= 2 ? cameraAt(s.scene, s.t)
                                                          : cameraFromPose(s.pose, s.scene.camera);
    c.width = std::max(1, int(std::lround(fw * s.options.renderScale)));
    c.height = std::max(1, int(std::lround(fh * s.options.renderScale)));
    return c;
}
}  // namespace

FlyApp::FlyApp(const FlyAppOptions& o) : s_(std::make_unique<State>()) {
    State& s = *s_;
    s.options = o;
    s.scene = loadScene(o.scene);
    std::error_code ec;
    s.sceneTime = std::filesystem::last_write_time(o.scene, ec);
    s.sceneStatus = "loaded";
    resetToScene(s);
    if (!o.script.empty()) startScript(s, loadFlight(o.script));
    ContextOptions co;
    co.backend = GlBackend::Glfw;
    co.width = o.width, co.height = o.height, co.visible = o.visible;
    co.title = "nephele fly: " + o.scene;
    s.context = Context::create(co);
    gl::setChecks(true);
    s.host = std::make_unique<FlyHost>(FlyHostSettings{o.method, std::nullopt, o.cacheDir, true});
    GLFWwindow* w = s.context->window();
    glfwSetWindowUserPointer(w, &s);
    glfwSwapInterval(0);
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the working folder
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForOpenGL(w, false);
    ImGui_ImplOpenGL3_Init("#version 410 core");
    s.imgui = true;
    glfwSetKeyCallback(w, onKey);
    glfwSetMouseButtonCallback(w, onMouseButton);
    glfwSetCursorPosCallback(w, onCursor);
    glfwSetScrollCallback(w, onScroll);
    glfwSetCharCallback(w, onChar);
    glfwGetCursorPos(w, &s.cursorX, &s.cursorY);
    if (!o.recordInput.empty()) s.recorder.emplace(s.pose, 30);
}

FlyApp::~FlyApp() {
    State& s = *s_;
    if (!s.imgui) return;
    s.context->makeCurrent();
    s.atlasViews.clear();
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
}

bool FlyApp::frame(double dt) {
    State& s = *s_;
    GLFWwindow* w = s.context->window();
    glfwPollEvents();
    if (glfwWindowShouldClose(w)) return false;
    const double wall = glfwGetTime();
    if (dt < 0) dt = s.lastWall < 0 ? 0 : std::min(wall - s.lastWall, 0.5);
    if (s.lastWall >= 0 && wall > s.lastWall)
        s.fps = s.fps == 0 ? 1 / (wall - s.lastWall) : 0.9 * s.fps + 0.1 / (wall - s.lastWall);
    s.lastWall = wall;
    pollReload(s, wall);
    fly(s, dt);
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(w, &fw, &fh);
    if (fw <= 0 || fh <= 0) return true;  // minimised
    const Camera camera = frameCamera(s, fw, fh);
    s.stats = s.host->draw(s.scene, camera, s.t);
    s.renderW = camera.width, s.renderH = camera.height;
    s.camera = camera;
    s.host->present(0, fw, fh);
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    drawOverlay(s);
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    gl::checkAlways("drawing the window's frame");
    if (!s.capture.empty()) writeWindow(s.capture, fw, fh), s.capture.clear();
    glfwSwapBuffers(w);
    return true;
}

int FlyApp::run() {
    while (frame()) {}
    finish();
    return 0;
}

void FlyApp::finish() {
    State& s = *s_;
    if (!s.recorder) return;
    cli::OutputFiles files;
    const std::string text = flightJson(s.recorder->flight());
    files.add(s.options.recordInput, [&](const std::string& p) {
        std::ofstream out(p);
        if (!(out << text)) throw std::runtime_error("cannot write '" + p + "'");
    });
    files.commit();
    s.recorder.reset();
}

void FlyApp::captureNextFrame(const std::string& png) { s_->capture = png; }
GLFWwindow* FlyApp::window() const { return s_->context->window(); }
const FlyPose& FlyApp::pose() const { return s_->pose; }
FlyViews& FlyApp::views() { return s_->views; }
const FlyFrameStats& FlyApp::stats() const { return s_->stats; }
const std::string& FlyApp::sceneError() const { return s_->sceneError; }
double FlyApp::time() const { return s_->t; }
int FlyApp::renderWidth() const { return s_->renderW; }
int FlyApp::renderHeight() const { return s_->renderH; }

}  // namespace nephele::fly
