// `--method auto` through the command line is the compositor on a scene without layers
// (near_lod_gl_test.cpp has the near LOD through the library).
#include "cli_run.hpp"
#include "gl_test_util.hpp"
#include "test_build.hpp"

#include "nephele/image.hpp"
#include "nephele/png.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

using namespace nephele;

namespace {

class NearLodGLTest : public test::EglTest {};

}  // namespace

TEST_F(NearLodGLTest, AutoWithoutLayersIsTheCompositor) {
    // Through the command line: the same PNG with --method auto --cloud-lod off and --method
    // ellipsoid (auto's composite is the compositor's default, back to front). With auto's far
    // clouds as impostors (its default) within a level of 8 bits: a fresh impostor is its tiles'
    // image to the RGBA16F image's rounding (CloudLodGLTest.AFreshImpostorIsItsTiles).
    const std::string dir = test::outputDir();
    const std::string scene = std::string(NEPHELE_SCENES) + "/two_clouds.json";
    auto render = [&](const std::string& method) {
        std::string name = method;
        std::replace(name.begin(), name.end(), ' ', '_');
        const std::string out = dir + "/near_lod_auto_vs_" + name + ".png";
        std::filesystem::remove(out);
        const test::CliResult r =
            test::runCli("render " + scene + " -o " + out + " --method " + method + " --width 128");
        EXPECT_EQ(r.code, 0) << r.output;
        return readPng(out);
    };
    const Image a = render("auto --cloud-lod off"), e = render("ellipsoid"), lod = render("auto");
    ASSERT_EQ(a.pixels.size(), e.pixels.size());
    EXPECT_TRUE(a.pixels == e.pixels);
    ASSERT_EQ(lod.pixels.size(), e.pixels.size());
    float worst = 0;
    for (std::size_t i = 0; i < e.pixels.size(); ++i) worst = std::max(worst, std::abs(lod.pixels[i] - e.pixels[i]));
    EXPECT_LE(worst, 1.5f / 255) << "auto's impostors against the tiles";
}
