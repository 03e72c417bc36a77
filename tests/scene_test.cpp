// The scene loader against data/scene-format.md: shared scenes, defaults, every rule.
#include "nephele/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>

namespace nephele {
namespace {

const std::string kData = NEPHELE_TEST_DATA "/scenes/";

// A valid scene with a minimal camera plus `rest` (more top-level members).
std::string scene(const std::string& rest = "") {
    return R"({"cloudscene": 1, "camera": {"position": [0, 0, 0], "look_at": [0, 1, 0]})" +
           (rest.empty() ? "" : ", " + rest) + "}";
}
// A scene whose camera object has the members `camera`.
std::string withCamera(const std::string& camera) { return R"({"cloudscene": 1, "camera": {)" + camera + "}}"; }
// A scene with one cloud made of the given ellipsoids.
std::string withEllipsoids(const std::string& ellipsoids) {
    return scene(R"("clouds": [{"name": "c", "ellipsoids": [)" + ellipsoids + "]}]");
}
const std::string kEllipsoid = R"({"center": [0, 0, 0], "radii": [1, 2, 3]})";

// Checks that `text` is rejected at exactly `path` with a fault containing `fault`,
// and that what() is "FILE: PATH: FAULT".
::testing::AssertionResult failsAt(const std::string& text, const std::string& path, const std::string& fault = "",
                                   const std::string& file = "test.json") {
    try {
        parseScene(text, file);
    } catch (const SceneError& e) {
        const std::string what = e.what();
        const std::string expected = file + ": " + (path.empty() ? "" : path + ": ") + e.fault();
        if (e.file() != file || e.jsonPath() != path || what != expected || e.fault().find(fault) == std::string::npos)
            return ::testing::AssertionFailure() << "got \"" << what << "\" (path \"" << e.jsonPath() << "\")";
        return ::testing::AssertionSuccess() << what;
    }
    return ::testing::AssertionFailure() << "accepted: " << text;
}

void expectNear(const Vec3& got, const Vec3& want, double tol = 1e-12) {
    EXPECT_NEAR(got.x, want.x, tol);
    EXPECT_NEAR(got.y, want.y, tol);
    EXPECT_NEAR(got.z, want.z, tol);
}

// ---------------------------------------------------------------- files

TEST(SceneLoaderTest, LoadsEverySharedScene) {
    const std::map<std::string, size_t> ellipsoids{
        {"cumulus27.json", 27},  {"dense_cumulus.json", 27}, {"example.json", 3}, {"field1000.json", 1000},
        {"flythrough.json", 30}, {"near_and_far.json", 70},  {"single.json", 1},  {"two_clouds.json", 6}};
    size_t loaded = 0;
    for (const auto& entry : std::filesystem::directory_iterator(NEPHELE_SCENES)) {
        if (entry.path().extension() != ".json") continue;
        SCOPED_TRACE(entry.path().string());
        const Scene s = loadScene(entry.path().string());
        EXPECT_EQ(s.file, entry.path().string());
        size_t n = 0;
        for (const Cloud& c : s.clouds) n += c.ellipsoids.size();
        if (const auto it = ellipsoids.find(entry.path().filename().string()); it != ellipsoids.end()) {
            EXPECT_EQ(n, it->second);
            ++loaded;
        }
    }
    EXPECT_EQ(loaded, ellipsoids.size());
}

TEST(SceneLoaderTest, SharedScenesCarryTheirValues) {
    const Scene fly = loadScene(NEPHELE_SCENES "/flythrough.json");
    ASSERT_EQ(fly.objects.size(), 1u);
    EXPECT_EQ(fly.objects[0].type, Object::Type::Box);
    expectNear(fly.objects[0].size, {16, 4, 4});
    expectNear(fly.objects[0].color, {0.2, 0.25, 0.2});
    ASSERT_EQ(fly.path.size(), 3u);
    EXPECT_EQ(fly.path[2].t, 20);

    const Scene far = loadScene(NEPHELE_SCENES "/near_and_far.json");
    ASSERT_EQ(far.layers.size(), 1u);
    EXPECT_EQ(far.layers[0].base, 2500);
    EXPECT_EQ(far.layers[0].density, 0.8);
    EXPECT_EQ(far.layers[0].wind, Vec2(6, 2));
    EXPECT_EQ(far.layers[0].extent, 40000);
    EXPECT_EQ(far.camera.width, 800);
    EXPECT_EQ(far.camera.height, 450);

    const Scene two = loadScene(NEPHELE_SCENES "/two_clouds.json");
    ASSERT_EQ(two.clouds.size(), 2u);
    EXPECT_EQ(two.clouds[1].name, "right");
    expectNear(two.clouds[1].ellipsoids[0].rotationDeg, {0, 0, 20});
}

TEST(SceneLoaderTest, EmptyFile) {
    const std::string file = kData + "empty.json";
    try {
        loadScene(file);
        FAIL() << "accepted an empty file";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.jsonPath(), "");
        EXPECT_EQ(std::string(e.what()), file + ": the file is empty");
    }
    EXPECT_TRUE(failsAt("", "", "the file is empty"));
}

TEST(SceneLoaderTest, MissingFile) {
    const std::string file = kData + "no_such_scene.json";
    try {
        loadScene(file);
        FAIL() << "loaded a missing file";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.jsonPath(), "");
        EXPECT_EQ(std::string(e.what()), file + ": cannot open: No such file or directory");
    }
}

TEST(SceneLoaderTest, SyntaxErrorCarriesLineAndColumn) {
    EXPECT_TRUE(failsAt("{\n  \"cloudscene\": 1,\n  camera: {}\n}", "", "syntax error at line 3, column 3: "));
    EXPECT_TRUE(failsAt(R"({"cloudscene": 1, "clouds": [1, 2,]})", "", "syntax error at line 1, column 35"));
    EXPECT_TRUE(failsAt(scene() + " trailing", "", "syntax error at line 1"));
    EXPECT_TRUE(failsAt("[1, 2]", "", "expected a JSON object at the top level, got an array of 2 elements"));
}

// ---------------------------------------------------------------- defaults

TEST(SceneLoaderTest, MinimalSceneGetsEveryDefault) {
    const Scene s = parseScene(scene(), "dir/test.json");
    EXPECT_EQ(s.file, "dir/test.json");
    expectNear(s.camera.position, {0, 0, 0});
    expectNear(s.camera.direction, {0, 1, 0});
    expectNear(s.camera.up, {0, 0, 1});
    EXPECT_EQ(s.camera.fovYDeg, 60);
    EXPECT_EQ(s.camera.nearClip, 0.5);
    EXPECT_EQ(s.camera.farClip, 100000);
    EXPECT_EQ(s.camera.width, 640);
    EXPECT_EQ(s.camera.height, 480);

    expectNear(s.sun.direction, glm::normalize(Vec3(0.3, 0.2, 0.93)));
    expectNear(s.sun.color, {1, 1, 1});
    EXPECT_EQ(s.sun.intensity, 3.0);

    expectNear(s.sky.zenith, {0.10, 0.22, 0.55});
    expectNear(s.sky.horizon, {0.40, 0.50, 0.65});
    expectNear(s.sky.ground, {0.12, 0.12, 0.10});

    EXPECT_EQ(s.medium.extinction, 0.04);
    EXPECT_EQ(s.medium.albedo, 0.99);
    EXPECT_EQ(s.medium.hgG, 0.85);
    EXPECT_EQ(s.medium.noise, 0.3);
    EXPECT_EQ(s.medium.noiseScale, 60);

    EXPECT_TRUE(s.clouds.empty());
    EXPECT_TRUE(s.generators.empty());
    EXPECT_TRUE(s.layers.empty());
    EXPECT_FALSE(s.skylight.has_value());
    EXPECT_TRUE(s.lightning.empty());
    EXPECT_TRUE(s.objects.empty());
    EXPECT_EQ(s.objectLight, ObjectLight::Sun);
    EXPECT_TRUE(s.path.empty());
}

