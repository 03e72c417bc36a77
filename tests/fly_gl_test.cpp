// `nephele fly`: recorded flights match `nephele render --time`, and the window (under Xvfb:
// README command 2 runs the suite with xvfb-run) moves the camera on injected key and mouse
// events, toggles its HUD and debug views without GL errors, resizes and closes cleanly.
#include "fly_app.hpp"
#include "fly_script.hpp"
#include "cli_run.hpp"

#include "nephele/context.hpp"
#include "nephele/gl.hpp"
#include "nephele/image.hpp"
#include "nephele/png.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <tuple>

namespace fs = std::filesystem;
using namespace nephele;
using namespace nephele::fly;

namespace {

bool haveDisplay() {
    const char* d = std::getenv("DISPLAY");
    return d && *d;
}
#define SKIP_WITHOUT_DISPLAY() \
    if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY: the window tests run under xvfb-run (README command 2)"

const std::string kScene = std::string(NEPHELE_TEST_DATA) + "/scenes/fly_small.json";

int run(const std::string& args, std::string* output = nullptr) {
    const test::CliResult r = test::runCli(args);
    if (output) *output = r.output;
    return r.code;
}

fs::path freshDir(const std::string& name) {
    const fs::path d = fs::path(NEPHELE_TEST_OUTPUT) / name;
    fs::remove_all(d);
    fs::create_directories(d.parent_path());
    return d;
}

// Records the scene's 2 s path at 1 fps (3 frames, 320x180) and compares `frames` with
// `nephele render --time` of the same moments.
void expectRecordingMatchesRender(const std::string& name, const std::string& extra,
                                  std::initializer_list<int> frames) {
    const fs::path dir = freshDir(name);
    std::string out;
    ASSERT_EQ(run("fly " + kScene + " --record " + dir.string() + " --fps 1 --no-video " + extra, &out), 0) << out;
    ASSERT_TRUE(fs::exists(dir / "frame_0002.png"));
    EXPECT_FALSE(fs::exists(dir / "frame_0003.png"));
    std::ifstream csv(dir / "frames.csv");
    int rows = 0;
    for (std::string line; std::getline(csv, line);) ++rows;
    EXPECT_EQ(rows, 4);  // header and three frames
    EXPECT_TRUE(fs::exists(dir / "flight.json"));
    for (int k : frames) {
        const std::string ref = (dir.string() + "_render_" + std::to_string(k) + ".png");
        ASSERT_EQ(run("render " + kScene + " --time " + std::to_string(k) + " -o " + ref, &out), 0) << out;
        char frame[32];
        std::snprintf(frame, sizeof frame, "frame_%04d.png", k);
        // The recording draws with the renderers and settings of `render`, into the same float
        // frame, encoded the same way, but as a flight: auto keeps tiles and far clouds'
        // impostors across frames (reuse, cloud LOD) until their error reaches 0.5 and 1.5 px,
        // where `render` draws them fresh. At a soft cloud edge that is a few 8-bit steps in a
        // few pixels (measured 7 steps at most, the mean within 0.1 step; identical before the
        // cloud LOD). Ten steps per pixel and 0.1 step on average allow that and the light
        // cache's rounding; a wrong camera, time or method changes hundreds of pixels by tens
        // of steps.
        const ImageDifference d = compareImages(readPng((dir / frame).string()), readPng(ref), 1.5 / 255);
        EXPECT_LE(d.maxAbs, 10.0 / 255 + 1e-6) << frame;
        EXPECT_LE(d.meanAbs, 0.1 / 255) << frame;
    }
}

// Calls the callbacks the window installed, as GLFW does for real events.
struct Inject {
    GLFWwindow* w;
    GLFWkeyfun key;
    GLFWmousebuttonfun button;
    GLFWcursorposfun cursor;
    explicit Inject(GLFWwindow* window)
        : w(window),
          key(glfwSetKeyCallback(window, nullptr)),
          button(glfwSetMouseButtonCallback(window, nullptr)),
          cursor(glfwSetCursorPosCallback(window, nullptr)) {
        glfwSetKeyCallback(w, key);
        glfwSetMouseButtonCallback(w, button);
        glfwSetCursorPosCallback(w, cursor);
    }
    void press(int k) const { key(w, k, 0, GLFW_PRESS, 0); }
    void release(int k) const { key(w, k, 0, GLFW_RELEASE, 0); }
    void tap(int k) const { press(k), release(k); }
    void drag(double dx, double dy) const {
        cursor(w, 50, 50);
        button(w, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0);
        cursor(w, 50 + dx, 50 + dy);
        button(w, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
    }
};

FlyAppOptions smallWindow(FlyMethod method, const std::string& scene = kScene) {
    FlyAppOptions o;
    o.scene = scene;
    o.method = method;
    o.width = 320, o.height = 180;
    o.cacheDir = std::string(NEPHELE_TEST_OUTPUT) + "/fly-cache";  // the layer's lighting, computed once
    return o;
}

}  // namespace

TEST(FlyGLTest, HeadlessRecordingMatchesRender) { expectRecordingMatchesRender("fly_headless", "--headless", {2}); }

TEST(FlyGLTest, WindowRecordingUnderXvfbMatchesRender) {
    SKIP_WITHOUT_DISPLAY();
    expectRecordingMatchesRender("fly_window", "", {1});
}

TEST(FlyGLTest, InjectedKeysAndMouseMoveTheCameraAsDocumented) {
    SKIP_WITHOUT_DISPLAY();
    FlyAppOptions o = smallWindow(FlyMethod::Ellipsoid);
    o.renderScale = 0.5;
    FlyApp app(o);
    const Inject in(app.window());
    ASSERT_TRUE(app.frame(0));
    FlyPose expected = app.pose();
    in.press(GLFW_KEY_W);  // forward for two steps of 0.5 s
    FlyInput forward;
    forward.forward = true;
    for (int k = 0; k < 2; ++k) {
        ASSERT_TRUE(app.frame(0.5));
        expected = stepFlight(expected, forward, 0.5);
    }
    in.release(GLFW_KEY_W);
    EXPECT_NEAR(glm::length(app.pose().position - expected.position), 0, 1e-9);
    EXPECT_GT(app.pose().position.y - (-1500), 15);  // heading north: moved north
    ASSERT_TRUE(app.frame(0.5));                     // no key: slowing to a hover
    EXPECT_LT(glm::length(app.pose().velocity), glm::length(expected.velocity));
    const double heading = app.pose().heading, pitch = app.pose().pitch;
    in.drag(100, 0);  // mouse-look: right
    ASSERT_TRUE(app.frame(0.1));
    EXPECT_NEAR(app.pose().heading, heading + 100 * FlyTuning().mouseDegPerPx, 1e-9);
    in.press(GLFW_KEY_UP);
    ASSERT_TRUE(app.frame(0.5));
    in.release(GLFW_KEY_UP);
    EXPECT_NEAR(app.pose().pitch, pitch + 0.5 * FlyTuning().pitchRate, 1e-9);
    in.tap(GLFW_KEY_R);  // back to the scene's camera
    ASSERT_TRUE(app.frame(0));
    EXPECT_NEAR(app.pose().position.y, -1500, 1e-9);
}

TEST(FlyGLTest, AScriptPlaysInTheWindowInALoopUntilR) {
    SKIP_WITHOUT_DISPLAY();
    const fs::path script = freshDir("fly_window_script.json");
    std::ofstream(script) << R"({"flight": 1, "fps": 10, "keyframes": [
        {"t": 0, "position": [100, -1500, 600], "look_at": [100, 0, 600]},
        {"t": 2, "position": [300, -1200, 700], "look_at": [300, 0, 700]}]})";
    FlyAppOptions o = smallWindow(FlyMethod::Ellipsoid);
    o.renderScale = 0.5;
    o.script = script.string();
    FlyApp app(o);
    const Flight flight = loadFlight(o.script);
    const std::vector<Camera> cameras = flightCameras(flight, loadScene(kScene));
    ASSERT_EQ(cameras.size(), 21u);
    const Inject in(app.window());
    auto expectAt = [&](int frame) {
        EXPECT_NEAR(glm::length(app.pose().position - cameras[frame].position), 0, 1e-9) << frame;
    };
    ASSERT_TRUE(app.frame(0));
    expectAt(0);
    ASSERT_TRUE(app.frame(1.05));  // t = 1.05 s: the step of frame 10
    expectAt(10);
    in.press(GLFW_KEY_W);  // the flight keys do not move a scripted camera
    ASSERT_TRUE(app.frame(0.5));
    in.release(GLFW_KEY_W);
    expectAt(15);
    ASSERT_TRUE(app.frame(0.6));  // t = 2.15 s, past the last frame's step: from the start again
    expectAt(0);
    in.tap(GLFW_KEY_R);  // back to the scene's camera, flown by hand
    ASSERT_TRUE(app.frame(0.5));
    EXPECT_NEAR(app.pose().position.y, -1500, 1e-9);
    EXPECT_NEAR(app.pose().position.x, 0, 1e-9);
}

