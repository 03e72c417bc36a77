// Hostile input, round three (issue 38), as the library reads it: numbers below float range in
// every numeric field, near-zero direction vectors, one big generated cumulus. The command line's
// part of the round (compare's memory, long output names, flags, flight scripts, printed paths,
// a 16384x1 frame) is hostile_cli_test.cpp's.
#include "full_scene.hpp"
#include "test_build.hpp"

#include "nephele/cloud_radiance.hpp"
#include "nephele/generate.hpp"
#include "nephele/scene.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

using json = nlohmann::json;

namespace nephele {
namespace {

using test::fullScene;
using test::numbersOf;

// ---------------------------------------------------------------- 2. numbers below float range

// Whether `fault` (a JSON path) is the field at `path` or the vector or object that holds it.
bool names(const std::string& fault, const std::string& path) {
    return !fault.empty() && path.rfind(fault, 0) == 0 &&
           (fault.size() == path.size() || path[fault.size()] == '.' || path[fault.size()] == '[');
}

TEST(HostileNumbersTest, EveryNumericFieldBelowFloatRangeFailsNamingItOrReadsAsZero) {
    const std::string file = NEPHELE_TEST_DATA "/scenes/full.json";
    const json base = fullScene();
    ASSERT_NO_THROW(parseScene(base.dump(), file));
    std::vector<std::pair<json::json_pointer, std::string>> fields;
    numbersOf(base, json::json_pointer(), "", fields);
    ASSERT_GT(fields.size(), 100u);  // 141 numbers, "cloudscene" among them
    int rejected = 0, accepted = 0;
    for (const auto& [at, path] : fields) {
        if (path == "cloudscene") continue;
        for (const double v : {1e-39, 1e-310, -1e-39}) {
            SCOPED_TRACE(path + " = " + std::to_string(v));
            json j = base;
            j[at] = v;
            try {
                parseScene(j.dump(), file);
            } catch (const SceneError& e) {
                ++rejected;
                // The message names the field (or its vector, or the object the rule is about).
                EXPECT_TRUE(names(e.jsonPath(), path)) << e.what();
                continue;
            }
            ++accepted;
            // Accepted: read as 0, so the scene with a 0 there loads as well (the same scene).
            j[at] = 0;
            EXPECT_NO_THROW(parseScene(j.dump(), file));
        }
    }
    EXPECT_GT(rejected, 0);
    EXPECT_GT(accepted, 0);
    // Read as 0, not kept as a subnormal the shaders would flush and the CPU would not.
    const std::pair<const char*, std::function<double(const Scene&)>> read[] = {
        {"/sun/intensity", [](const Scene& s) { return s.sun.intensity; }},
        {"/skylight/intensity", [](const Scene& s) { return s.skylight->intensity; }},
        {"/sky/zenith/0", [](const Scene& s) { return s.sky.zenith.x; }},
        {"/medium/noise", [](const Scene& s) { return s.medium.noise; }},
        {"/layers/0/wind/0", [](const Scene& s) { return s.layers[0].wind.x; }},
        {"/clouds/0/ellipsoids/0/center/0", [](const Scene& s) { return s.clouds[0].ellipsoids[0].center.x; }},
    };
    for (const auto& [at, value] : read)
        for (const double v : {1e-39, 1e-310, -1e-39}) {
            json j = base;
            j[json::json_pointer(at)] = v;
            EXPECT_EQ(value(parseScene(j.dump(), file)), 0.0) << at << " = " << v;
        }
}

// ---------------------------------------------------------------- 3. near-zero directions

TEST(HostileNumbersTest, EveryDirectionVectorNeedsALengthThatMeansSomethingInFloat) {
    const std::string file = NEPHELE_TEST_DATA "/scenes/full.json";
    json withDirection = fullScene();
    withDirection["camera"].erase("look_at");
    withDirection["camera"]["direction"] = {0, 1, 0};
    struct Field {
        json scene;
        json::json_pointer at;
        std::string path;
    };
    const Field directions[] = {
        {fullScene(), json::json_pointer("/camera/up"), "camera.up"},
        {withDirection, json::json_pointer("/camera/direction"), "camera.direction"},
        {fullScene(), json::json_pointer("/sun/direction"), "sun.direction"},
        {fullScene(), json::json_pointer("/skylight/direction"), "skylight.direction"},
    };
    // [0, 0, 1e-200] and [0, 0, 1e-39] read as the zero vector; 1e-7 is a float but too short
    // to be a direction (under 1e-6); 1e-5 is accepted (the bound is not tighter than it says).
    for (const Field& f : directions) {
        for (const json& tiny : {json{0, 0, 1e-200}, json{0, 0, 1e-39}, json{1e-7, 0, 1e-8}, json{0, 0, -1e-310}}) {
            SCOPED_TRACE(f.path + " = " + tiny.dump());
            json j = f.scene;
            j[f.at] = tiny;
            try {
                parseScene(j.dump(), file);
                ADD_FAILURE() << "accepted";
            } catch (const SceneError& e) {
                EXPECT_EQ(e.jsonPath(), f.path) << e.what();
            }
        }
        json j = f.scene;
        j[f.at] = {1e-5, 1e-5, 1e-5};
        EXPECT_NO_THROW(parseScene(j.dump(), file)) << f.path;
    }
    // look_at - position, of the camera and of path keyframes: zero in float, or too close
    // against the coordinates (float positions 9e6 m out differ by 1 m steps).
    for (const char* at : {"/camera", "/path/1"}) {
        for (const auto& [position, lookAt] : {std::pair{json{0, 0, 1200}, json{0, 0, 1200 + 1e-200}},
                                               std::pair{json{9e6, 0, 1200}, json{9e6 + 1e-3, 0, 1200}},
                                               std::pair{json{9e6, 0, 1200}, json{9e6, 0.5, 1200}}}) {
            SCOPED_TRACE(std::string(at) + " " + position.dump() + " -> " + lookAt.dump());
            json j = fullScene();
            j[json::json_pointer(at)]["position"] = position;
            j[json::json_pointer(at)]["look_at"] = lookAt;
            try {
                parseScene(j.dump(), file);
                ADD_FAILURE() << "accepted";
            } catch (const SceneError& e) {
                EXPECT_EQ(e.jsonPath(), std::string(at) == "/camera" ? "camera.look_at" : "path[1].look_at")
                    << e.what();
            }
        }
        json j = fullScene();  // 20 m apart at 9e6 m: accepted
        j[json::json_pointer(at)]["position"] = {9e6, 0, 1200};
        j[json::json_pointer(at)]["look_at"] = {9e6, 20, 1200};
        if (std::string(at) == "/camera") {
            EXPECT_NO_THROW(parseScene(j.dump(), file));
        }
    }
}

// ---------------------------------------------------------------- 4. one big generated cumulus

double processCpuSeconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);  // every thread's (the grid is made on all cores)
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

TEST(HostileCumulusTest, ARadianceGridCostsLittleMoreForManyEllipsoidsThanForFew) {
    // One cumulus entry of count 100000 took 7 minutes at 160x120 and its 100,000 ellipsoids
    // written out as clouds of their own 14 s: the cloud's radiance grid crossed every voxel of
    // its finer sun transmittance grid (64^3) with every ellipsoid, n^3 N. Now each ellipsoid
    // crosses the voxels in its shadow only. The grid of one cumulus of 20000 ellipsoids
    // (18405 after pruning) against that of 200 of them, the same 32^3 grid and photons (the
    // fixed part), CPU time: measured 10.1 s against 1.2 s, 8.5x; with every voxel crossing
    // every ellipsoid 31.8 s against 1.39 s, 23x. 13x sits between, with room for timing noise.
    Scene scene;
    Generator g;
    g.center = Vec3(0, 0, 1000);
    // Under the sanitizers the same code on 4,000 (their CPU is not the release build's: the
    // ratio is asserted there only).
    g.count = test::kSanitized ? 4000 : 20000;
    const Cloud many = generateCumulus(g);
    Cloud few = many;
    few.ellipsoids.resize(200);
    RadianceGridSettings s;
    s.fitToCloud = false;  // both 32^3, with all the photons
    double cpu[2];
    for (int k = 0; k < 2; ++k) {
        const double start = processCpuSeconds();
        const CloudRadiance grid = computeCloudRadiance(scene, k == 0 ? few : many, s);
        cpu[k] = processCpuSeconds() - start;
        ASSERT_GT(grid.size, 0);
    }
    std::cout << "radiance grid: " << few.ellipsoids.size() << " ellipsoids " << cpu[0] << " s CPU, "
              << many.ellipsoids.size() << " ellipsoids " << cpu[1] << " s CPU\n";
    if (!test::kSanitized) {
        EXPECT_LT(cpu[1], 13 * cpu[0]) << few.ellipsoids.size() << " ellipsoids: " << cpu[0] << " s; "
                                       << many.ellipsoids.size() << ": " << cpu[1] << " s";
    }
}

}  // namespace
}  // namespace nephele
