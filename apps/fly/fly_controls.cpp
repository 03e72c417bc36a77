#include "fly_controls.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace nephele::fly {

namespace {
constexpr double kDeg = std::numbers::pi / 180;

struct Control {
    const char* name;
    bool FlyInput::*held;
    int key, altKey;
};
constexpr Control kControls[] = {
    {"forward", &FlyInput::forward, GLFW_KEY_W, -1},
    {"back", &FlyInput::back, GLFW_KEY_S, -1},
    {"left", &FlyInput::left, GLFW_KEY_A, -1},
    {"right", &FlyInput::right, GLFW_KEY_D, -1},
    {"up", &FlyInput::up, GLFW_KEY_E, -1},
    {"down", &FlyInput::down, GLFW_KEY_Q, -1},
    {"yaw_left", &FlyInput::yawLeft, GLFW_KEY_LEFT, -1},
    {"yaw_right", &FlyInput::yawRight, GLFW_KEY_RIGHT, -1},
    {"pitch_up", &FlyInput::pitchUp, GLFW_KEY_UP, -1},
    {"pitch_down", &FlyInput::pitchDown, GLFW_KEY_DOWN, -1},
    {"fast", &FlyInput::fast, GLFW_KEY_LEFT_SHIFT, GLFW_KEY_RIGHT_SHIFT},
};

double axis(bool plus, bool minus) { return (plus ? 1.0 : 0.0) - (minus ? 1.0 : 0.0); }
}  // namespace

std::vector<std::string> heldNames(const FlyInput& input) {
    std::vector<std::string> out;
    for (const Control& c : kControls)
        if (input.*c.held) out.push_back(c.name);
    return out;
}

bool setHeld(FlyInput& input, const std::string& name, bool down) {
    for (const Control& c : kControls)
        if (name == c.name) return input.*c.held = down, true;
    return false;
}

bool applyKey(FlyInput& input, int glfwKey, bool down) {
    for (const Control& c : kControls)
        if (glfwKey == c.key || glfwKey == c.altKey) return input.*c.held = down, true;
    return false;
}

Vec3 headingDirection(double heading, double pitch) {
    const double h = heading * kDeg, p = pitch * kDeg;
    return {std::sin(h) * std::cos(p), std::cos(h) * std::cos(p), std::sin(p)};
}

FlyPose stepFlight(const FlyPose& pose, const FlyInput& in, double dt, const FlyTuning& t) {
    FlyPose out = pose;
    if (!(dt > 0)) return out;
    const double boost = in.fast ? t.fastFactor : 1.0;
    out.heading += (axis(in.yawRight, in.yawLeft) * t.yawRate * dt + in.mouseDx * t.mouseDegPerPx);
    out.heading = std::fmod(std::fmod(out.heading, 360.0) + 360.0, 360.0);
    out.pitch += axis(in.pitchUp, in.pitchDown) * t.pitchRate * dt - in.mouseDy * t.mouseDegPerPx;
    out.pitch = std::clamp(out.pitch, -t.maxPitch, t.maxPitch);
    // Commanded velocity: horizontal along and across the (new) heading, vertical climb.
    const Vec3 ahead = headingDirection(out.heading, 0), across(ahead.y, -ahead.x, 0.0);  // across: to the right
    const Vec3 command = boost * (t.speed * (axis(in.forward, in.back) * ahead + axis(in.right, in.left) * across) +
                                  Vec3(0, 0, t.climbRate * axis(in.up, in.down)));
    // v(t) = c + (v0 - c) e^(-t/tau): the position integrates it exactly over the step.
    const double tau = std::max(t.response, 1e-6), decay = std::exp(-dt / tau);
    out.velocity = command + (pose.velocity - command) * decay;
    out.position = pose.position + command * dt + (pose.velocity - command) * tau * (1 - decay);
    return out;
}

FlyPose poseFromCamera(const Camera& camera) {
    const Vec3 d = glm::normalize(camera.direction);
    FlyPose p;
    p.position = camera.position;
    p.pitch = std::clamp(std::asin(std::clamp(d.z, -1.0, 1.0)) / kDeg, -89.9, 89.9);  // never along up
    p.heading = std::hypot(d.x, d.y) > 1e-9 ? std::fmod(std::atan2(d.x, d.y) / kDeg + 360.0, 360.0) : 0.0;
    return p;
}

Camera cameraFromPose(const FlyPose& pose, const Camera& base) {
    Camera c = base;
    c.position = pose.position;
    c.direction = headingDirection(pose.heading, pose.pitch);
    c.up = Vec3(0, 0, 1);
    return c;
}

}  // namespace nephele::fly
