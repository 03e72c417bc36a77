// Shared by the *GLTest suites: a headless context per test suite and golden images.
#pragma once

#include "nephele/context.hpp"
#include "nephele/gl.hpp"
#include "nephele/camera.hpp"
#include "nephele/image.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

namespace nephele::test {

// A scene of data/scenes at `width` pixels wide (its aspect kept; 160x120 for the 4:3
// scenes): enough pixels per ellipsoid to measure, small enough for CI on llvmpipe.
inline Scene sharedScene(const std::string& name, int width = 160) {
    Scene s = loadScene(std::string(NEPHELE_SCENES) + "/" + name);
    const double aspect = double(s.camera.width) / s.camera.height;
    s.camera.width = width;
    s.camera.height = int(std::lround(width / aspect));
    return s;
}

// Makes a context of `backend` (checks on) or fails the test with the context's message.
inline std::unique_ptr<Context> makeContext(GlBackend backend) {
    ContextOptions o;
    o.backend = backend;
    o.visible = false;
    o.width = 64;
    o.height = 64;
    auto ctx = Context::create(o);
    gl::setChecks(true);
    return ctx;
}

// A test fixture with a headless EGL context per test (checks on).
class EglTest : public ::testing::Test {
protected:
    void SetUp() override { ctx_ = makeContext(GlBackend::Egl); }
    std::unique_ptr<Context> ctx_;
};

// A host's window: draws the scene's sky and objects, then `clouds(view, 0)`, into the
// default framebuffer of a hidden GLFW window the camera's size (needs a DISPLAY: the suite
// runs under xvfb-run) and reads it back as RGBA, top row first.
template <class DrawClouds>
Image renderInWindow(const Scene& scene, DrawClouds&& clouds) {
    ContextOptions o;
    o.backend = GlBackend::Glfw;
    o.visible = false;
    o.width = scene.camera.width;
    o.height = scene.camera.height;
    auto window = Context::create(o);
    gl::setChecks(true);
    GLint viewport[4];
    gl::glGetIntegerv(GL_VIEWPORT, viewport);
    const int w = viewport[2], h = viewport[3];
    EXPECT_EQ(w, scene.camera.width);
    EXPECT_EQ(h, scene.camera.height);
    const View view = makeView(scene.camera);
    OpaquePass().draw(scene, view, 0);
    clouds(view, GLuint(0));
    std::vector<float> bottomUp(std::size_t(w) * h * 4);
    gl::glReadBuffer(GL_BACK);
    gl::glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, bottomUp.data());
    Image image(w, h, 4);
    for (int y = 0; y < h; ++y)
        std::copy_n(bottomUp.data() + std::size_t(h - 1 - y) * w * 4, std::size_t(w) * 4,
                    image.pixels.data() + std::size_t(y) * w * 4);
    return image;
}

// Where tests write actual and diff images for a person to look at.
inline std::string outputDir() {
    const std::string dir = std::string(NEPHELE_TEST_OUTPUT);
    std::filesystem::create_directories(dir);
    return dir;
}

struct GoldenTolerance {
    double pixel;          // per-channel difference (in [0,1] of 8-bit sRGB) that counts a pixel as off
    double fractionOff;    // largest allowed fraction of pixels that are off
    double mean;           // largest allowed mean absolute difference over all channels
};

// Compares an sRGB-encoded rendering with tests/golden/NAME.png. On failure, or when the
// golden is missing, writes NAME[_TAG]_actual.png and NAME[_TAG]_diff.png to outputDir()
// and fails; tests/promote_golden.sh NAME [TAG] copies an actual image to golden after a
// person looked at it. TAG tells apart renderings (e.g. backends) that share one golden.
inline void expectMatchesGolden(const Image& linearRgb, const std::string& name, const GoldenTolerance& tol,
                                const std::string& tag = "") {
    const std::string stem = outputDir() + "/" + name + (tag.empty() ? "" : "_" + tag);
    const std::string actualPath = stem + "_actual.png";
    writePng(actualPath, linearRgb, Encoding::Srgb);
    const Image actual = readPng(actualPath);  // the 8-bit values as stored
    const std::string goldenPath = std::string(NEPHELE_GOLDEN) + "/" + name + ".png";
    if (!std::filesystem::exists(goldenPath)) {
        ADD_FAILURE() << "no golden image " << goldenPath << "; look at " << actualPath
                      << " and promote it with tests/promote_golden.sh " << name << " " << tag;
        return;
    }
    const Image golden = readPng(goldenPath);
    ASSERT_EQ(golden.width, actual.width);
    ASSERT_EQ(golden.height, actual.height);
    ASSERT_EQ(golden.channels, actual.channels);
    const ImageDifference d = compareImages(actual, golden, tol.pixel);
    const bool ok = d.fractionOver <= tol.fractionOff && d.meanAbs <= tol.mean;
    if (!ok) writePng(stem + "_diff.png", differenceImage(actual, golden, 8.0f), Encoding::Linear);
    else std::filesystem::remove(actualPath);
    EXPECT_TRUE(ok) << name << ": " << d.fractionOver * 100 << "% of pixels differ by more than " << tol.pixel * 255
                    << "/255 (allowed " << tol.fractionOff * 100 << "%), mean difference " << d.meanAbs * 255
                    << "/255 (allowed " << tol.mean * 255 << "/255), max " << d.maxAbs * 255
                    << "/255. Actual and diff images: " << outputDir();
}

}  // namespace nephele::test
