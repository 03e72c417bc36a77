#include "fly_script.hpp"

#include "nephele/scene_text.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace nephele::fly {

namespace {
using json = nlohmann::json;

// A JSON value and its path, for messages that name both the file and the path.
struct At {
    const json& j;
    std::string path;
    const std::string& file;
    [[noreturn]] void fail(const std::string& fault) const { throw SceneError(file, path, fault); }
    At key(const char* k) const { return {j.at(k), path.empty() ? k : path + "." + k, file}; }
    At item(std::size_t i) const { return {j[i], path + "[" + std::to_string(i) + "]", file}; }
    bool has(const char* k) const { return j.contains(k); }
    void onlyKeys(std::initializer_list<const char*> keys) const {
        if (!j.is_object()) fail("expected an object");
        for (const auto& [k, v] : j.items()) {
            bool known = k.starts_with('_');
            for (const char* allowed : keys) known = known || k == allowed;
            if (!known) At{v, path.empty() ? k : path + "." + k, file}.fail("unknown key");
        }
    }
    double number() const {
        if (!j.is_number() || !std::isfinite(j.get<double>())) fail("expected a finite number");
        return j.get<double>();
    }
    const json& array(std::size_t minSize) const {
        if (!j.is_array()) fail("expected an array");
        if (j.size() < minSize)
            fail("expected at least " + std::to_string(minSize) + " element(s), got " + std::to_string(j.size()));
        return j;
    }
    Vec3 vec3() const {
        if (!j.is_array() || j.size() != 3) fail("expected [x, y, z]");
        return {item(0).number(), item(1).number(), item(2).number()};
    }
};

Keyframe readKeyframe(const At& a) {
    a.onlyKeys({"t", "position", "look_at"});
    for (const char* k : {"t", "position", "look_at"})
        if (!a.has(k)) a.fail(std::string("missing key '") + k + "'");
    Keyframe kf{a.key("t").number(), a.key("position").vec3(), a.key("look_at").vec3()};
    // A direction that means something in float: 1e-6 of the coordinates' size, and 1e-6 m
    // (issue 38; as the scene's path keyframes).
    const Vec3 p = glm::abs(kf.position), l = glm::abs(kf.lookAt);
    const double size = std::max({1.0, p.x, p.y, p.z, l.x, l.y, l.z});
    if (!(glm::length(kf.lookAt - kf.position) >= 1e-6 * size))
        a.key("look_at").fail(glm::length(kf.lookAt - kf.position) == 0
                                  ? "equals the position"
                                  : "is too close to the position to give a direction in float (at least 1e-06 of the "
                                    "largest coordinate, and 1e-06 m)");
    return kf;
}

InputSample readInput(const At& a) {
    a.onlyKeys({"t", "hold", "mouse"});
    if (!a.has("t")) a.fail("missing key 't'");
    InputSample s{a.key("t").number(), {}};
    if (a.has("hold")) {
        const At h = a.key("hold");
        h.array(0);
        for (std::size_t i = 0; i < h.j.size(); ++i) {
            const At c = h.item(i);
            if (!c.j.is_string() || !setHeld(s.input, c.j.get<std::string>(), true))
                c.fail(
                    "expected a control: forward, back, left, right, up, down, yaw_left, yaw_right, pitch_up, "
                    "pitch_down or fast");
        }
    }
    if (a.has("mouse")) {
        const At m = a.key("mouse");
        if (!m.j.is_array() || m.j.size() != 2) m.fail("expected [dx, dy] in pixels");
        s.input.mouseDx = m.item(0).number();
        s.input.mouseDy = m.item(1).number();
    }
    return s;
}

void readInputs(const At& root, Flight& f) {
    if (root.has("start")) {
        const At s = root.key("start");
        s.onlyKeys({"position", "heading_deg", "pitch_deg"});
        if (!s.has("position")) s.fail("missing key 'position'");
        FlyPose p;
        p.position = s.key("position").vec3();
        if (s.has("heading_deg")) p.heading = s.key("heading_deg").number();
        if (s.has("pitch_deg")) p.pitch = s.key("pitch_deg").number();
        if (std::abs(p.pitch) >= 90) s.key("pitch_deg").fail("must be in (-90, 90)");
        f.start = p;
    }
    const At in = root.key("inputs");
    in.array(1);
    for (std::size_t i = 0; i < in.j.size(); ++i) {
        f.inputs.push_back(readInput(in.item(i)));
        if (i > 0 && f.inputs[i].t < f.inputs[i - 1].t)
            in.item(i).key("t").fail("must not be less than the previous t");
    }
    f.end = root.has("end") ? root.key("end").number() : f.inputs.back().t;
    if (f.end < f.inputs.front().t) root.key("end").fail("must not be less than the first input's t");
}
}  // namespace

double Flight::firstTime() const {
    return keyframes.empty() ? (inputs.empty() ? 0 : inputs.front().t) : keyframes.front().t;
}
double Flight::lastTime() const { return keyframes.empty() ? end : keyframes.back().t; }
int Flight::frameCount() const { return int(std::floor((lastTime() - firstTime()) * fps + 1e-9)) + 1; }