TEST(SceneLoaderTest, ObjectLightIsSunOrAll) {
    EXPECT_EQ(parseScene(scene(R"("object_light": "sun")"), "t.json").objectLight, ObjectLight::Sun);
    EXPECT_EQ(parseScene(scene(R"("object_light": "all")"), "t.json").objectLight, ObjectLight::All);
    EXPECT_TRUE(
        failsAt(scene(R"("object_light": "ambient")"), "object_light", "must be one of 'sun', 'all', got 'ambient'"));
    EXPECT_TRUE(failsAt(scene(R"("object_light": true)"), "object_light"));
}

TEST(SceneLoaderTest, NestedDefaults) {
    const Scene s = parseScene(scene(R"(
        "clouds": [{"ellipsoids": [{"center": [1, 2, 3], "radii": [4, 5, 6]}]}, {"ellipsoids": []}],
        "layers": [{"base": 2000, "thickness": 500, "city_glow": {}}, {"base": 0, "thickness": 1}],
        "skylight": {"direction": [0, 0, 2]},
        "lightning": [{"position": [0, 0, 1000], "intensity": 1e6}],
        "objects": [{"type": "box", "center": [0, 0, 0], "size": [1, 2, 3]},
                    {"type": "sphere", "center": [0, 0, 0], "radius": 2}])"),
                               "test.json");
    ASSERT_EQ(s.clouds.size(), 2u);
    EXPECT_EQ(s.clouds[0].name, "cloud0");
    EXPECT_EQ(s.clouds[1].name, "cloud1");
    const Ellipsoid& e = s.clouds[0].ellipsoids.at(0);
    expectNear(e.center, {1, 2, 3});
    expectNear(e.radii, {4, 5, 6});
    expectNear(e.rotationDeg, {0, 0, 0});
    EXPECT_EQ(e.density, 1.0);

    ASSERT_EQ(s.layers.size(), 2u);
    const Layer& l = s.layers[0];
    EXPECT_EQ(l.base, 2000);
    EXPECT_EQ(l.thickness, 500);
    EXPECT_EQ(l.coverage, 0.6);
    EXPECT_EQ(l.density, 1.0);
    EXPECT_EQ(l.wind, Vec2(0, 0));
    EXPECT_EQ(l.extent, 20000);
    EXPECT_EQ(l.seed, 1u);
    EXPECT_TRUE(l.nearLod);
    ASSERT_TRUE(l.cityGlow.has_value());
    expectNear(l.cityGlow->color, {1.0, 0.6, 0.3});
    EXPECT_EQ(l.cityGlow->strength, 1.0);
    EXPECT_FALSE(s.layers[1].cityGlow.has_value());

    ASSERT_TRUE(s.skylight.has_value());
    expectNear(s.skylight->direction, {0, 0, 1});
    expectNear(s.skylight->color, {1, 1, 1});
    EXPECT_EQ(s.skylight->intensity, 1.0);

    ASSERT_EQ(s.lightning.size(), 1u);
    EXPECT_EQ(s.lightning[0].intensity, 1e6);
    EXPECT_EQ(s.lightning[0].start, 0.0);
    EXPECT_EQ(s.lightning[0].duration, 0.2);

    ASSERT_EQ(s.objects.size(), 2u);
    EXPECT_EQ(s.objects[0].type, Object::Type::Box);
    expectNear(s.objects[0].size, {1, 2, 3});
    expectNear(s.objects[0].rotationDeg, {0, 0, 0});
    expectNear(s.objects[0].color, {0.5, 0.5, 0.5});
    EXPECT_EQ(s.objects[1].type, Object::Type::Sphere);
    EXPECT_EQ(s.objects[1].radius, 2.0);
}

TEST(SceneLoaderTest, ExplicitValuesOverrideDefaults) {
    const Scene s = parseScene(R"({"cloudscene": 1,
        "camera": {"position": [1, 2, 3], "direction": [0, 0, -5], "up": [0, 1, 0], "fov_y_deg": 40,
                   "near": 2, "far": 300, "width": 320, "height": 200},
        "sun": {"color": [1, 0.9, 0.8], "intensity": 2},
        "sky": {"zenith": [0, 0, 1], "horizon": [1, 1, 1], "ground": [0, 0, 0]},
        "medium": {"extinction": 0.1, "albedo": 1, "hg_g": -0.5, "noise": 0, "noise_scale": 10},
        "layers": [{"base": 1, "thickness": 2, "coverage": 0, "density": 1, "wind": [3, -4], "extent": 5,
                    "seed": 4294967295, "near_lod": false, "city_glow": {"color": [1, 0, 0], "strength": 0}}]})",
                               "test.json");
    expectNear(s.camera.position, {1, 2, 3});
    expectNear(s.camera.direction, {0, 0, -1});
    expectNear(s.camera.up, {0, 1, 0});
    EXPECT_EQ(s.camera.fovYDeg, 40);
    EXPECT_EQ(s.camera.nearClip, 2);
    EXPECT_EQ(s.camera.farClip, 300);
    EXPECT_EQ(s.camera.width, 320);
    EXPECT_EQ(s.camera.height, 200);
    expectNear(s.sun.color, {1, 0.9, 0.8});
    EXPECT_EQ(s.sun.intensity, 2);
    expectNear(s.sky.zenith, {0, 0, 1});
    EXPECT_EQ(s.medium.hgG, -0.5);
    EXPECT_EQ(s.medium.noise, 0);
    EXPECT_EQ(s.medium.noiseScale, 10);
    EXPECT_EQ(s.layers[0].seed, 4294967295u);
    EXPECT_FALSE(s.layers[0].nearLod);
    EXPECT_EQ(s.layers[0].wind, Vec2(3, -4));
    EXPECT_EQ(s.layers[0].cityGlow->strength, 0);
}

// ---------------------------------------------------------------- generic rules

TEST(SceneLoaderTest, WrongType) {
    EXPECT_TRUE(failsAt(withCamera(R"("position": "here", "look_at": [0, 1, 0])"), "camera.position",
                        "expected an array of 3 numbers, got a string"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0], "look_at": [0, 1, 0])"), "camera.position",
                        "expected an array of 3 numbers, got an array of 2 elements"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, "0", 0], "look_at": [0, 1, 0])"), "camera.position[1]",
                        "expected a number, got a string"));
    EXPECT_TRUE(failsAt(scene(R"("sun": {"intensity": "3"})"), "sun.intensity", "expected a number, got a string"));
    EXPECT_TRUE(failsAt(scene(R"("sun": {"intensity": true})"), "sun.intensity", "expected a number, got true"));
    EXPECT_TRUE(failsAt(scene(R"("sun": [1, 2])"), "sun", "expected an object, got an array"));
    EXPECT_TRUE(failsAt(scene(R"("clouds": {})"), "clouds", "expected an array, got an object"));
    EXPECT_TRUE(
        failsAt(scene(R"("clouds": [{"name": 3, "ellipsoids": []}])"), "clouds[0].name", "expected a string, got 3"));
    EXPECT_TRUE(failsAt(scene(R"("layers": [{"base": 0, "thickness": 1, "near_lod": "yes"}])"), "layers[0].near_lod",
                        "expected true or false, got a string"));
    EXPECT_TRUE(failsAt(scene(R"("layers": [{"base": 0, "thickness": 1, "wind": [1, 2, 3]}])"), "layers[0].wind",
                        "expected an array of 2 numbers, got an array of 3 elements"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"albedo": null})"), "medium.albedo", "expected a number, got null"));
}

