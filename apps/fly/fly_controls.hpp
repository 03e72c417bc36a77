// `nephele fly`: helicopter controls as a pure function of the input held and the time
// step, so that they are tested without a window (FlyControlsTest) and a recorded flight
// replays the same way at any step.
//
// Keys (GLFW key codes; the help overlay lists them from kFlyKeys):
//   W / S  forward / back      A / D  sideways left / right     E / Q  climb / descend
//   arrows yaw (left/right) and pitch (up/down)    mouse: drag with the left button to look
//   Shift  fast (x kFastFactor)                    no key: the helicopter hovers (slows to 0)
#pragma once

#include "nephele/scene.hpp"

#include <string>
#include <vector>

namespace nephele::fly {

// What the pilot holds during one step.
struct FlyInput {
    bool forward = false, back = false, left = false, right = false, up = false, down = false;
    bool yawLeft = false, yawRight = false, pitchUp = false, pitchDown = false;
    bool fast = false;
    double mouseDx = 0, mouseDy = 0;  // px the mouse moved with the look button held during the step
    bool operator==(const FlyInput&) const = default;
};

// The input's held controls by name ("forward", ..., "fast"), for flight files.
std::vector<std::string> heldNames(const FlyInput& input);
// Sets the named control; false if the name is not one of heldNames'.
bool setHeld(FlyInput& input, const std::string& name, bool down);
// Sets the control a key drives (GLFW key code); false if the key drives none.
bool applyKey(FlyInput& input, int glfwKey, bool down);

struct FlyTuning {
    double speed = 40;            // m/s, horizontal cruise (about 80 kt)
    double climbRate = 10;        // m/s
    double fastFactor = 5;        // speed and climb rate with Shift
    double yawRate = 45;          // deg/s on the arrows
    double pitchRate = 30;        // deg/s on the arrows
    double mouseDegPerPx = 0.15;  // deg of yaw or pitch per pixel of mouse drag
    double response = 0.5;        // s, time constant of the velocity's approach to the commanded one
    double maxPitch = 85;         // deg, |pitch| limit
};

// Heading in degrees clockwise from north (+y) towards east (+x), in [0, 360); pitch in
// degrees above the horizon. Velocity in m/s, world frame (z up).
struct FlyPose {
    Vec3 position{0.0};
    double heading = 0, pitch = 0;
    Vec3 velocity{0.0};
};

// One step of dt seconds: the commanded velocity is speed along the heading (forward/back),
// across it (left/right) and climbRate up or down, all horizontal or vertical whatever the
// pitch, as a helicopter moves; the velocity approaches it with time constant `response`
// (exactly, so any dt gives the same path for a constant input); heading and pitch turn at
// their rates and by the mouse.
FlyPose stepFlight(const FlyPose& pose, const FlyInput& input, double dt, const FlyTuning& tuning = {});

FlyPose poseFromCamera(const Camera& camera);
// `base` (fov, clip planes, size) looking along the pose's heading and pitch.
Camera cameraFromPose(const FlyPose& pose, const Camera& base);
Vec3 headingDirection(double heading, double pitch);

}  // namespace nephele::fly
