// Core pieces that need no GL: image files and metrics, view maths, the CPU opaque reference.
#include "nephele/camera.hpp"
#include "nephele/image.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"
#include "parallel.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <thread>

#include <sched.h>
#include <sys/resource.h>

using namespace nephele;

namespace {

std::string tempPath(const std::string& name) {
    return (std::filesystem::temp_directory_path() / ("nephele_core_test_" + name)).string();
}

Image gradient(int w, int h, int c) {
    Image img(w, h, c);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < c; ++k) img.at(x, y, k) = float((x * 7 + y * 13 + k * 50) % 256) / 255.0f;
    return img;
}

TEST(ImageTest, SrgbRoundTripAndKnownValues) {
    EXPECT_FLOAT_EQ(linearToSrgb(0.0f), 0.0f);
    EXPECT_FLOAT_EQ(linearToSrgb(1.0f), 1.0f);
    EXPECT_NEAR(linearToSrgb(0.5f), 0.7353569f, 1e-6);  // IEC 61966-2-1
    EXPECT_NEAR(linearToSrgb(0.002f), 0.02584f, 1e-6);  // linear segment
    for (float v = 0; v <= 1.0f; v += 0.01f) EXPECT_NEAR(srgbToLinear(linearToSrgb(v)), v, 1e-5);
}

TEST(ImageTest, PngStoresValuesExactlyAt8Bits) {
    for (int c : {1, 3, 4}) {
        const Image img = gradient(13, 7, c);  // values are multiples of 1/255
        const std::string path = tempPath("png" + std::to_string(c) + ".png");
        writePng(path, img, Encoding::Linear);
        const Image back = readPng(path);
        ASSERT_EQ(back.channels, c);
        EXPECT_EQ(compareImages(img, back, 1e-6).maxAbs, 0.0);
        std::remove(path.c_str());
    }
}

TEST(ImageTest, PngSrgbEncodesColourNotAlpha) {
    Image img(1, 1, 4);
    img.pixels = {0.5f, 0.5f, 0.5f, 0.5f};
    const std::string path = tempPath("srgb.png");
    writePng(path, img, Encoding::Srgb);
    const Image back = readPng(path);
    EXPECT_NEAR(back.pixels[0], 188 / 255.0f, 1e-6);  // round(0.7354 * 255) = 188
    EXPECT_NEAR(back.pixels[3], 128 / 255.0f, 1e-6);  // alpha stays linear: round(127.5) = 128
    std::remove(path.c_str());
}

TEST(ImageTest, PfmRoundTripIsExactAndTopRowFirst) {
    Image img = gradient(5, 3, 3);
    img.at(0, 0, 0) = 12.5f;  // HDR values survive
    const std::string path = tempPath("img.pfm");
    writePfm(path, img);
    const Image back = readPfm(path);
    EXPECT_EQ(compareImages(img, back, 0).maxAbs, 0.0);
    EXPECT_EQ(back.at(0, 0, 0), 12.5f);
    std::remove(path.c_str());
}

TEST(ImageTest, UnwritablePathIsAClearError) {
    try {
        writePng("/nonexistent-folder/x.png", gradient(2, 2, 3));
        FAIL();
    } catch (const ImageError& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent-folder/x.png: cannot open"), std::string::npos);
    }
}

TEST(ImageTest, MetricsOnKnownImages) {
    Image a(10, 10, 1, 0.5f), b = a;
    EXPECT_TRUE(std::isinf(psnr(a, b)));
    b.at(3, 3, 0) = 0.6f;  // one pixel off by 0.1: MSE = 0.01 / 100
    EXPECT_NEAR(psnr(a, b), 10 * std::log10(1.0 / 1e-4), 1e-4);
    const ImageDifference d = compareImages(a, b, 0.05);
    EXPECT_NEAR(d.maxAbs, 0.1, 1e-6);
    EXPECT_NEAR(d.meanAbs, 0.001, 1e-7);
    EXPECT_DOUBLE_EQ(d.fractionOver, 0.01);
    EXPECT_THROW(compareImages(a, Image(10, 9, 1), 0), ImageError);
}

Camera testCamera() {
    Camera c;
    c.position = {10, -20, 30};
    c.direction = glm::normalize(Vec3(0.2, 1.0, -0.1));
    c.fovYDeg = 60;
    c.width = 200;
    c.height = 100;
    return c;
}