// Where a view's pixels fall on the window: the box around the pixels it changed (more than 0.1
// in a channel), in window pixels, and how many it changed.
struct Footprint {
    int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1, pixels = 0;
};
Footprint footprint(const Image& with, const Image& without) {
    Footprint f;
    for (int y = 0; y < with.height; ++y)
        for (int x = 0; x < with.width; ++x) {
            double d = 0;
            for (int c = 0; c < 3; ++c) d = std::max(d, double(std::abs(with.at(x, y, c) - without.at(x, y, c))));
            if (d <= 0.1) continue;
            f.x0 = std::min(f.x0, x), f.y0 = std::min(f.y0, y), f.x1 = std::max(f.x1, x), f.y1 = std::max(f.y1, y),
            ++f.pixels;
        }
    return f;
}

// Each view draws over the frame where it says it does and goes away again: the HUD's panel at
// the top left corner, the help centred, the live controls at the top right corner, the atlas
// at the bottom left corner (each 8 px in from its corner); the tile rectangles and the cells
// over the scene. Then each method draws its own frame, every view on, without a GL error.
TEST(FlyGLTest, HudAndDebugViewsToggleWithoutGlErrors) {
    SKIP_WITHOUT_DISPLAY();
    FlyAppOptions o = smallWindow(FlyMethod::Auto);
    o.renderScale = 0.5;  // the views are drawn on the 320x180 window, the frames at 160x90
    FlyApp app(o);
    const Inject in(app.window());
    app.views().hud = false;
    const fs::path out = fs::path(NEPHELE_TEST_OUTPUT);
    fs::create_directories(out);
    auto capture = [&](const std::string& name) {
        const std::string png = (out / ("fly_view_" + name + ".png")).string();
        app.captureNextFrame(png);
        EXPECT_NO_THROW(app.frame(0)) << name;
        return readPng(png);
    };
    ASSERT_NO_THROW(app.frame(0));
    const Image none = capture("none");
    const int w = none.width, h = none.height;
    enum class Anchor { TopLeft, Centre, TopRight, BottomLeft, Scene };
    const std::tuple<int, const char*, Anchor> views[] = {
        {GLFW_KEY_F1, "hud", Anchor::TopLeft},        {GLFW_KEY_H, "help", Anchor::Centre},
        {GLFW_KEY_TAB, "controls", Anchor::TopRight}, {GLFW_KEY_F2, "atlas", Anchor::BottomLeft},
        {GLFW_KEY_F3, "tiles", Anchor::Scene},        {GLFW_KEY_F4, "cells", Anchor::Scene}};
    for (auto [key, name, anchor] : views) {
        in.tap(key);                            // on: each view draws something over the frame, without a GL error
        ASSERT_NO_THROW(app.frame(0)) << name;  // ImGui sizes a new window in its first frame, shows it in the next
        const Image on = capture(name);
        const ImageDifference d = compareImages(on, none, 0.1);
        EXPECT_GT(d.fractionOver, 0.002) << name << ": nothing drawn";
        const Footprint f = footprint(on, none);
        std::printf("view %-8s: %5.2f%% of the %dx%d window, in x %d..%d, y %d..%d\n", name, 100 * d.fractionOver, w, h,
                    f.x0, f.x1, f.y0, f.y1);
        // A panel's corner sits 8 px in from the window's; its border and shadow may reach a
        // few pixels further.
        auto near = [](int v, int want) { return std::abs(v - want) <= 4; };
        switch (anchor) {
            case Anchor::TopLeft: EXPECT_TRUE(near(f.x0, 8) && near(f.y0, 8)) << name; break;
            case Anchor::TopRight: EXPECT_TRUE(near(f.x1, w - 9) && near(f.y0, 8)) << name; break;
            case Anchor::BottomLeft: EXPECT_TRUE(near(f.x0, 8) && near(f.y1, h - 9)) << name; break;
            case Anchor::Centre: EXPECT_TRUE(near(f.x0 + f.x1, w - 1) && near(f.y0 + f.y1, h - 1)) << name; break;
            case Anchor::Scene: break;
        }
        in.tap(key);  // and off again: the frame is the one without it
        ASSERT_NO_THROW(app.frame(0)) << name;
        EXPECT_EQ(compareImages(capture(std::string(name) + "_off"), none, 0.1).fractionOver, 0.0) << name;
    }
    const FlyViews& v = app.views();
    EXPECT_FALSE(v.hud || v.help || v.controls || v.atlas || v.tiles || v.cells);
    // Every method and both composite orders, with every view on but the HUD (its timings change
    // every frame): each method's frame is its own, not the last method's.
    for (int key : {GLFW_KEY_F2, GLFW_KEY_F3, GLFW_KEY_F4}) in.tap(key);
    in.tap(GLFW_KEY_O);  // back to front
    ASSERT_NO_THROW(app.frame(0));
    Image last = capture("method_start");
    // Measured: 69.2%, 53.9%, 0.49% (raymarch to layered: the cumulus alone), 67.8% of the window
    // changed; M not changing the method (tests/sabotage/18-fly-method-key-stuck.sabotage): 0.
    // The bounds are 0.8x each.
    const double least[4] = {0.55, 0.43, 0.004, 0.54};
    for (int m = 0; m < 4; ++m) {  // from auto: ellipsoid, raymarch, layered, auto
        in.tap(GLFW_KEY_M);
        ASSERT_NO_THROW(app.frame(0)) << m;
        const Image frame = capture("method_" + std::to_string(m));
        const double changed = compareImages(frame, last, 0.1).fractionOver;
        std::printf("method %d: %.2f%% of the window changed from the method before\n", m, 100 * changed);
        EXPECT_GT(changed, least[m]) << "method " << m << " drew the frame of the method before";
        last = frame;
    }
}