TEST(SceneLoaderTest, UnknownKeys) {
    EXPECT_TRUE(failsAt(scene(R"("clods": [])"), "clods", "unknown key 'clods' (did you mean 'clouds'?)"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "look_at": [0, 1, 0], "fovy": 50)"), "camera.fovy",
                        "unknown key 'fovy' (did you mean 'fov_y_deg'?)"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "look_at": [0, 1, 0], "widht": 50)"), "camera.widht",
                        "(did you mean 'width'?)"));
    EXPECT_TRUE(failsAt(withEllipsoids(R"({"center": [0, 0, 0], "radii": [1, 1, 1], "colour": [1, 1, 1]})"),
                        "clouds[0].ellipsoids[0].colour", "unknown key 'colour'"));
    EXPECT_TRUE(failsAt(scene(R"("layers": [{"base": 0, "thickness": 1, "city_glow": {"strenght": 1}}])"),
                        "layers[0].city_glow.strenght", "(did you mean 'strength'?)"));
    EXPECT_TRUE(failsAt(scene(R"("zzzz": 1)"), "zzzz", "unknown key 'zzzz'"));
    // A typo of a required key is reported as such, not as the key missing.
    EXPECT_TRUE(failsAt(withCamera(R"("postion": [0, 0, 0], "look_at": [0, 1, 0])"), "camera.postion",
                        "unknown key 'postion' (did you mean 'position'?)"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "lookat": [0, 1, 0])"), "camera.lookat",
                        "unknown key 'lookat' (did you mean 'look_at'?)"));
    EXPECT_TRUE(failsAt(R"({"cloudscene": 1, "clouds": []})", "camera", "required key is missing"));
    // Keys beginning with '_' are comments, at every level.
    EXPECT_NO_THROW(parseScene(R"({"_": "top", "cloudscene": 1, "_c": 1,
        "camera": {"_why": [1], "position": [0, 0, 0], "look_at": [0, 1, 0]},
        "clouds": [{"_": {}, "ellipsoids": [{"_note": null, "center": [0, 0, 0], "radii": [1, 1, 1]}]}]})",
                               "test.json"));
}

TEST(SceneLoaderTest, DuplicateKeys) {
    EXPECT_TRUE(failsAt(R"({"cloudscene": 1, "cloudscene": 1})", "cloudscene", "duplicate key 'cloudscene'"));
    EXPECT_TRUE(failsAt(withEllipsoids(R"({"center": [0, 0, 0], "radii": [1, 1, 1]},
                                          {"center": [0, 0, 0], "radii": [1, 1, 1], "radii": [2, 2, 2]})"),
                        "clouds[0].ellipsoids[1].radii", "duplicate key 'radii'"));
    // The same key in different objects is fine, and repeated comments too.
    EXPECT_NO_THROW(parseScene(R"({"_": 1, "_": 2, "cloudscene": 1,
        "camera": {"position": [0, 0, 0], "look_at": [0, 1, 0]}, "sun": {"color": [1, 1, 1]},
        "sky": {"zenith": [1, 1, 1]}})",
                               "test.json"));
}

TEST(SceneLoaderTest, NonFiniteNumber) {
    // nlohmann parses 1e400 to inf and reports an overflow; the loader names the place.
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "look_at": [0, 1, 0], "fov_y_deg": 1e400)"),
                        "camera.fov_y_deg", "not a finite number"));
    EXPECT_TRUE(failsAt(withEllipsoids(kEllipsoid + R"(, {"center": [0, -1e400, 0], "radii": [1, 1, 1]})"),
                        "clouds[0].ellipsoids[1].center[1]", "not a finite number"));
    EXPECT_TRUE(failsAt(R"({"cloudscene": 1, "path": [{"t": 0}, {"t": 1E999}]})", "path[1].t", "1E999"));
}

TEST(SceneLoaderTest, MissingRequiredKeys) {
    EXPECT_TRUE(failsAt(R"({"cloudscene": 1})", "camera", "required key is missing"));
    EXPECT_TRUE(failsAt(withCamera(R"("look_at": [0, 1, 0])"), "camera.position", "required key is missing"));
    EXPECT_TRUE(failsAt(withEllipsoids(R"({"center": [0, 0, 0]})"), "clouds[0].ellipsoids[0].radii",
                        "required key is missing"));
    EXPECT_TRUE(failsAt(scene(R"("clouds": [{"name": "x"}])"), "clouds[0].ellipsoids", "required key is missing"));
}

// ---------------------------------------------------------------- version and camera

TEST(SceneLoaderTest, Version) {
    EXPECT_TRUE(failsAt(R"({"cloudscene": 2, "camera": {}})", "cloudscene",
                        "unsupported cloudscene version 2; this Nephele reads version 1"));
    EXPECT_TRUE(failsAt(R"({"camera": {"position": [0, 0, 0], "look_at": [0, 1, 0]}})", "cloudscene",
                        "required key is missing"));
    EXPECT_TRUE(failsAt(R"({"cloudscene": "1"})", "cloudscene", "expected an integer, got a string"));
    EXPECT_TRUE(failsAt(R"({"cloudscene": 1.5})", "cloudscene", "expected an integer, got 1.5"));
    const std::string text = scene();
    EXPECT_NO_THROW(parseScene(R"({"cloudscene": 1.0)" + text.substr(text.find(',')), "test.json"));
}

TEST(SceneLoaderTest, CameraNeedsExactlyOneOfLookAtAndDirection) {
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "look_at": [0, 1, 0], "direction": [0, 1, 0])"), "camera",
                        "both 'look_at' and 'direction'"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0])"), "camera", "needs 'look_at' or 'direction'"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "direction": [0, 0, 0])"), "camera.direction",
                        "must not be the zero vector"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [1, 2, 3], "look_at": [1, 2, 3])"), "camera.look_at",
                        "must differ from position"));
    const Scene s = parseScene(withCamera(R"("position": [1, 1, 1], "look_at": [4, 5, 1])"), "test.json");
    expectNear(s.camera.direction, {0.6, 0.8, 0});
    // Below float's range a component reads as 0 (docs/reliability.md, hostile input): no direction.
    EXPECT_TRUE(failsAt(withCamera(R"("position": [1, 1, 1], "direction": [0, 1e-300, 0])"), "camera.direction",
                        "must not be the zero vector"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [1, 1, 1], "direction": [0, 1e-7, 0])"), "camera.direction",
                        "is too short to give a direction"));
    const Scene d = parseScene(withCamera(R"("position": [1, 1, 1], "direction": [0, 1e-5, 0])"), "test.json");
    expectNear(d.camera.direction, {0, 1, 0});
}

