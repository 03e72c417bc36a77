// A scene with every section and every numeric field of data/scene-format.md set, and what
// the hostile-input tests make of it: the library's reader (hostile_input_test.cpp) and the
// command line's (hostile_cli_test.cpp) are given the same scenes.
#pragma once

#include "nephele/scene.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <utility>
#include <vector>

namespace nephele::test {

using json = nlohmann::json;

// A scene with every section and every numeric field of data/scene-format.md set (layers,
// skylight, lightning, objects, path; the three generate types), small enough to render.
inline json fullScene() {
    return json::parse(R"({
      "cloudscene": 1,
      "camera": {"position": [10, -3000, 1150], "look_at": [0, 0, 1200], "up": [0, 0, 1], "fov_y_deg": 60,
                 "near": 0.5, "far": 100000, "width": 32, "height": 24},
      "sun": {"direction": [0.3, 0.2, 0.93], "color": [1, 1, 1], "intensity": 3},
      "sky": {"zenith": [0.1, 0.22, 0.55], "horizon": [0.4, 0.5, 0.65], "ground": [0.12, 0.12, 0.1]},
      "medium": {"extinction": 0.04, "albedo": 0.99, "hg_g": 0.85, "noise": 0.3, "noise_scale": 60},
      "clouds": [{"ellipsoids": [{"center": [0, 0, 1200], "radii": [300, 200, 150], "rotation_deg": [0, 0, 30],
                                  "density": 1}]}],
      "generate": [
        {"type": "cumulus", "seed": 3, "density": 1, "center": [800, 0, 1300], "count": 20, "sigma": [100, 100, 50],
         "clamp_lo": [-2, -2, -0.5], "clamp_hi": [2, 2, 2], "max_radius": 80, "aspect": [1, 1, 0.7]},
        {"type": "lsystem", "density": 1, "center": [-800, 0, 1300], "axiom": "F", "rules": {"F": "F[+F]F"},
         "angle_deg": 25, "iterations": 2, "step": 50, "radius": 30, "jitter": 0.2},
        {"type": "mesh", "density": 1, "path": ")" NEPHELE_TEST_DATA R"(/scenes/tetra.obj", "position": [0, 500, 1200],
         "scale": 50, "rotation_deg": [0, 0, 10], "thickness_ratio": 0.5}],
      "layers": [{"base": 2000, "thickness": 500, "coverage": 0.6, "density": 1, "wind": [5, 1], "extent": 20000,
                  "seed": 1, "city_glow": {"color": [1, 0.5, 0.2], "strength": 0.1}}],
      "skylight": {"direction": [-0.3, 0, 0.5], "color": [0.5, 0.6, 1], "intensity": 1},
      "lightning": [{"position": [0, 0, 1200], "intensity": 1000, "start": 0, "duration": 0.2}],
      "objects": [{"type": "box", "center": [0, 0, 100], "size": [50, 50, 50], "rotation_deg": [0, 0, 15],
                   "color": [0.5, 0.5, 0.5]},
                  {"type": "sphere", "center": [100, 0, 100], "radius": 20, "color": [0.3, 0.3, 0.3]}],
      "path": [{"t": 0, "position": [10, -3000, 1150], "look_at": [0, 0, 1200]},
               {"t": 10, "position": [10, -2500, 1150], "look_at": [0, 0, 1200]}]
    })");
}

// Every number of `j`: its JSON pointer and its path as scene messages write it
// ("clouds[0].ellipsoids[0].radii[1]").
inline void numbersOf(const json& j, const json::json_pointer& at, const std::string& path,
                      std::vector<std::pair<json::json_pointer, std::string>>& out) {
    if (j.is_number()) out.push_back({at, path});
    if (j.is_object())
        for (const auto& [k, v] : j.items()) numbersOf(v, at / k, path.empty() ? k : path + "." + k, out);
    if (j.is_array())
        for (std::size_t i = 0; i < j.size(); ++i) numbersOf(j[i], at / i, path + "[" + std::to_string(i) + "]", out);
}

// The scene with every field that accepts a number below float range set to one at once.
inline json everyTinyAccepted(const json& base, const std::string& file) {
    std::vector<std::pair<json::json_pointer, std::string>> fields;
    numbersOf(base, json::json_pointer(), "", fields);
    json all = base;
    for (const auto& [at, path] : fields) {
        json j = all;
        j[at] = 1e-39;
        try {
            parseScene(j.dump(), file);
            all = j;
        } catch (const SceneError&) {}
    }
    return all;
}

}  // namespace nephele::test