TEST(FlyGLTest, ResizesAndClosesCleanly) {
    SKIP_WITHOUT_DISPLAY();
    const fs::path inputs = freshDir("fly_inputs.json");
    FlyAppOptions o = smallWindow(FlyMethod::Ellipsoid);
    o.recordInput = inputs.string();
    {
        FlyApp app(o);
        const Inject in(app.window());
        ASSERT_TRUE(app.frame(0));
        EXPECT_EQ(app.renderWidth(), 320);
        glfwSetWindowSize(app.window(), 200, 150);
        int w = 0, h = 0;
        for (int k = 0; k < 100 && (w != 200 || h != 150); ++k) {
            glfwWaitEventsTimeout(0.02);
            glfwGetFramebufferSize(app.window(), &w, &h);
        }
        ASSERT_EQ(w, 200);
        ASSERT_TRUE(app.frame(0.1));
        EXPECT_EQ(app.renderWidth(), 200);
        EXPECT_EQ(app.renderHeight(), 150);
        in.press(GLFW_KEY_D);
        ASSERT_TRUE(app.frame(0.1));
        in.tap(GLFW_KEY_ESCAPE);  // closes
        EXPECT_FALSE(app.frame(0.1));
        app.finish();
    }
    // The window is gone and GL still works: a headless context renders after it.
    auto ctx = Context::create({GlBackend::Egl});
    EXPECT_NO_THROW(gl::checkAlways("after the window closed"));
    std::ifstream f(inputs);
    std::stringstream text;
    text << f.rdbuf();
    EXPECT_NE(text.str().find("\"right\""), std::string::npos) << text.str();
    // The recorded inputs replay as a script.
    const fs::path replay = freshDir("fly_replay");
    std::string out;
    EXPECT_EQ(run("fly " + kScene + " --script " + inputs.string() + " --record " + replay.string() +
                      " --headless --method ellipsoid --width 64 --no-video",
                  &out),
              0)
        << out;
    EXPECT_TRUE(fs::exists(replay / "frame_0000.png"));
}