TEST(SceneLoaderTest, CameraUp) {
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "look_at": [0, 0, 10], "up": [0, 0, 3])"), "camera.up",
                        "parallel to the view direction"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "direction": [0, 0, -1])"), "camera.up",
                        "the default up [0, 0, 1] is parallel"));
    EXPECT_TRUE(failsAt(withCamera(R"("position": [0, 0, 0], "look_at": [0, 1, 0], "up": [0, 0, 0])"), "camera.up",
                        "must not be the zero vector"));
    const Scene s =
        parseScene(withCamera(R"("position": [0, 0, 0], "direction": [0, 0, -1], "up": [0, 2, 0])"), "test.json");
    expectNear(s.camera.up, {0, 2, 0});  // kept as given
}

TEST(SceneLoaderTest, ClipPlanes) {
    const std::string camera = R"("position": [0, 0, 0], "look_at": [0, 1, 0], )";
    EXPECT_TRUE(failsAt(withCamera(camera + R"("near": 10, "far": 10)"), "camera.near", "must be < far (10), got 10"));
    EXPECT_TRUE(failsAt(withCamera(camera + R"("near": 200000)"), "camera.near", "must be < far (100000)"));
    EXPECT_TRUE(failsAt(withCamera(camera + R"("near": 0)"), "camera.near", "must be > 0, got 0"));
    EXPECT_TRUE(failsAt(withCamera(camera + R"("far": -5)"), "camera.far", "must be > 0, got -5"));
    EXPECT_TRUE(
        failsAt(withCamera(camera + R"("fov_y_deg": 179)"), "camera.fov_y_deg", "must be in (1, 179), got 179"));
    EXPECT_TRUE(failsAt(withCamera(camera + R"("fov_y_deg": 1)"), "camera.fov_y_deg", "must be in (1, 179)"));
}

TEST(SceneLoaderTest, ImageSize) {
    const std::string camera = R"("position": [0, 0, 0], "look_at": [0, 1, 0], )";
    EXPECT_TRUE(failsAt(withCamera(camera + R"("width": 0)"), "camera.width", "must be in 1..16384, got 0"));
    EXPECT_TRUE(failsAt(withCamera(camera + R"("height": 16385)"), "camera.height", "must be in 1..16384, got 16385"));
    EXPECT_TRUE(failsAt(withCamera(camera + R"("width": 640.5)"), "camera.width", "expected an integer, got 640.5"));
    EXPECT_TRUE(failsAt(withCamera(camera + R"("width": -1)"), "camera.width", "got -1"));
    const Scene s = parseScene(withCamera(camera + R"("width": 640.0, "height": 16384)"), "test.json");
    EXPECT_EQ(s.camera.width, 640);
    EXPECT_EQ(s.camera.height, 16384);
}

// ---------------------------------------------------------------- lights, medium, clouds

TEST(SceneLoaderTest, SunDirectionIsNormalised) {
    const Scene s = parseScene(scene(R"("sun": {"direction": [0, 3, 4]})"), "test.json");
    expectNear(s.sun.direction, {0, 0.6, 0.8});
    EXPECT_TRUE(failsAt(scene(R"("sun": {"direction": [0, 0, 0]})"), "sun.direction", "must not be the zero vector"));
    EXPECT_TRUE(failsAt(scene(R"("sun": {"intensity": -1})"), "sun.intensity", "must be >= 0, got -1"));
}

TEST(SceneLoaderTest, ColoursAreNonNegative) {
    EXPECT_TRUE(failsAt(scene(R"("sun": {"color": [1, -0.5, 1]})"), "sun.color[1]", "must be >= 0, got -0.5"));
    EXPECT_TRUE(failsAt(scene(R"("sky": {"ground": [0, 0, -1]})"), "sky.ground[2]", "must be >= 0"));
    EXPECT_TRUE(
        failsAt(scene(R"("objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "color": [-1, 0, 0]}])"),
                "objects[0].color[0]", "must be >= 0"));
    EXPECT_TRUE(failsAt(scene(R"("layers": [{"base": 0, "thickness": 1, "city_glow": {"color": [0, -2, 0]}}])"),
                        "layers[0].city_glow.color[1]", "must be >= 0"));
}

TEST(SceneLoaderTest, MediumRanges) {
    EXPECT_TRUE(failsAt(scene(R"("medium": {"extinction": -0.1})"), "medium.extinction", "must be >= 0, got -0.1"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"albedo": 1.01})"), "medium.albedo", "must be in [0, 1], got 1.01"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"hg_g": 1})"), "medium.hg_g", "must be in (-1, 1), got 1"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"hg_g": -1})"), "medium.hg_g", "must be in (-1, 1), got -1"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"noise": -1})"), "medium.noise", "must be >= 0"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"noise_scale": 0})"), "medium.noise_scale", "must be > 0, got 0"));
}

// The physical medium: 3 LWC / (2 rho_w r_eff) is the mean extinction of one ellipsoid of
// density 1, so the extinction at density 1 is that times 35/8 (data/scene-format.md, "medium").
TEST(SceneLoaderTest, PhysicalMediumConvertsToExtinction) {
    struct Case {
        double lwc, reff, mean;  // g/m^3, um, 1/m (the expected mean, worked by hand)
    };
    // 0.5 g/m^3 and 10 um: the issue's cumulus, 1.5 / (2e6 * 1e-5) = 0.075 /m; the ends of the ranges.
    for (const Case c :
         {Case{0.5, 10, 0.075}, Case{1, 1, 1.5}, Case{5, 100, 0.075}, Case{0.01, 100, 0.00015}, Case{1.5, 3, 0.75}}) {
        const Scene s = parseScene(scene(R"("medium": {"liquid_water_content": )" + std::to_string(c.lwc) +
                                         R"(, "droplet_effective_radius": )" + std::to_string(c.reff) + "}"),
                                   "test.json");
        SCOPED_TRACE(std::to_string(c.lwc) + " g/m^3, " + std::to_string(c.reff) + " um");
        EXPECT_NEAR(s.medium.extinction, c.mean * 35.0 / 8.0, 1e-6 * c.mean * 35.0 / 8.0);
        EXPECT_NEAR(meanExtinctionFromWater(c.lwc, c.reff), c.mean, 1e-6 * c.mean);
        EXPECT_EQ(s.medium.albedo, 0.99);  // the albedo keeps its default
    }
    // 35/8 is 1 / the mean of (1 - q)^2 over the unit ball: 3 * integral of (1 - r^2)^2 r^2 dr from 0 to 1.
    double mean = 0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        const double r = (i + 0.5) / n;
        mean += 3 * (1 - r * r) * (1 - r * r) * r * r / n;
    }
    EXPECT_NEAR(mean, kProfileMean, 1e-9);
}

