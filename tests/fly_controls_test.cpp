// `nephele fly` without a window: the helicopter controls (a pure function of the input and
// the time step) and flight files (keyframes or recorded inputs).
#include "fly_controls.hpp"
#include "fly_script.hpp"
#include "cli_run.hpp"
#include "temp_dir.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

using namespace nephele;
using namespace nephele::fly;

namespace {

FlyInput holding(std::initializer_list<const char*> names) {
    FlyInput in;
    for (const char* n : names) EXPECT_TRUE(setHeld(in, n, true)) << n;
    return in;
}

FlyPose flyFor(FlyPose p, const FlyInput& in, double seconds, double dt) {
    for (int k = 0; k < int(std::lround(seconds / dt)); ++k) p = stepFlight(p, in, dt);
    return p;
}

}  // namespace

TEST(FlyControlsTest, ForwardMovesAlongTheHeadingHorizontallyAtCruiseSpeed) {
    const FlyTuning t;
    FlyPose p;
    p.heading = 90;  // east
    p.pitch = 30;    // pitch does not tilt a helicopter's translation
    const FlyPose q = flyFor(p, holding({"forward"}), 10, 0.05);
    EXPECT_NEAR(q.velocity.x, t.speed, 1e-3);  // 20 time constants: at cruise speed
    EXPECT_NEAR(q.velocity.y, 0, 1e-9);
    EXPECT_NEAR(q.position.z, 0, 1e-9);
    // x(T) = v (T - tau (1 - e^(-T/tau))) from rest.
    EXPECT_NEAR(q.position.x, t.speed * (10 - t.response * (1 - std::exp(-10 / t.response))), 1e-6);
}

TEST(FlyControlsTest, TheStepDoesNotChangeThePathOfAConstantInput) {
    const FlyInput in = holding({"forward", "left", "up", "fast"});
    FlyPose p;
    p.heading = 30;
    const FlyPose coarse = flyFor(p, in, 4, 0.5), fine = flyFor(p, in, 4, 1.0 / 60);
    EXPECT_NEAR(glm::length(coarse.position - fine.position), 0, 1e-6);
    EXPECT_NEAR(glm::length(coarse.velocity - fine.velocity), 0, 1e-9);
}

TEST(FlyControlsTest, SidewaysClimbAndFastAreWhereTheKeysSay) {
    const FlyTuning t;
    FlyPose p;  // heading north: right is east
    const FlyPose right = flyFor(p, holding({"right"}), 10, 0.1);
    EXPECT_GT(right.position.x, 300);
    EXPECT_NEAR(right.position.y, 0, 1e-6);
    const FlyPose climb = flyFor(p, holding({"up"}), 10, 0.1), fastClimb = flyFor(p, holding({"up", "fast"}), 10, 0.1);
    EXPECT_NEAR(climb.velocity.z, t.climbRate, 1e-3);
    EXPECT_NEAR(fastClimb.position.z / climb.position.z, t.fastFactor, 1e-9);
    const FlyPose down = flyFor(p, holding({"down"}), 10, 0.1);
    EXPECT_NEAR(down.position.z, -climb.position.z, 1e-9);
}

TEST(FlyControlsTest, NoKeyHovers) {
    FlyPose p = flyFor(FlyPose{}, holding({"forward", "fast"}), 5, 0.1);
    ASSERT_GT(glm::length(p.velocity), 100);
    p = flyFor(p, FlyInput{}, 5, 0.1);  // 10 time constants
    EXPECT_LT(glm::length(p.velocity), 200 * std::exp(-10.0) * 1.01);
    const FlyPose still = flyFor(p, FlyInput{}, 5, 0.1);
    EXPECT_LT(glm::length(still.position - p.position), 0.01);
}

TEST(FlyControlsTest, ArrowsAndMouseTurn) {
    const FlyTuning t;
    FlyPose p;
    EXPECT_NEAR(flyFor(p, holding({"yaw_right"}), 2, 0.1).heading, 2 * t.yawRate, 1e-9);
    EXPECT_NEAR(flyFor(p, holding({"yaw_left"}), 2, 0.1).heading, 360 - 2 * t.yawRate, 1e-9);  // wraps to [0, 360)
    EXPECT_NEAR(flyFor(p, holding({"pitch_up"}), 1, 0.1).pitch, t.pitchRate, 1e-9);
    EXPECT_NEAR(flyFor(p, holding({"pitch_up"}), 10, 0.1).pitch, t.maxPitch, 1e-9);  // limited
    FlyInput mouse;
    mouse.mouseDx = 100, mouse.mouseDy = -40;  // right and up
    const FlyPose m = stepFlight(p, mouse, 0.1);
    EXPECT_NEAR(m.heading, 100 * t.mouseDegPerPx, 1e-9);
    EXPECT_NEAR(m.pitch, 40 * t.mouseDegPerPx, 1e-9);
}