Flight parseFlight(const std::string& text, const std::string& file) {
    // As a scene file: a NUL byte, a syntax error or a truncated script is named by line and
    // column; duplicate keys, nesting and size are bounded (issue 38).
    checkJsonText(text, file);
    const json j = json::parse(text);
    const At root{j, "", file};
    root.onlyKeys({"flight", "fps", "keyframes", "start", "inputs", "end"});
    if (!root.has("flight") || !j["flight"].is_number_integer() || j["flight"].get<int>() != 1)
        (root.has("flight") ? root.key("flight") : root).fail("expected \"flight\": 1");
    Flight f;
    if (root.has("fps")) {
        f.fps = root.key("fps").number();
        if (!(f.fps > 0 && f.fps <= 1000)) root.key("fps").fail("must be in (0, 1000]");
    }
    if (root.has("keyframes") == root.has("inputs")) root.fail("expected either \"keyframes\" or \"inputs\"");
    if (root.has("keyframes")) {
        if (root.has("start") || root.has("end")) root.fail("\"start\" and \"end\" belong to an \"inputs\" flight");
        const At k = root.key("keyframes");
        k.array(2);
        for (std::size_t i = 0; i < k.j.size(); ++i) {
            f.keyframes.push_back(readKeyframe(k.item(i)));
            if (i > 0 && !(f.keyframes[i].t > f.keyframes[i - 1].t))
                k.item(i).key("t").fail("must be greater than the previous t");
        }
    } else {
        readInputs(root, f);
    }
    if (double(f.lastTime() - f.firstTime()) * f.fps + 1 > kMaxFlightFrames)
        root.fail("the flight makes more than " + std::to_string(kMaxFlightFrames) + " frames at this fps");
    return f;
}

Flight loadFlight(const std::string& file) {
    return parseFlight(readSceneText(file), file);  // a regular file within the scene's size limit
}

Flight pathFlight(const Scene& scene, double fps) {
    if (scene.path.size() < 2)
        throw SceneError(
            scene.file, "path",
            "a recorded flight without --script follows the scene's `path`, which needs at least two keyframes");
    Flight f;
    f.fps = fps;
    f.keyframes = scene.path;
    if ((f.lastTime() - f.firstTime()) * fps + 1 > kMaxFlightFrames)
        throw SceneError(
            scene.file, "path",
            "the path makes more than " + std::to_string(kMaxFlightFrames) + " frames at --fps " + std::to_string(fps));
    return f;
}

std::string flightJson(const Flight& f) {
    json j = {{"flight", 1}, {"fps", f.fps}};
    auto v3 = [](const Vec3& v) { return json::array({v.x, v.y, v.z}); };
    if (!f.keyframes.empty()) {
        for (const Keyframe& k : f.keyframes)
            j["keyframes"].push_back({{"t", k.t}, {"position", v3(k.position)}, {"look_at", v3(k.lookAt)}});
        return j.dump(1) + "\n";
    }
    if (f.start)
        j["start"] = {
            {"position", v3(f.start->position)}, {"heading_deg", f.start->heading}, {"pitch_deg", f.start->pitch}};
    j["inputs"] = json::array();
    for (const InputSample& s : f.inputs) {
        json e = {{"t", s.t}, {"hold", heldNames(s.input)}};
        if (s.input.mouseDx != 0 || s.input.mouseDy != 0) e["mouse"] = {s.input.mouseDx, s.input.mouseDy};
        j["inputs"].push_back(e);
    }
    j["end"] = f.end;
    return j.dump(1) + "\n";
}

std::vector<Camera> flightCameras(const Flight& f, const Scene& scene, const FlyTuning& tuning) {
    std::vector<Camera> out;
    const int n = f.frameCount();
    out.reserve(n);
    if (!f.keyframes.empty()) {
        Scene withPath = scene;
        withPath.path = f.keyframes;
        for (int k = 0; k < n; ++k) out.push_back(cameraAt(withPath, f.frameTime(k)));
        return out;
    }
    FlyPose pose = f.start ? *f.start : poseFromCamera(scene.camera);
    const double eps = 1e-9;
    std::size_t held = 0, moved = 0;  // the next sample to hold, the next whose mouse to apply
    FlyInput controls;
    for (int k = 0; k < n; ++k) {
        const double tk = f.frameTime(k);
        if (k > 0) {  // the step from frame k-1: the controls held then, the mouse moved within it
            const double t0 = f.frameTime(k - 1);
            FlyInput step = controls;
            step.mouseDx = step.mouseDy = 0;
            for (; moved < f.inputs.size() && f.inputs[moved].t < tk - eps; ++moved)
                if (f.inputs[moved].t >= t0 - eps)
                    step.mouseDx += f.inputs[moved].input.mouseDx, step.mouseDy += f.inputs[moved].input.mouseDy;
            pose = stepFlight(pose, step, 1 / f.fps, tuning);
        }
        for (; held < f.inputs.size() && f.inputs[held].t <= tk + eps; ++held) controls = f.inputs[held].input;
        out.push_back(cameraFromPose(pose, scene.camera));
    }
    return out;
}

InputRecorder::InputRecorder(const FlyPose& start, double fps) {
    flight_.fps = fps;
    flight_.start = start;
    flight_.start->velocity = Vec3(0.0);
}

void InputRecorder::add(double t, const FlyInput& input) {
    FlyInput held = input;
    held.mouseDx = held.mouseDy = 0;
    const bool moved = input.mouseDx != 0 || input.mouseDy != 0;
    if (flight_.inputs.empty() || !(held == held_) || moved) flight_.inputs.push_back({t, input});
    held_ = held;
    flight_.end = t;
}

}  // namespace nephele::fly