TEST(SceneLoaderTest, PhysicalMediumRules) {
    const std::string pair = R"("liquid_water_content": 0.5, "droplet_effective_radius": 10)";
    EXPECT_TRUE(failsAt(
        scene(R"("medium": {"extinction": 0.04, )" + pair + "}"), "medium.liquid_water_content",
        "give either 'extinction' or the pair 'liquid_water_content' and 'droplet_effective_radius', not both"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"extinction": 0.04, "droplet_effective_radius": 10})"),
                        "medium.droplet_effective_radius", "give either 'extinction' or the pair"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"liquid_water_content": 0.5})"), "medium.droplet_effective_radius",
                        "required key is missing: 'liquid_water_content' is given, and the extinction needs both"));
    EXPECT_TRUE(failsAt(scene(R"("medium": {"droplet_effective_radius": 10})"), "medium.liquid_water_content",
                        "required key is missing: 'droplet_effective_radius' is given"));
    auto with = [](const std::string& lwc, const std::string& reff) {
        return scene(R"("medium": {"liquid_water_content": )" + lwc + R"(, "droplet_effective_radius": )" + reff + "}");
    };
    EXPECT_TRUE(failsAt(with("0", "10"), "medium.liquid_water_content",
                        "must be in (0, 5] g/m^3 (cloud liquid water content), got 0"));
    EXPECT_TRUE(failsAt(with("-0.5", "10"), "medium.liquid_water_content", "must be in (0, 5] g/m^3"));
    EXPECT_TRUE(failsAt(with("5.01", "10"), "medium.liquid_water_content",
                        "must be in (0, 5] g/m^3 (cloud liquid water content), got 5.01"));
    EXPECT_TRUE(failsAt(with("\"a\"", "10"), "medium.liquid_water_content", "expected a number, got a string"));
    EXPECT_TRUE(failsAt(with("0.5", "0.99"), "medium.droplet_effective_radius",
                        "must be in [1, 100] micrometres (cloud droplets), got 0.99"));
    EXPECT_TRUE(failsAt(with("0.5", "101"), "medium.droplet_effective_radius", "must be in [1, 100] micrometres"));
    EXPECT_TRUE(failsAt(with("0.5", "null"), "medium.droplet_effective_radius", "expected a number, got null"));
    // 5 g/m^3 of 1 um droplets: 7.5 /m on average, 32.8 /m at density 1, over the extinction limit.
    EXPECT_TRUE(failsAt(with("5", "1"), "medium.liquid_water_content",
                        "5 g/m^3 with droplet_effective_radius 1 um gives an extinction of 32.8125 1/m at density 1, "
                        "over the limit 'extinction' (10 1/m)"));
    // The per-ellipsoid optical depth limit sees the converted extinction: 0.328125 * 16/15 * 30000 m = 10500.
    EXPECT_TRUE(failsAt(scene(R"("medium": {)" + pair +
                              R"(}, "clouds": [{"ellipsoids": [{"center": [0, 0, 0], "radii": [30000, 1, 1]}]}])"),
                        "clouds[0].ellipsoids[0].density", "(medium.extinction 0.328125 x density 1"));
}

TEST(SceneLoaderTest, DenseCumulusIsCumulus27WithRealWater) {
    const Scene dense = loadScene(NEPHELE_SCENES "/dense_cumulus.json");
    const Scene thin = loadScene(NEPHELE_SCENES "/cumulus27.json");
    EXPECT_NEAR(dense.medium.extinction, 0.328125, 1e-6 * 0.328125);
    ASSERT_EQ(dense.clouds.size(), thin.clouds.size());
    ASSERT_EQ(dense.clouds[0].ellipsoids.size(), thin.clouds[0].ellipsoids.size());
    for (size_t i = 0; i < thin.clouds[0].ellipsoids.size(); ++i) {
        EXPECT_EQ(dense.clouds[0].ellipsoids[i].center, thin.clouds[0].ellipsoids[i].center);
        EXPECT_EQ(dense.clouds[0].ellipsoids[i].radii, thin.clouds[0].ellipsoids[i].radii);
        EXPECT_EQ(dense.clouds[0].ellipsoids[i].density, thin.clouds[0].ellipsoids[i].density);
    }
    EXPECT_EQ(dense.medium.noise, thin.medium.noise);  // the accuracy bench sets noise 0 itself
}

TEST(SceneLoaderTest, EllipsoidRules) {
    EXPECT_TRUE(failsAt(withEllipsoids(kEllipsoid + R"(, {"center": [0, 0, 0], "radii": [1, 2, -3]})"),
                        "clouds[0].ellipsoids[1].radii[2]", "must be > 0, got -3"));
    EXPECT_TRUE(failsAt(withEllipsoids(R"({"center": [0, 0, 0], "radii": [0, 2, 3]})"),
                        "clouds[0].ellipsoids[0].radii[0]", "must be > 0, got 0"));
    EXPECT_TRUE(failsAt(withEllipsoids(R"({"center": [0, 0, 0], "radii": [1, 2, 3], "density": -1})"),
                        "clouds[0].ellipsoids[0].density", "must be >= 0"));
    EXPECT_TRUE(
        failsAt(scene(R"("clouds": [{"ellipsoids": []}, {"ellipsoids": [{"center": [0, 0, 0], "radii": [1, 1]}]}])"),
                "clouds[1].ellipsoids[0].radii", "expected an array of 3 numbers"));
}

TEST(SceneLoaderTest, LayerRanges) {
    auto layer = [](const std::string& keys) { return scene(R"("layers": [{"base": 1000, )" + keys + "}]"); };
    EXPECT_TRUE(failsAt(scene(R"("layers": [{"thickness": 1}])"), "layers[0].base", "required key is missing"));
    EXPECT_TRUE(failsAt(scene(R"("layers": [{"base": 1}])"), "layers[0].thickness", "required key is missing"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 0)"), "layers[0].thickness", "must be > 0, got 0"));
    EXPECT_TRUE(
        failsAt(layer(R"("thickness": 1, "coverage": 1.5)"), "layers[0].coverage", "must be in [0, 1], got 1.5"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 1, "density": -0.1)"), "layers[0].density", "must be in [0, 1]"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 1, "extent": 0)"), "layers[0].extent", "must be > 0"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 1, "seed": -1)"), "layers[0].seed", "must be in 0..4294967295, got -1"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 1, "seed": 1.5)"), "layers[0].seed", "expected an integer"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 1, "seed": 4294967296)"), "layers[0].seed", "must be in 0..4294967295"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 1, "city_glow": {"strength": -1})"), "layers[0].city_glow.strength",
                        "must be >= 0"));
    EXPECT_TRUE(failsAt(layer(R"("thickness": 1, "city_glow": 1)"), "layers[0].city_glow", "expected an object"));
}

TEST(SceneLoaderTest, Skylight) {
    EXPECT_TRUE(failsAt(scene(R"("skylight": {"color": [1, 1, 1]})"), "skylight.direction", "required key is missing"));
    EXPECT_TRUE(failsAt(scene(R"("skylight": {"direction": [0, 0, 0]})"), "skylight.direction", "zero vector"));
    EXPECT_TRUE(failsAt(scene(R"("skylight": {"direction": [0, 0, 1], "intensity": -1})"), "skylight.intensity",
                        "must be >= 0"));
    const Scene s = parseScene(
        scene(R"("skylight": {"direction": [-2, 0, 0], "color": [0.5, 0.6, 1], "intensity": 0.3})"), "test.json");
    expectNear(s.skylight->direction, {-1, 0, 0});
    expectNear(s.skylight->color, {0.5, 0.6, 1});
    EXPECT_EQ(s.skylight->intensity, 0.3);
}