TEST(FlyControlsTest, KeysDriveTheDocumentedControls) {
    FlyInput in;
    const std::pair<int, bool FlyInput::*> keys[] = {{GLFW_KEY_W, &FlyInput::forward},
                                                     {GLFW_KEY_S, &FlyInput::back},
                                                     {GLFW_KEY_A, &FlyInput::left},
                                                     {GLFW_KEY_D, &FlyInput::right},
                                                     {GLFW_KEY_E, &FlyInput::up},
                                                     {GLFW_KEY_Q, &FlyInput::down},
                                                     {GLFW_KEY_LEFT, &FlyInput::yawLeft},
                                                     {GLFW_KEY_RIGHT, &FlyInput::yawRight},
                                                     {GLFW_KEY_UP, &FlyInput::pitchUp},
                                                     {GLFW_KEY_DOWN, &FlyInput::pitchDown},
                                                     {GLFW_KEY_LEFT_SHIFT, &FlyInput::fast},
                                                     {GLFW_KEY_RIGHT_SHIFT, &FlyInput::fast}};
    for (auto [key, held] : keys) {
        EXPECT_TRUE(applyKey(in, key, true));
        EXPECT_TRUE(in.*held) << key;
        EXPECT_TRUE(applyKey(in, key, false));
        EXPECT_FALSE(in.*held) << key;
    }
    EXPECT_FALSE(applyKey(in, GLFW_KEY_H, true));  // a command, not a control
    EXPECT_EQ(in, FlyInput{});
}

TEST(FlyControlsTest, PoseAndCameraRoundTrip) {
    Camera c;
    c.position = Vec3(10, 20, 30);
    c.direction = glm::normalize(Vec3(1, 1, -0.5));
    const FlyPose p = poseFromCamera(c);
    EXPECT_NEAR(p.heading, 45, 1e-9);
    const Camera back = cameraFromPose(p, c);
    EXPECT_NEAR(glm::length(back.direction - c.direction), 0, 1e-12);
    EXPECT_EQ(back.position, c.position);
}

TEST(FlyScriptTest, KeyframesPlayAsTheScenePath) {
    const Flight f = parseFlight(R"({"flight": 1, "fps": 4, "keyframes": [
        {"t": 1, "position": [0, 0, 100], "look_at": [0, 100, 100]},
        {"t": 2, "position": [0, 40, 100], "look_at": [0, 140, 100]}]})",
                                 "f.json");
    EXPECT_EQ(f.frameCount(), 5);
    Scene scene;
    const std::vector<Camera> cams = flightCameras(f, scene);
    ASSERT_EQ(cams.size(), 5u);
    EXPECT_NEAR(cams[2].position.y, 20, 1e-9);  // t = 1.5
    EXPECT_NEAR(cams[4].position.y, 40, 1e-9);
}

TEST(FlyScriptTest, InputsReplayAtTheFixedStep) {
    const Flight f = parseFlight(R"({"flight": 1, "fps": 10, "start": {"position": [0, 0, 500], "heading_deg": 90},
        "inputs": [{"t": 0, "hold": ["forward"]}, {"t": 1, "hold": []}, {"t": 1.5, "mouse": [100, 0]}], "end": 2})",
                                 "f.json");
    Scene scene;
    const std::vector<Camera> cams = flightCameras(f, scene);
    ASSERT_EQ(cams.size(), 21u);
    // The same steps by hand: forward for ten steps, then none, the mouse in the step from 1.5 s.
    FlyPose p = *f.start;
    for (int k = 1; k <= 20; ++k) {
        FlyInput in;
        in.forward = k <= 10;
        if (k == 16) in.mouseDx = 100;
        p = stepFlight(p, in, 0.1);
        EXPECT_NEAR(glm::length(cams[k].position - p.position), 0, 1e-9) << k;
    }
    EXPECT_GT(cams[20].position.x, 20);  // east
    EXPECT_NEAR(poseFromCamera(cams[20]).heading, 90 + 100 * FlyTuning().mouseDegPerPx, 1e-6);
}

TEST(FlyScriptTest, RecordedInputsReadBack) {
    InputRecorder rec(FlyPose{Vec3(1, 2, 3), 10, 5, Vec3(0.0)}, 30);
    FlyInput in;
    rec.add(0, in);
    in.forward = true;
    rec.add(0.1, in);
    rec.add(0.2, in);  // unchanged: no sample
    in.mouseDx = 3;
    rec.add(0.3, in);
    const Flight f = parseFlight(flightJson(rec.flight()), "rec.json");
    ASSERT_EQ(f.inputs.size(), 3u);
    EXPECT_TRUE(f.inputs[1].input.forward);
    EXPECT_EQ(f.inputs[2].input.mouseDx, 3);
    EXPECT_DOUBLE_EQ(f.end, 0.3);
    ASSERT_TRUE(f.start);
    EXPECT_EQ(f.start->position, Vec3(1, 2, 3));
}