// The frames themselves, not only the error text: after a bad edit the window draws what it
// drew before (the last good scene), and after the fix it draws the fixed scene. Frames are
// taken with dt = 0 (the same scene time) and the overlay off (the HUD shows the error).
TEST(FlyGLTest, ABadEditOfTheSceneKeepsTheLastGoodOne) {
    SKIP_WITHOUT_DISPLAY();
    const fs::path scene = freshDir("fly_reload.json");
    fs::copy_file(kScene, scene);
    std::ifstream good(kScene);
    std::stringstream text;
    text << good.rdbuf();
    FlyApp app(smallWindow(FlyMethod::Ellipsoid, scene.string()));
    app.views() = FlyViews{};
    app.views().hud = false;
    ASSERT_TRUE(app.frame(0));
    auto capture = [&](const std::string& name) {
        const std::string png = (fs::path(NEPHELE_TEST_OUTPUT) / ("fly_reload_" + name + ".png")).string();
        app.captureNextFrame(png);
        EXPECT_TRUE(app.frame(0));
        return readPng(png);
    };
    auto rewrite = [&](const std::string& from, const std::string& to) {
        std::string s = text.str();
        s.replace(s.find(from), from.size(), to);
        std::this_thread::sleep_for(std::chrono::milliseconds(600));  // reloads are checked twice a second
        std::ofstream(scene) << s;
    };
    const Image before = capture("before");
    rewrite("\"coverage\": 0.3", "\"coverage\": 1.5");
    const Image kept = capture("bad");  // still draws the last good scene
    EXPECT_NE(app.sceneError().find("layers[0].coverage"), std::string::npos) << app.sceneError();
    rewrite("\"max_radius\": 110", "\"max_radius\": 220");  // a good edit the ellipsoid view shows: larger puffs
    const Image fixed = capture("fixed");
    EXPECT_EQ(app.sceneError(), "");
    const ImageDifference same = compareImages(kept, before, 1.5 / 255),
                          changed = compareImages(fixed, before, 2.0 / 255);
    std::printf(
        "[ figure ] reload: bad edit vs before: %.4f of the pixels differ (max %.1f/255); fixed edit vs before: "
        "%.3f differ (mean %.2f/255)\n",
        same.fractionOver, same.maxAbs * 255, changed.fractionOver, changed.meanAbs * 255);
    // Measured 0 pixels differing: the same scene at the same time draws the same frame.
    // Broken (the last good scene's clouds dropped on a bad edit, tests/sabotage/06-fly-bad
    // -edit-drops-the-scene.sabotage): 1.15% of the pixels differ (up to 45/255). 0.1% leaves
    // room for a driver's rounding.
    EXPECT_LE(same.fractionOver, 0.001);
    // Measured 0.026 of the pixels: puffs of twice the radius make a larger cloud. Broken (the
    // reloaded scene not applied, tests/sabotage/07-fly-reload-not-applied.sabotage): 0.
    EXPECT_GT(changed.fractionOver, 0.02);
}