TEST(CameraTest, RaysSpanTheFieldOfView) {
    const View v = makeView(testCamera());
    EXPECT_NEAR(glm::length(v.rayDirection(100, 50) - v.forward), 0, 1e-12);
    // The top edge of the image is half the vertical fov above the axis.
    const Vec3 top = v.rayDirection(100, 0);
    EXPECT_NEAR(glm::degrees(std::acos(glm::dot(top, v.forward))), 30.0, 1e-9);
    EXPECT_GT(glm::dot(top, v.up), 0);
    // The right edge: atan(aspect * tan(30 deg)).
    const Vec3 right = v.rayDirection(200, 50);
    EXPECT_NEAR(std::acos(glm::dot(right, v.forward)), std::atan(2.0 * std::tan(glm::radians(30.0))), 1e-9);
    EXPECT_GT(glm::dot(right, v.right), 0);
}

TEST(CameraTest, ProjectionAgreesWithRays) {
    // A point along a pixel's ray projects back onto that pixel's centre.
    const View v = makeView(testCamera());
    for (auto [px, py] : {std::pair{10.5, 20.5}, {199.5, 0.5}, {100.5, 50.5}}) {
        const Vec3 p = v.eye + 500.0 * v.rayDirection(px, py);
        const glm::dvec4 clip = v.projectionMatrix * v.viewMatrix * glm::dvec4(p, 1.0);
        EXPECT_NEAR((clip.x / clip.w * 0.5 + 0.5) * 200, px, 1e-7);
        EXPECT_NEAR((0.5 - clip.y / clip.w * 0.5) * 100, py, 1e-7);
    }
}

TEST(CameraTest, UpParallelToViewIsRejected) {
    Camera c = testCamera();
    c.direction = {0, 0, -1};
    EXPECT_THROW(makeView(c), std::invalid_argument);
}

TEST(OpaqueCpuTest, SkyFormula) {
    const Sky sky;
    EXPECT_LT(glm::length(skyRadiance(sky, {0, 0, 1}) - sky.zenith), 1e-12);
    EXPECT_EQ(skyRadiance(sky, {1, 0, 0}), sky.horizon);
    EXPECT_EQ(skyRadiance(sky, {0, 0.6, -0.8}), sky.ground);
    const Vec3 mid = skyRadiance(sky, {0, 0.6, 0.8});
    EXPECT_NEAR(mid.b, sky.horizon.b + 0.8 * (sky.zenith.b - sky.horizon.b), 1e-12);
}

TEST(OpaqueCpuTest, WhitePlaneFacingTheSunReflectsIntensityOverPi) {
    const Sun sun;  // defaults: colour 1, intensity 3
    const Vec3 l = lambertRadiance(sun, Vec3(1.0), sun.direction);
    EXPECT_NEAR(l.r, 3.0 / std::numbers::pi, 1e-12);
    EXPECT_EQ(lambertRadiance(sun, Vec3(1.0), -sun.direction), Vec3(0.0));
}

TEST(OpaqueCpuTest, RayHitsNearestObjectWithOutwardNormal) {
    Scene s;
    Object sphere;
    sphere.type = Object::Type::Sphere;
    sphere.center = {0, 10, 0};
    sphere.radius = 2;
    Object box;
    box.type = Object::Type::Box;
    box.center = {0, 20, 0};
    box.size = {4, 4, 4};
    box.rotationDeg = {0, 0, 45};
    s.objects = {box, sphere};
    auto hit = intersectObjects(s, Vec3(0.0), {0, 1, 0}, 0, 1e9);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->distance, 8.0, 1e-12);
    EXPECT_NEAR(hit->normal.y, -1.0, 1e-12);
    // Past the sphere, the box rotated 45 degrees: its corner at y = 20 - 2*sqrt(2).
    hit = intersectObjects(s, {0, 13, 0}, {0, 1, 0}, 0, 1e9);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->distance, 7.0 - 2.0 * std::sqrt(2.0), 1e-9);
    // From inside the sphere, its far side.
    hit = intersectObjects(s, {0, 10, 0}, {1, 0, 0}, 0, 1e9);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->distance, 2.0, 1e-12);
    EXPECT_FALSE(intersectObjects(s, Vec3(0.0), {0, -1, 0}, 0, 1e9));
}

}  // namespace

// The background workers (radiance grids, layer lighting) run below every normal thread:
// SCHED_IDLE, else nice 19; the thread that asks only, not the process.
TEST(ParallelTest, ABackgroundThreadRunsBelowTheFrame) {
    int policy = -1, nice = 0;
    std::thread([&] {
        nephele::makeThisThreadBackground();
        policy = sched_getscheduler(0);
        nice = getpriority(PRIO_PROCESS, 0);
    }).join();
    EXPECT_TRUE(policy == SCHED_IDLE || nice == 19) << "policy " << policy << ", nice " << nice;
    EXPECT_EQ(sched_getscheduler(0), SCHED_OTHER);  // the calling thread is untouched
}