TEST(FlyScriptTest, BadFlightsNameTheJsonPath) {
    const std::pair<const char*, const char*> cases[] = {
        {"{", "f.json: syntax error at line 1, column 2: unexpected end of input"},
        {R"({"fps": 10, "keyframes": []})", "f.json: expected \"flight\": 1"},
        {R"({"flight": 1})", "expected either \"keyframes\" or \"inputs\""},
        {R"({"flight": 1, "fps": 0, "inputs": [{"t": 0}]})", "f.json: fps: must be in (0, 1000]"},
        {R"({"flight": 1, "keyframes": [{"t": 0, "position": [0,0,0], "look_at": [0,1,0]}]})",
         "keyframes: expected at least 2"},
        {R"({"flight": 1, "keyframes": [{"t": 0, "position": [0,0,0], "look_at": [0,1,0]}, )"
         R"({"t": 0, "position": [0,0,0], "look_at": [0,1,0]}]})",
         "keyframes[1].t: must be greater than the previous t"},
        {R"({"flight": 1, "keyframes": [{"t": 0, "position": [0,0], "look_at": [0,1,0]}, )"
         R"({"t": 1, "position": [0,0,0], "look_at": [0,1,0]}]})",
         "keyframes[0].position: expected [x, y, z]"},
        {R"({"flight": 1, "inputs": [{"t": 0, "hold": ["sideways"]}]})", "inputs[0].hold[0]: expected a control"},
        {R"({"flight": 1, "inputs": [{"t": 1}, {"t": 0}]})", "inputs[1].t: must not be less than the previous t"},
        {R"({"flight": 1, "inputs": [{"t": 0, "speed": 3}]})", "inputs[0].speed: unknown key"},
        {R"({"flight": 1, "inputs": [{"t": 0}], "end": 1e9})", "more than 100000 frames"},
    };
    for (auto [text, message] : cases) {
        try {
            parseFlight(text, "f.json");
            ADD_FAILURE() << "accepted: " << text;
        } catch (const SceneError& e) {
            EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what() << "\nexpected: " << message;
        }
    }
}

TEST(FlyScriptTest, APathlessSceneCannotBeFollowed) {
    Scene scene;
    scene.file = "s.json";
    EXPECT_THROW(pathFlight(scene, 10), SceneError);
}

// The command line rejects bad flights and options with exit code 2 before it makes a
// context (so these need no GL), and leaves no record folder behind.
namespace {
test::CliResult runNephele(const std::string& args) { return test::runCli(args); }
}  // namespace

TEST(FlyCliTest, BadInputExitsTwoAndWritesNothing) {
    const std::filesystem::path dir = test::freshProcessDir("nephele_fly_cli_");
    std::filesystem::create_directories(dir / "full");
    std::ofstream(dir / "full" / "x") << "x";
    std::ofstream(dir / "bad.json") << R"({"flight": 1, "keyframes": [{"t": 0, "position": [0,0,0], "look_at": [0,1,0]},
        {"t": 0, "position": [0,0,0], "look_at": [0,1,0]}]})";
    const std::string scene = std::string(NEPHELE_SCENES) + "/example.json";  // no path
    const std::string rec = (dir / "rec").string();
    const std::pair<std::string, std::string> cases[] = {
        {"fly " + scene + " --script " + (dir / "bad.json").string() + " --record " + rec,
         "bad.json: keyframes[1].t: must be greater"},
        {"fly " + scene + " --record " + rec, "example.json: path: "},
        {"fly " + scene + " --record " + (dir / "full").string(), "exists and is not an empty folder"},
        {"fly " + scene + " --script " + (dir / "bad.json").string(),
         "bad.json: keyframes[1].t: must be greater"},  // the window's
        {"fly " + scene + " --headless", "--headless needs --record"},
        {"fly " + scene + " --script " + (dir / "bad.json").string() + " --record-input " + (dir / "in.json").string(),
         "does not go with --script"},
        {"fly " + scene + " --method volume --record " + rec, "--method: unknown method 'volume'"},
        {"fly " + (dir / "missing.json").string() + " --record " + rec, "missing.json"},
        {"fly " + scene + " --record " + (dir / "no" / "such" / "rec").string(), "does not exist"},
        {"fly " + scene + " --width 0", "--width"},
        {"fly " + scene + " --record " + rec + " --record-input " + (dir / "in.json").string(),
         "does not go with --record"},
    };
    for (const auto& [args, message] : cases) {
        const test::CliResult r = runNephele(args);
        EXPECT_EQ(r.code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(message), std::string::npos) << args << "\n" << r.output;
    }
    EXPECT_FALSE(std::filesystem::exists(rec));
    std::filesystem::remove_all(dir);
}
