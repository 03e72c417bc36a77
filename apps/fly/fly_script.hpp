// `nephele fly --script FLIGHT.json`: a flight played at a fixed time step, as keyframes (the
// scene `path`'s form) or as recorded inputs (what `--record-input` writes). Format:
//   { "flight": 1, "fps": 10,
//     "keyframes": [ { "t": 0, "position": [x, y, z], "look_at": [x, y, z] }, ... ] }
//   { "flight": 1, "fps": 30,
//     "start": { "position": [x, y, z], "heading_deg": 0, "pitch_deg": 0 },   (default: the scene camera)
//     "inputs": [ { "t": 0, "hold": ["forward", "fast"], "mouse": [dx, dy] }, ... ],
//     "end": 12.5 }                                                       (default: the last input's t)
// Keys beginning with `_` are comments; any other unknown key is an error.
#pragma once

#include "fly_controls.hpp"

#include "nephele/scene.hpp"

#include <optional>
#include <string>
#include <vector>

namespace nephele::fly {

inline constexpr int kMaxFlightFrames = 100000;

struct InputSample {
    double t = 0;    // s: the held controls from here on, the mouse moved at this moment
    FlyInput input;  // mouseDx, mouseDy: px moved since the previous sample
};

struct Flight {
    double fps = 10;                  // frames (and fixed steps) per second of scene time, (0, 1000]
    std::vector<Keyframe> keyframes;  // either these (at least two) ...
    std::optional<FlyPose> start;     // ... or a start pose (default: the scene camera)
    std::vector<InputSample> inputs;  // and inputs (t non-decreasing)
    double end = 0;                   // inputs: last time (s)
    double firstTime() const;
    double lastTime() const;
    int frameCount() const;  // floor((last - first) fps) + 1
    double frameTime(int k) const { return firstTime() + k / fps; }
};

// Throws SceneError naming the file, the JSON path and the fault (exit code 2).
Flight parseFlight(const std::string& text, const std::string& file);
Flight loadFlight(const std::string& file);
// The scene's `path` as a flight (SceneError if it has fewer than two keyframes).
Flight pathFlight(const Scene& scene, double fps);
// The flight file's JSON (parseFlight reads it back).
std::string flightJson(const Flight& flight);

// The camera of every frame (the scene camera's fov, clip planes and size): keyframes
// interpolated as the scene path is; inputs integrated with stepFlight at the fixed step,
// the controls held at a frame being those of the last sample at or before it and the
// mouse the sum of the samples within its step.
std::vector<Camera> flightCameras(const Flight& flight, const Scene& scene, const FlyTuning& tuning = {});

// Records an interactive flight's inputs (`--record-input`): a sample when the held
// controls change or the mouse moved.
class InputRecorder {
public:
    explicit InputRecorder(const FlyPose& start, double fps = 30);
    void add(double t, const FlyInput& input);
    const Flight& flight() const { return flight_; }

private:
    Flight flight_;
    FlyInput held_;
};

}  // namespace nephele::fly