TEST(SceneLoaderTest, Lightning) {
    EXPECT_TRUE(
        failsAt(scene(R"("lightning": [{"intensity": 1}])"), "lightning[0].position", "required key is missing"));
    EXPECT_TRUE(failsAt(scene(R"("lightning": [{"position": [0, 0, 0]}])"), "lightning[0].intensity", "required"));
    EXPECT_TRUE(failsAt(scene(R"("lightning": [{"position": [0, 0, 0], "intensity": -1}])"), "lightning[0].intensity",
                        "must be >= 0"));
    EXPECT_TRUE(failsAt(scene(R"("lightning": [{"position": [0, 0, 0], "intensity": 1, "duration": 0}])"),
                        "lightning[0].duration", "must be > 0, got 0"));
    const Scene s = parseScene(
        scene(R"("lightning": [{"position": [1, 2, 3], "intensity": 5, "start": 1.5, "duration": 0.1}])"), "test.json");
    EXPECT_EQ(s.lightning[0].start, 1.5);
    EXPECT_EQ(s.lightning[0].duration, 0.1);
}

TEST(SceneLoaderTest, Objects) {
    auto object = [](const std::string& keys) { return scene(R"("objects": [)" + keys + "]"); };
    EXPECT_TRUE(
        failsAt(object(R"({"type": "box", "center": [0, 0, 0]})"), "objects[0].size", "required key is missing"));
    EXPECT_TRUE(
        failsAt(object(R"({"type": "sphere", "center": [0, 0, 0]})"), "objects[0].radius", "required key is missing"));
    EXPECT_TRUE(failsAt(object(R"({"type": "box", "center": [0, 0, 0], "size": [1, 1, 1], "radius": 1})"),
                        "objects[0].radius", "'radius' is not a key of a box"));
    EXPECT_TRUE(failsAt(object(R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "size": [1, 1, 1]})"),
                        "objects[0].size", "'size' is not a key of a sphere"));
    EXPECT_TRUE(failsAt(object(R"({"center": [0, 0, 0], "radius": 1})"), "objects[0].type", "required key is missing"));
    EXPECT_TRUE(failsAt(object(R"({"type": "cube", "center": [0, 0, 0]})"), "objects[0].type",
                        "must be one of 'box', 'sphere', got 'cube'"));
    EXPECT_TRUE(
        failsAt(object(R"({"type": "box", "size": [1, 1, 1]})"), "objects[0].center", "required key is missing"));
    EXPECT_TRUE(failsAt(object(R"({"type": "box", "center": [0, 0, 0], "size": [1, 0, 1]})"), "objects[0].size[1]",
                        "must be > 0"));
    EXPECT_TRUE(failsAt(object(R"({"type": "sphere", "center": [0, 0, 0], "radius": -2})"), "objects[0].radius",
                        "must be > 0, got -2"));
    const Scene s = parseScene(
        object(R"({"type": "box", "center": [1, 2, 3], "size": [4, 5, 6], "rotation_deg": [0, 0, 45]})"), "test.json");
    expectNear(s.objects[0].center, {1, 2, 3});
    expectNear(s.objects[0].rotationDeg, {0, 0, 45});
}

TEST(SceneLoaderTest, CameraPath) {
    const std::string k0 = R"({"t": 0, "position": [0, 0, 0], "look_at": [0, 1, 0]})";
    const std::string k1 = R"({"t": 5, "position": [10, 0, 0], "look_at": [10, 1, 0]})";
    EXPECT_TRUE(
        failsAt(scene(R"("path": [)" + k0 + ", " + k1 + R"(, {"t": 5, "position": [0, 0, 0], "look_at": [1, 0, 0]}])"),
                "path[2].t", "must be > the previous keyframe's t (5), got 5"));
    EXPECT_TRUE(failsAt(scene(R"("path": [)" + k1 + ", " + k0 + "]"), "path[1].t", "got 0"));
    EXPECT_TRUE(failsAt(scene(R"("path": [{"t": 0, "position": [1, 1, 1], "look_at": [1, 1, 1]}])"), "path[0].look_at",
                        "must differ from position"));
    EXPECT_TRUE(
        failsAt(scene(R"("path": [{"t": 0, "look_at": [1, 1, 1]}])"), "path[0].position", "required key is missing"));
    EXPECT_TRUE(failsAt(scene(R"("path": [{"position": [0, 0, 0], "look_at": [1, 1, 1]}])"), "path[0].t", "required"));
    EXPECT_TRUE(failsAt(scene(R"("path": [{"t": 0, "position": [0, 0, 0]}])"), "path[0].look_at", "required"));
    EXPECT_EQ(parseScene(scene(R"("path": [)" + k0 + ", " + k1 + "]"), "test.json").path.size(), 2u);
}

// ---------------------------------------------------------------- generate

TEST(SceneGeneratorTest, CumulusDefaultsAndValues) {
    const Scene s = parseScene(scene(R"("generate": [
        {"type": "cumulus", "center": [0, 0, 1500]},
        {"type": "cumulus", "name": "big", "seed": 7, "density": 0.5, "center": [1, 2, 3], "count": 100,
         "sigma": [400, 300, 100], "clamp_lo": [-1, -1, 0], "clamp_hi": [1, 1, 3], "max_radius": 300,
         "aspect": [1, 1, 0.5], "hollow": false, "prune_contained": false}])"),
                               "test.json");
    ASSERT_EQ(s.generators.size(), 2u);
    const Generator& g = s.generators[0];
    EXPECT_EQ(g.type, Generator::Type::Cumulus);
    EXPECT_EQ(g.name, "cumulus0");
    EXPECT_EQ(g.seed, 1u);
    EXPECT_EQ(g.density, 1.0);
    expectNear(g.center, {0, 0, 1500});
    EXPECT_EQ(g.count, 35);
    expectNear(g.sigma, {300, 300, 120});
    expectNear(g.clampLo, {-2, -2, -0.5});
    expectNear(g.clampHi, {2, 2, 2});
    EXPECT_EQ(g.maxRadius, 250);
    expectNear(g.aspect, {1, 1, 0.7});
    EXPECT_TRUE(g.hollow);
    EXPECT_TRUE(g.pruneContained);

    const Generator& h = s.generators[1];
    EXPECT_EQ(h.name, "big");
    EXPECT_EQ(h.seed, 7u);
    EXPECT_EQ(h.density, 0.5);
    EXPECT_EQ(h.count, 100);
    expectNear(h.sigma, {400, 300, 100});
    expectNear(h.clampLo, {-1, -1, 0});
    expectNear(h.clampHi, {1, 1, 3});
    EXPECT_EQ(h.maxRadius, 300);
    expectNear(h.aspect, {1, 1, 0.5});
    EXPECT_FALSE(h.hollow);
    EXPECT_FALSE(h.pruneContained);
    EXPECT_EQ(s.clouds.size(), 2u);  // the loader expands generators (tests/generate_test.cpp)
}

TEST(SceneGeneratorTest, LSystemDefaultsAndValues) {
    const Scene s = parseScene(scene(R"("generate": [
        {"type": "cumulus", "center": [0, 0, 0]},
        {"type": "lsystem", "center": [0, 0, 1000], "axiom": "F",
         "rules": {"F": "F[+F]F[-F]", "X": "", "_": "comment"}},
        {"type": "lsystem", "center": [0, 0, 0], "axiom": "X", "rules": {}, "angle_deg": 30, "iterations": 8,
         "step": 50, "radius": 40, "jitter": 0}])"),
                               "test.json");
    const Generator& g = s.generators.at(1);
    EXPECT_EQ(g.type, Generator::Type::LSystem);
    EXPECT_EQ(g.name, "lsystem1");
    expectNear(g.center, {0, 0, 1000});
    EXPECT_EQ(g.axiom, "F");
    const std::vector<std::pair<char, std::string>> rules{{'F', "F[+F]F[-F]"}, {'X', ""}};
    EXPECT_EQ(g.rules, rules);
    EXPECT_EQ(g.angleDeg, 25);
    EXPECT_EQ(g.iterations, 3);
    EXPECT_EQ(g.step, 100);
    EXPECT_EQ(g.radius, 80);
    EXPECT_EQ(g.jitter, 0.2);
    const Generator& h = s.generators.at(2);
    EXPECT_EQ(h.name, "lsystem2");
    EXPECT_EQ(h.angleDeg, 30);
    EXPECT_EQ(h.iterations, 8);
    EXPECT_EQ(h.step, 50);
    EXPECT_EQ(h.radius, 40);
    EXPECT_EQ(h.jitter, 0);
}

TEST(SceneGeneratorTest, MeshPathIsRelativeToTheSceneFile) {
    const Scene s = loadScene(kData + "mesh.json");
    ASSERT_EQ(s.generators.size(), 1u);
    const Generator& g = s.generators[0];
    EXPECT_EQ(g.type, Generator::Type::Mesh);
    EXPECT_EQ(g.name, "mesh0");
    EXPECT_EQ(g.path, "tetra.obj");
    EXPECT_TRUE(std::filesystem::equivalent(g.resolvedPath, kData + "tetra.obj"));
    EXPECT_EQ(g.scale, 2);
    expectNear(g.position, {0, 0, 1000});
    EXPECT_EQ(g.thicknessRatio, 0.3);
    expectNear(g.rotationDeg, {0, 0, 0});

    const Scene d = parseScene(scene(R"("generate": [{"type": "mesh", "path": "tetra.obj"}])"), kData + "inline.json");
    EXPECT_EQ(d.generators[0].scale, 1.0);
    EXPECT_EQ(d.generators[0].thicknessRatio, 0.5);
    expectNear(d.generators[0].position, {0, 0, 0});
}

TEST(SceneGeneratorTest, MeshFileMustExist) {
    const std::string file = kData + "inline.json";
    try {
        parseScene(scene(R"("generate": [{"type": "mesh", "path": "missing.obj"}])"), file);
        FAIL() << "accepted a missing mesh";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.jsonPath(), "generate[0].path");
        EXPECT_EQ(e.fault(), "cannot open '" + kData + "missing.obj': No such file or directory");
        EXPECT_EQ(std::string(e.what()).rfind(file + ": generate[0].path: ", 0), 0u);
    }
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "mesh"}])"), "generate[0].path", "required key is missing"));
}

TEST(SceneGeneratorTest, KeysOfAnotherTypeAreRejected) {
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "cumulus", "center": [0, 0, 0], "axiom": "F"}])"),
                        "generate[0].axiom", "'axiom' is not a key of a cumulus generator"));
    EXPECT_TRUE(failsAt(
        scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "F", "rules": {}, "count": 3}])"),
        "generate[0].count", "'count' is not a key of a lsystem generator"));
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "mesh", "path": "x.obj", "center": [0, 0, 0]}])"),
                        "generate[0].center", "'center' is not a key of a mesh generator"));
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "cumulus", "center": [0, 0, 0], "cout": 3}])"),
                        "generate[0].cout", "unknown key 'cout' (did you mean 'count'?)"));
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "cloud"}])"), "generate[0].type",
                        "must be one of 'cumulus', 'mesh', 'lsystem', got 'cloud'"));
    EXPECT_TRUE(
        failsAt(scene(R"("generate": [{"center": [0, 0, 0]}])"), "generate[0].type", "required key is missing"));
}

TEST(SceneGeneratorTest, Ranges) {
    auto cumulus = [](const std::string& keys) {
        return scene(R"("generate": [{"type": "cumulus", "center": [0, 0, 0], )" + keys + "}]");
    };
    auto lsystem = [](const std::string& keys) {
        return scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "F", "rules": {"F": "FF"}, )" +
                     keys + "}]");
    };
    EXPECT_TRUE(
        failsAt(scene(R"("generate": [{"type": "cumulus"}])"), "generate[0].center", "required key is missing"));
    EXPECT_TRUE(failsAt(cumulus(R"("count": 0)"), "generate[0].count", "must be in 1..100000, got 0"));
    EXPECT_TRUE(failsAt(cumulus(R"("count": 100001)"), "generate[0].count",
                        "100001 is over the limit 'ellipsoids per generate entry' (100000)"));
    EXPECT_TRUE(failsAt(cumulus(R"("seed": -3)"), "generate[0].seed", "must be in 0..4294967295"));
    EXPECT_TRUE(failsAt(cumulus(R"("density": -1)"), "generate[0].density", "must be >= 0"));
    EXPECT_TRUE(failsAt(cumulus(R"("sigma": [1, 0, 1])"), "generate[0].sigma[1]", "must be > 0"));
    EXPECT_TRUE(
        failsAt(cumulus(R"("clamp_lo": [0, 0, 3])"), "generate[0].clamp_hi[2]", "must be > clamp_lo[2] (3), got 2"));
    EXPECT_TRUE(failsAt(cumulus(R"("clamp_hi": [-2, 2, 2])"), "generate[0].clamp_hi[0]", "must be > clamp_lo[0] (-2)"));
    EXPECT_TRUE(failsAt(cumulus(R"("max_radius": 0)"), "generate[0].max_radius", "must be > 0"));
    EXPECT_TRUE(failsAt(cumulus(R"("aspect": [1, 1, -1])"), "generate[0].aspect[2]", "must be > 0"));
    EXPECT_TRUE(failsAt(cumulus(R"("hollow": 1)"), "generate[0].hollow", "expected true or false"));
    EXPECT_TRUE(failsAt(cumulus(R"("name": ["x"])"), "generate[0].name", "expected a string"));

    EXPECT_TRUE(failsAt(lsystem(R"("iterations": 9)"), "generate[0].iterations", "must be in 0..8, got 9"));
    EXPECT_TRUE(failsAt(lsystem(R"("iterations": -1)"), "generate[0].iterations", "must be in 0..8"));
    EXPECT_TRUE(failsAt(lsystem(R"("jitter": 1)"), "generate[0].jitter", "must be in [0, 1), got 1"));
    EXPECT_TRUE(failsAt(lsystem(R"("jitter": -0.1)"), "generate[0].jitter", "must be in [0, 1)"));
    EXPECT_TRUE(failsAt(lsystem(R"("step": 0)"), "generate[0].step", "must be > 0"));
    EXPECT_TRUE(failsAt(lsystem(R"("radius": -1)"), "generate[0].radius", "must be > 0"));
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "", "rules": {}}])"),
                        "generate[0].axiom", "must not be empty"));
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "rules": {}}])"),
                        "generate[0].axiom", "required key is missing"));
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "F"}])"),
                        "generate[0].rules", "required key is missing"));
    EXPECT_TRUE(
        failsAt(scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "F", "rules": {"FF": "F"}}])"),
                "generate[0].rules.FF", "a rule's symbol must be one character, got 'FF'"));
    EXPECT_TRUE(
        failsAt(scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "F", "rules": {"F": 1}}])"),
                "generate[0].rules.F", "expected a string, got 1"));
    EXPECT_TRUE(
        failsAt(scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "F", "rules": ["F"]}])"),
                "generate[0].rules", "expected an object mapping one-character symbols to strings"));
    EXPECT_TRUE(failsAt(
        scene(R"("generate": [{"type": "lsystem", "center": [0, 0, 0], "axiom": "F", "rules": {"F": "a", "F": "b"}}])"),
        "generate[0].rules.F", "duplicate key 'F'"));
    EXPECT_TRUE(failsAt(scene(R"("generate": [{"type": "mesh", "path": "tetra.obj", "scale": 0}])"),
                        "generate[0].scale", "must be > 0", kData + "inline.json"));  // next to tetra.obj
}

// ---------------------------------------------------------------- rotation

TEST(RotationTest, OrderIsRzRyRx) {
    // R = Rz(90) Ry(0) Rx(90): Rx takes x->x, y->z; Rz then takes x->y, z->z.
    const glm::dmat3 r = rotationFromDegrees({90, 0, 90});
    expectNear(r * Vec3(1, 0, 0), {0, 1, 0});
    expectNear(r * Vec3(0, 1, 0), {0, 0, 1});
    expectNear(r * Vec3(0, 0, 1), {1, 0, 0});
    // The other order (Rx after Rz) would send x to z: rotations do not commute.
    const glm::dmat3 rx = rotationFromDegrees({90, 0, 0}), rz = rotationFromDegrees({0, 0, 90});
    expectNear(rx * rz * Vec3(1, 0, 0), {0, 0, 1});
    expectNear(rz * rx * Vec3(1, 0, 0), r * Vec3(1, 0, 0));

    // Each elementary rotation is right-handed about its world axis.
    expectNear(rotationFromDegrees({90, 0, 0}) * Vec3(0, 1, 0), {0, 0, 1});
    expectNear(rotationFromDegrees({0, 90, 0}) * Vec3(0, 0, 1), {1, 0, 0});
    expectNear(rotationFromDegrees({0, 0, 90}) * Vec3(1, 0, 0), {0, 1, 0});
    // Ry(90) takes x to -z, then Rz(90) leaves it there; y goes to -x under Rz.
    const glm::dmat3 yz = rotationFromDegrees({0, 90, 90});
    expectNear(yz * Vec3(1, 0, 0), {0, 0, -1});
    expectNear(yz * Vec3(0, 1, 0), {-1, 0, 0});
}

TEST(RotationTest, GeneralAnglesMatchTheProduct) {
    const double x = glm::radians(30.0), y = glm::radians(-50.0), z = glm::radians(115.0);
    // Row-major hand-written elementary matrices, transposed into glm's column order.
    const glm::dmat3 rx =
        glm::transpose(glm::dmat3(1, 0, 0, 0, std::cos(x), -std::sin(x), 0, std::sin(x), std::cos(x)));
    const glm::dmat3 ry =
        glm::transpose(glm::dmat3(std::cos(y), 0, std::sin(y), 0, 1, 0, -std::sin(y), 0, std::cos(y)));
    const glm::dmat3 rz =
        glm::transpose(glm::dmat3(std::cos(z), -std::sin(z), 0, std::sin(z), std::cos(z), 0, 0, 0, 1));
    const glm::dmat3 r = rotationFromDegrees({30, -50, 115});
    for (const Vec3& v : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(0.3, -2, 5)})
        expectNear(r * v, rz * (ry * (rx * v)));
    expectNear(glm::transpose(r) * (r * Vec3(0.3, -2, 5)), {0.3, -2, 5});  // orthonormal
    EXPECT_NEAR(glm::determinant(r), 1.0, 1e-12);
}

TEST(RotationTest, LoadedEllipsoidAxes) {
    const Scene s = parseScene(
        withEllipsoids(R"({"center": [0, 0, 0], "radii": [3, 2, 1], "rotation_deg": [90, 0, 90]})"), "test.json");
    const Ellipsoid& e = s.clouds[0].ellipsoids[0];
    const glm::dmat3 r = rotationFromDegrees(e.rotationDeg);
    // The semi-axes along local x, y, z end up along world y, z, x.
    expectNear(r * Vec3(e.radii.x, 0, 0), {0, 3, 0});
    expectNear(r * Vec3(0, e.radii.y, 0), {0, 0, 2});
    expectNear(r * Vec3(0, 0, e.radii.z), {1, 0, 0});
}

// ---------------------------------------------------------------- cameraAt

TEST(CameraAtTest, NoPathGivesTheSceneCamera) {
    const Scene s = parseScene(
        withCamera(R"("position": [1, 2, 3], "look_at": [1, 2, 0], "up": [0, 1, 0], "width": 100)"), "test.json");
    const Camera c = cameraAt(s, 7.0);
    expectNear(c.position, {1, 2, 3});
    expectNear(c.direction, {0, 0, -1});
    EXPECT_EQ(c.width, 100);
}

TEST(CameraAtTest, InterpolatesLinearlyAndClamps) {
    // up [1, 1, 0]: keyframe 1 looks straight up, which the default up would not allow.
    const Scene s =
        parseScene(R"({"cloudscene": 1, "camera": {"position": [0, 0, 0], "look_at": [0, 1, 0], "up": [1, 1, 0]},
        "path": [{"t": 0, "position": [0, 0, 0], "look_at": [0, 10, 0]},
                 {"t": 10, "position": [100, 0, 0], "look_at": [100, 0, 10]},
                 {"t": 20, "position": [100, 0, 100], "look_at": [110, 0, 100]}]})",
                   "test.json");
    const Camera mid = cameraAt(s, 5);
    expectNear(mid.position, {50, 0, 0});
    expectNear(mid.direction, glm::normalize(Vec3(0, 5, 5)));  // look_at (50, 5, 5)
    expectNear(cameraAt(s, 15).position, {100, 0, 50});
    expectNear(cameraAt(s, 15).direction, glm::normalize(Vec3(5, 0, 5)));
    expectNear(cameraAt(s, 10).position, {100, 0, 0});
    expectNear(cameraAt(s, 10).direction, {0, 0, 1});
    expectNear(cameraAt(s, -5).position, {0, 0, 0});  // clamped before the first keyframe
    expectNear(cameraAt(s, -5).direction, {0, 1, 0});
    expectNear(cameraAt(s, 99).position, {100, 0, 100});  // and after the last
    expectNear(cameraAt(s, 99).direction, {1, 0, 0});
    // Other fields are the scene camera's.
    EXPECT_EQ(mid.fovYDeg, s.camera.fovYDeg);
    EXPECT_EQ(mid.width, s.camera.width);
    expectNear(mid.up, s.camera.up);
}

// ---------------------------------------------------------------- SceneError

TEST(SceneErrorTest, MessageFormat) {
    const SceneError withPath("scene.json", "clouds[2].ellipsoids[5].radii[1]", "must be > 0, got -3");
    EXPECT_STREQ(withPath.what(), "scene.json: clouds[2].ellipsoids[5].radii[1]: must be > 0, got -3");
    EXPECT_EQ(withPath.file(), "scene.json");
    EXPECT_EQ(withPath.jsonPath(), "clouds[2].ellipsoids[5].radii[1]");
    EXPECT_EQ(withPath.fault(), "must be > 0, got -3");
    const SceneError whole("scene.json", "", "the file is empty");
    EXPECT_STREQ(whole.what(), "scene.json: the file is empty");
}

}  // namespace
}  // namespace nephele
