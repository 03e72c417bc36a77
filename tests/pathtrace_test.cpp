// The path-traced reference: its trackers against analytic transmittance, its opacity against
// the closed form of the format's field, energy conservation (white furnace), single
// scattering against quadrature, Monte Carlo convergence, determinism, objects in and under
// clouds, the noise path and the cache. Small images throughout (the file runs in seconds).
#include "nephele/pathtrace.hpp"

#include "../reference/src/tracking.hpp"
#include "cache_test_util.hpp"
#include "temp_dir.hpp"
#include "stats_test_util.hpp"
#include "pathtrace_hooks.hpp"

#include "nephele/gardner.hpp"
#include "nephele/gardner_model.hpp"
#include "cache_file.hpp"
#include "nephele/log.hpp"
#include "nephele/opaque.hpp"
#include "nephele/projection.hpp"

#include "test_build.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <span>
#include <thread>
#include <numbers>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

using namespace nephele;
using detail::MajorantPiece;
using detail::MajorantSegment;

namespace {

// One rotated ellipsoid (about 400 x 300 x 240 m) 450 m in front of the camera, filling most
// of the view; no noise.
Scene cloudScene(int width, int height) {
    Scene s;
    s.camera.position = {0, -450, 0};
    s.camera.direction = {0, 1, 0};
    s.camera.fovYDeg = 40;
    s.camera.width = width;
    s.camera.height = height;
    s.medium.noise = 0;
    s.medium.extinction = 0.02;
    Ellipsoid e;
    e.radii = {200, 150, 120};
    e.rotationDeg = {10, 20, 30};
    s.clouds.push_back({"one", {e}});
    return s;
}

// Optical depth of the field along o + t d over [t0, t1], closed form per ellipsoid.
double opticalDepth(const Scene& s, const Vec3& o, const Vec3& d, double t0, double t1) {
    double tau = 0;
    for (const Cloud& c : s.clouds)
        for (const Ellipsoid& e : c.ellipsoids) {
            const glm::dmat3 m = ellipsoidToUnit(e);
            tau += s.medium.extinction * e.density *
                   model::segmentDepth(glm::vec3(m * (o - e.center)), glm::vec3(m * d), float(t0),
                                       float(std::min(t1, 1e30)));
        }
    return tau;
}

// The cloud opacity of pixel (x, y) as the format defines it, up to the first object.
double exactAlpha(const Scene& s, const View& v, int x, int y) {
    const Vec3 d = v.rayDirection(x + 0.5, y + 0.5);
    const double c = glm::dot(d, v.forward);
    double t0 = v.camera.nearClip / c, t1 = v.camera.farClip / c;
    if (auto hit = intersectObjects(s, v.eye, d, t0, t1)) t1 = hit->distance;
    return 1 - std::exp(-opticalDepth(s, v.eye, d, t0, t1));
}

double rmse(const Image& a, const Image& b) {  // over rgb
    double sum = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int k = 0; k < 3; ++k) sum += std::pow(double(a.at(x, y, k)) - b.at(x, y, k), 2);
    return std::sqrt(sum / (3.0 * a.width * a.height));
}

using test::MeanAndError;
using test::meanOf;

double seconds(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// Delta tracking (fraction of flights without a collision) and ratio tracking (mean estimate)
// against the exact transmittance, within 3 standard errors each.
void checkTrackers(const char* what, std::span<const MajorantSegment> segs, const std::function<double(double)>& sigma,
                   double exact) {
    const int n = 200000;
    detail::Pcg32 rng(12345, 678);
    const MeanAndError delta =
        meanOf(n, [&](int) { return detail::deltaTrack(segs, sigma, rng) == detail::kNoCollision ? 1.0 : 0.0; });
    const MeanAndError ratio = meanOf(n, [&](int) { return detail::ratioTrack(segs, sigma, rng); });
    std::printf("[ figure ] %s: exact T %.5f, delta %.5f +- %.5f, ratio %.5f +- %.5f\n", what, exact, delta.mean,
                delta.error, ratio.mean, ratio.error);
    EXPECT_NEAR(delta.mean, exact, 3 * delta.error) << what;
    EXPECT_NEAR(ratio.mean, exact, 3 * ratio.error) << what;
}

}  // namespace

TEST(PathTraceTest, MajorantSumsOverlappingPieces) {
    const std::vector<MajorantPiece> pieces{{0, 4, 0.5}, {3, 9, 0.45}, {12, 13, 0.1}, {13, 14, 0.1}, {20, 21, 0}};
    std::vector<std::pair<double, double>> events;
    std::vector<MajorantSegment> segs;
    detail::buildMajorant(pieces, events, segs);
    ASSERT_EQ(segs.size(), 4u);  // [0,3] [3,4] [4,9] [12,14]: equal neighbours merge, empty pieces vanish
    const double expected[4][3] = {{0, 3, 0.5}, {3, 4, 0.95}, {4, 9, 0.45}, {12, 14, 0.1}};
    for (int i = 0; i < 4; ++i) {
        EXPECT_DOUBLE_EQ(segs[i].t0, expected[i][0]);
        EXPECT_DOUBLE_EQ(segs[i].t1, expected[i][1]);
        EXPECT_NEAR(segs[i].majorant, expected[i][2], 1e-9);
        EXPECT_GE(segs[i].majorant, expected[i][2]);
    }
}

TEST(PathTraceTest, TrackersMatchAHomogeneousSlab) {
    // sigma = 0.3 / m over [2, 7] m under an uneven majorant with null collisions around it.
    std::vector<std::pair<double, double>> events;
    std::vector<MajorantSegment> segs;
    const std::vector<MajorantPiece> pieces{{0, 4, 0.5}, {3, 9, 0.45}};
    detail::buildMajorant(pieces, events, segs);
    checkTrackers(
        "slab", segs, [](double t) { return t >= 2 && t <= 7 ? 0.3 : 0.0; }, std::exp(-0.3 * 5));
}

TEST(PathTraceTest, TrackersMatchAHomogeneousSphere) {
    // A ray along x at impact parameter 0.8 m through a sphere of radius 2 m centred 10 m ahead.
    const double sigma = 0.7, b = 0.8, r = 2;
    auto inside = [=](double t) { return (t - 10) * (t - 10) + b * b < r * r ? sigma : 0.0; };
    const double exact = std::exp(-sigma * 2 * std::sqrt(r * r - b * b));
    const std::vector<MajorantSegment> tight{{8, 12, sigma}}, loose{{5, 9, 1.5}, {9, 14, 0.9}};
    checkTrackers("sphere, tight majorant", tight, inside, exact);
    checkTrackers("sphere, loose majorant", loose, inside, exact);
}

TEST(PathTraceTest, AlphaIsTheClosedFormOfTheField) {
    Scene scene = cloudScene(32, 24);
    Object box;  // partly inside the cloud: its pixels see only the matter in front of it
    box.center = {30, -110, 10};
    box.size = {60, 60, 60};
    box.rotationDeg = {0, 0, 25};
    scene.objects.push_back(box);
    const View view = makeView(scene.camera);
    const Image image = renderPathTraced(scene, view, {.spp = 1, .maxBounces = 0}, nullptr);
    double worst = 0, largest = 0;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const double expected = exactAlpha(scene, view, x, y);
            worst = std::max(worst, std::fabs(image.at(x, y, 3) - expected));
            largest = std::max(largest, expected);
        }
    std::printf("[ figure ] alpha against closed form: max |diff| %.2e (largest alpha %.3f)\n", worst, largest);
    EXPECT_LT(worst, 1e-6);  // float segmentDepth on both sides; only the float cast of alpha differs
    EXPECT_GT(largest, 0.8);
}

TEST(PathTraceTest, WhiteFurnaceConservesEnergy) {
    // Albedo 1 under a uniform white sky and no sun: every path must come back with radiance 1.
    // Each path's estimate is exactly 1 unless maxBounces truncates it (set out of reach here), so
    // the estimator has zero variance and "a few standard errors" is float round-off.
    Scene scene = cloudScene(24, 18);
    scene.medium.albedo = 1;
    scene.medium.extinction = 0.05;  // optical depth about 8 through the centre
    scene.sky = {Vec3(1.0), Vec3(1.0), Vec3(1.0)};
    scene.sun.intensity = 0;
    const View view = makeView(scene.camera);
    const NoiseVolume volume = makeNoiseVolume(16, 4, 2, 3);
    for (double noise : {0.0, 0.5}) {
        scene.medium.noise = noise;
        const Image image = renderPathTraced(scene, view, {.spp = 8, .maxBounces = 1000000}, &volume);
        double sum = 0, worst = 0, alpha = 0;
        for (int y = 0; y < image.height; ++y)
            for (int x = 0; x < image.width; ++x) {
                for (int k = 0; k < 3; ++k) {
                    sum += image.at(x, y, k);
                    worst = std::max(worst, std::fabs(image.at(x, y, k) - 1.0));
                }
                alpha = std::max(alpha, double(image.at(x, y, 3)));
            }
        const double mean = sum / (3.0 * image.width * image.height);
        std::printf("[ figure ] white furnace (noise %.1f): mean radiance %.6f, max |L - 1| %.2e, max alpha %.3f\n",
                    noise, mean, worst, alpha);
        EXPECT_NEAR(mean, 1.0, 0.01);
        EXPECT_LT(worst, 1e-5);
        EXPECT_GT(alpha, 0.99);  // the cloud really is dense where it is seen
    }
}

TEST(PathTraceTest, SingleScatteringMatchesQuadrature) {
    // One pixel looking through a sphere of matter, lit by the sun only (black sky), one
    // scattering event: L = integral of T_view sigma_s p(theta) E T_sun dt.
    Scene scene = cloudScene(1, 1);
    scene.clouds[0].ellipsoids[0].radii = {120, 100, 90};
    scene.medium.extinction = 0.01;
    scene.medium.albedo = 0.9;
    scene.sky = {Vec3(0.0), Vec3(0.0), Vec3(0.0)};
    scene.sun.direction = glm::normalize(Vec3(0.2, 0.6, 0.5));
    scene.sun.intensity = 3;
    const View view = makeView(scene.camera);
    const Vec3 eye = view.eye, d = view.rayDirection(0.5, 0.5), l = scene.sun.direction;
    const Ellipsoid& e = scene.clouds[0].ellipsoids[0];
    const glm::dmat3 m = ellipsoidToUnit(e);
    const double g = scene.medium.hgG, cosTheta = glm::dot(d, l);
    const double phase = (1 - g * g) / (4 * std::numbers::pi * std::pow(1 + g * g - 2 * g * cosTheta, 1.5));
    double expected = 0;
    const int steps = 20000;
    const double t0 = 250, t1 = 650, dt = (t1 - t0) / steps;
    for (int i = 0; i < steps; ++i) {
        const double t = t0 + (i + 0.5) * dt;
        const Vec3 p = m * (eye + t * d - e.center);
        const double q = glm::dot(p, p);
        if (q >= 1) continue;
        const double sigmaS = scene.medium.albedo * scene.medium.extinction * (1 - q) * (1 - q);
        expected += std::exp(-opticalDepth(scene, eye, d, view.camera.nearClip, t)) * sigmaS * phase *
                    scene.sun.intensity * std::exp(-opticalDepth(scene, eye + t * d, l, 0, 1e30)) * dt;
    }
    const MeanAndError rendered = meanOf(16, [&](int k) {
        return double(renderPathTraced(scene, view, {.spp = 2000, .maxBounces = 0, .seed = unsigned(k + 1)}, nullptr)
                          .at(0, 0, 1));
    });
    std::printf("[ figure ] single scattering: quadrature %.6f, path traced %.6f +- %.6f\n", expected, rendered.mean,
                rendered.error);
    EXPECT_GT(expected, 0.01);
    EXPECT_NEAR(rendered.mean, expected, 3 * rendered.error);
}

TEST(PathTraceTest, ErrorFallsAsOneOverSqrtSpp) {
    const Scene scene = cloudScene(40, 30);
    const View view = makeView(scene.camera);
    auto start = std::chrono::steady_clock::now();
    const Image reference = renderPathTraced(scene, view, {.spp = 2048, .seed = 101}, nullptr);
    const double referenceSeconds = seconds(start);
    // Mean squared error over 8 independent renders per sample count: one render's RMSE over
    // so few pixels swings with the odd bright path.
    auto meanRmse = [&](int spp, unsigned seed0) {
        double mse = 0;
        for (unsigned k = 0; k < 8; ++k) {
            const double e = rmse(renderPathTraced(scene, view, {.spp = spp, .seed = seed0 + k}, nullptr), reference);
            mse += e * e / 8;
        }
        return std::sqrt(mse);
    };
    const double e16 = meanRmse(16, 1000), e64 = meanRmse(64, 2000);
    // The reference's own noise adds 1/2048 to both variances: the expected ratio is about 1.98.
    std::printf(
        "[ figure ] convergence: RMSE 16 spp %.5f, 64 spp %.5f, ratio %.3f (ideal 2); 2048 spp reference %.2f s\n", e16,
        e64, e16 / e64, referenceSeconds);
    EXPECT_GT(e16 / e64, 1.6);
    EXPECT_LT(e16 / e64, 2.5);
}

TEST(PathTraceTest, SameSeedSameImage) {
    const Scene scene = cloudScene(16, 12);
    const View view = makeView(scene.camera);
    const Image a = renderPathTraced(scene, view, {.spp = 4, .seed = 5}, nullptr);
    const Image b = renderPathTraced(scene, view, {.spp = 4, .seed = 5}, nullptr);
    const Image c = renderPathTraced(scene, view, {.spp = 4, .seed = 6}, nullptr);
    EXPECT_TRUE(a.pixels == b.pixels);
    EXPECT_FALSE(a.pixels == c.pixels);
}

TEST(PathTraceTest, ObjectInsideACloudIsSeenThroughTheMatterInFront) {
    // A purely absorbing cloud (albedo 0) under a black sky: the box's centre pixel is
    // lambert * T_sun with probability T_view (no collision before the box), else 0.
    Scene scene = cloudScene(9, 9);
    scene.clouds[0].ellipsoids[0].rotationDeg = Vec3(0.0);
    scene.medium.albedo = 0;
    scene.sky = {Vec3(0.0), Vec3(0.0), Vec3(0.0)};
    scene.sun.direction = glm::normalize(Vec3(0.3, -0.8, 0.5));
    Object box;
    box.center = {0, 0, 0};
    box.size = {40, 40, 40};
    box.color = {0.8, 0.6, 0.4};
    scene.objects.push_back(box);
    const View view = makeView(scene.camera);
    const int spp = 4000;
    const Image image = renderPathTraced(scene, view, {.spp = spp}, nullptr);
    const double tBox = -20 - view.eye.y;  // m, to the face y = -20
    const Vec3 d = view.rayDirection(4.5, 4.5), hitPoint = view.eye + tBox * d;
    const double tView = std::exp(-opticalDepth(scene, view.eye, d, view.camera.nearClip, tBox));
    const double tSun = std::exp(-opticalDepth(scene, hitPoint, scene.sun.direction, 0, 1e30));
    const Vec3 lambert = lambertRadiance(scene.sun, box.color, Vec3(0, -1, 0));
    const double expected = lambert.r * tSun * tView, error = lambert.r * tSun * std::sqrt(tView * (1 - tView) / spp);
    std::printf("[ figure ] box inside a cloud: radiance %.5f, expected %.5f +- %.5f; alpha %.5f, closed form %.5f\n",
                image.at(4, 4, 0), expected, error, image.at(4, 4, 3), 1 - tView);
    EXPECT_NEAR(image.at(4, 4, 0), expected, 3 * error);
    EXPECT_NEAR(image.at(4, 4, 3), 1 - tView, 1e-6);
    EXPECT_GT(1 - tView, 0.1);
    scene.objects.clear();  // without the box the ray crosses the whole cloud
    const Image open = renderPathTraced(scene, view, {.spp = 1}, nullptr);
    EXPECT_GT(open.at(4, 4, 3), image.at(4, 4, 3) + 0.05);
}

// A 9x9 image from `position` along `direction` of the smooth field (noise 0): the objects' tests.
static Scene nineByNine(const Vec3& position, const Vec3& direction) {
    Scene scene;
    scene.camera.position = position;
    scene.camera.direction = glm::normalize(direction);
    scene.camera.width = scene.camera.height = 9;
    scene.medium.noise = 0;
    return scene;
}

TEST(PathTraceTest, CloudShadowsAnObject) {
    // A box lit from above, a cloud between it and the sun, a camera that sees the box's top
    // face without looking through the cloud: the face's radiance is lambert * T_sun exactly.
    Scene scene = nineByNine({0, -300, 150}, {0, 300, -140});
    scene.sun.direction = glm::normalize(Vec3(0.1, 0.2, 1));
    Object box;
    box.size = {100, 100, 20};
    scene.objects.push_back(box);
    const View view = makeView(scene.camera);
    const Image bare = renderPathTraced(scene, view, {.spp = 4}, nullptr);
    Ellipsoid e;
    e.center = {40, 80, 400};
    e.radii = {150, 150, 80};
    scene.clouds.push_back({"shade", {e}});
    const Image shaded = renderPathTraced(scene, view, {.spp = 4}, nullptr);
    const Vec3 top = view.eye + (140.0 / std::fabs(view.rayDirection(4.5, 4.5).z)) * view.rayDirection(4.5, 4.5);
    const double tSun = std::exp(-opticalDepth(scene, top, scene.sun.direction, 0, 1e30));
    const double lambert = lambertRadiance(scene.sun, box.color, Vec3(0, 0, 1)).r;
    std::printf("[ figure ] cloud shadow: lit face %.5f without the cloud, %.5f under it (expected %.5f, T_sun %.4f)\n",
                bare.at(4, 4, 0), shaded.at(4, 4, 0), lambert * tSun, tSun);
    EXPECT_NEAR(bare.at(4, 4, 0), lambert, 1e-6);
    EXPECT_NEAR(shaded.at(4, 4, 0), lambert * tSun, 1e-5);
    EXPECT_LT(tSun, 0.5);
    EXPECT_EQ(shaded.at(4, 4, 3), 0.0f);  // the camera does not look through the cloud
}

TEST(PathTraceTest, ObjectsLitByAllLightReflectAUniformSkyTimesTheirAlbedo) {
    // object_light "all" under a sky and ground of one radiance L, no sun, no cloud: a convex
    // object's every bounce reaches the sky, so each path through a surface carries albedo * L
    // exactly (the cosine sampling's weight is the albedo), whatever the normal; with "sun"
    // the same object is black (no sun, no ambient term).
    Scene scene = nineByNine({0, -30, 8}, {0, 30, -6});
    scene.sun.intensity = 0;
    const Vec3 L(0.3, 0.5, 0.7);
    scene.sky.zenith = scene.sky.horizon = scene.sky.ground = L;
    Object sphere;
    sphere.type = Object::Type::Sphere;
    sphere.center = {0, 0, 2};
    sphere.radius = 12;
    sphere.color = {0.8, 0.4, 0.2};
    scene.objects.push_back(sphere);
    const View view = makeView(scene.camera);
    const Image sunOnly = renderPathTraced(scene, view, {.spp = 2}, nullptr);
    scene.objectLight = ObjectLight::All;
    const Image all = renderPathTraced(scene, view, {.spp = 2}, nullptr);
    int hits = 0;
    for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 9; ++x) {
            if (!intersectObjects(scene, view.eye, view.rayDirection(x + 0.5, y + 0.5), 0, 1e9)) continue;
            ++hits;
            for (int k = 0; k < 3; ++k) {
                EXPECT_EQ(sunOnly.at(x, y, k), 0.0f);
                EXPECT_NEAR(all.at(x, y, k), sphere.color[k] * L[k], 1e-6) << "pixel " << x << ", " << y;
            }
        }
    EXPECT_GT(hits, 20);
}

TEST(PathTraceTest, NoisePathIsUnbiasedOnAConstantVolume) {
    // A noise volume of constant 0.5 with amplitude 0.6 scales the field by exactly 1.3: the
    // tracking estimates (alpha by ratio tracking, radiance by delta and ratio tracking) must
    // agree with the noise-free closed form at 1.3 x the extinction.
    Scene noisy = cloudScene(1, 1);
    noisy.medium.noise = 0.6;
    NoiseVolume constant;
    constant.size = 2;
    constant.texels.assign(8, 0.5f);
    Scene smooth = noisy;
    smooth.medium.noise = 0;
    smooth.medium.extinction *= 1.3;
    const View view = makeView(noisy.camera);
    const double alpha = exactAlpha(smooth, view, 0, 0);
    auto render = [&](const Scene& s, int k) {
        return renderPathTraced(s, view, {.spp = 256, .seed = unsigned(k + 1)}, &constant);
    };
    const MeanAndError a = meanOf(16, [&](int k) { return double(render(noisy, k).at(0, 0, 3)); });
    const MeanAndError ln = meanOf(16, [&](int k) { return double(render(noisy, k).at(0, 0, 2)); });
    const MeanAndError ls = meanOf(16, [&](int k) { return double(render(smooth, k + 100).at(0, 0, 2)); });
    const double both = std::hypot(ln.error, ls.error);
    std::printf(
        "[ figure ] constant noise: alpha %.5f +- %.5f (closed form %.5f); blue %.5f +- %.5f vs smooth %.5f +- %.5f\n",
        a.mean, a.error, alpha, ln.mean, ln.error, ls.mean, ls.error);
    EXPECT_NEAR(a.mean, alpha, 3 * a.error + 1e-6);
    EXPECT_NEAR(ln.mean, ls.mean, 3 * both);
    EXPECT_THROW(renderPathTraced(noisy, view, {}, nullptr), std::invalid_argument);  // noise needs a volume
}

TEST(PathTraceTest, NoiseIsReadPerEllipsoidAtTheCompositorsOffsets) {
    // Two overlapping ellipsoids in two clouds, with the project's noise at full amplitude:
    // each ellipsoid's density is rho_i(x) max(0, 1 + noise n(x / P + o_i)), o_i =
    // ellipsoidNoiseOffset(cloud, index, seed) as the compositor and gardner-exact read it.
    // The reference's opacity (ratio tracking, unbiased) must match a fine quadrature of that
    // field along the pixel's ray, and must be told apart from the old field without offsets.
    Scene scene = cloudScene(1, 1);
    scene.medium.noise = 0.9;
    scene.medium.noiseScale = 40;
    scene.medium.extinction = 0.006;
    Ellipsoid second;
    second.center = {60, 80, -30};
    second.radii = {150, 180, 100};
    scene.clouds.push_back({"two", {second}});
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(32, ns.cells, 3, ns.seed);
    const View view = makeView(scene.camera);
    const Vec3 d = view.rayDirection(0.5, 0.5);
    const double period = scene.medium.noiseScale * ns.cells;
    auto quadrature = [&](bool offsets) {
        const double t0 = view.camera.nearClip / glm::dot(d, view.forward), t1 = 1200;
        const int n = 40000;
        double tau = 0;
        for (int k = 0; k < n; ++k) {
            const double t = t0 + (k + 0.5) * (t1 - t0) / n;
            const Vec3 x = view.eye + t * d;
            for (std::size_t c = 0; c < scene.clouds.size(); ++c) {
                const Ellipsoid& e = scene.clouds[c].ellipsoids[0];
                const Vec3 p = ellipsoidToUnit(e) * (x - e.center);
                const double q = glm::dot(p, p);
                if (q >= 1) continue;
                const Vec3 uvw = x / period + (offsets ? ellipsoidNoiseOffset(c, 0, ns.seed) : Vec3(0.0));
                tau += scene.medium.extinction * e.density * (1 - q) * (1 - q) *
                       std::max(0.0, 1 + scene.medium.noise * noise.sample(glm::vec3(uvw))) * (t1 - t0) / n;
            }
        }
        return 1 - std::exp(-tau);
    };
    const double withOffsets = quadrature(true), without = quadrature(false);
    const Image image = renderPathTraced(scene, view, {.spp = 16384, .maxBounces = 0}, &noise);
    // Ratio-tracking estimates of T lie in [0, 1]; their spread here is below 0.2, so 16384 of
    // them give a standard error below 0.2 / 128 = 0.0016: allow 3 of them, 0.005. The fields
    // with and without offsets differ by 0.014 in alpha here (measured), nearly 3 tolerances.
    std::printf("[ figure ] per-ellipsoid noise: reference alpha %.4f, quadrature with offsets %.4f, without %.4f\n",
                image.at(0, 0, 3), withOffsets, without);
    EXPECT_NEAR(image.at(0, 0, 3), withOffsets, 0.005);
    EXPECT_GT(std::fabs(withOffsets - without), 0.01);  // the test can tell the two fields apart
}

TEST(PathTraceTest, CacheHitsAndMisses) {
    const std::filesystem::path dir = test::freshProcessDir("nephele_pathtrace_cache_", false);
    Scene scene = cloudScene(12, 9);
    scene.objects.push_back(Object{});
    const PathTraceSettings settings{.spp = 2};
    const std::uint64_t before = detail::pathTracedImagesComputed();
    const Image first = renderPathTracedCached(scene, makeView(scene.camera), settings, nullptr, dir.string());
    EXPECT_EQ(detail::pathTracedImagesComputed(), before + 1);
    const auto start = std::chrono::steady_clock::now();
    PathTraceSettings quiet = settings;
    quiet.progress = true;  // not part of the key
    const Image second = renderPathTracedCached(scene, makeView(scene.camera), quiet, nullptr, dir.string());
    std::printf("[ figure ] cache hit in %.2f ms\n", 1e3 * seconds(start));
    EXPECT_EQ(detail::pathTracedImagesComputed(), before + 1);  // not recomputed
    EXPECT_TRUE(first.pixels == second.pixels);
    // Every change below must miss (and compute) once.
    const std::vector<std::pair<const char*, std::function<void(Scene&, PathTraceSettings&)>>> changes{
        {"spp", [](Scene&, PathTraceSettings& s) { s.spp = 3; }},
        {"maxBounces", [](Scene&, PathTraceSettings& s) { s.maxBounces = 5; }},
        {"firstBounce", [](Scene&, PathTraceSettings& s) { s.firstBounce = 1; }},
        {"seed", [](Scene&, PathTraceSettings& s) { s.seed = 9; }},
        {"camera", [](Scene& c, PathTraceSettings&) { c.camera.fovYDeg = 41; }},
        {"sun", [](Scene& c, PathTraceSettings&) { c.sun.intensity = 2.5; }},
        {"sky", [](Scene& c, PathTraceSettings&) { c.sky.ground.g = 0.2; }},
        {"medium", [](Scene& c, PathTraceSettings&) { c.medium.hgG = 0.8; }},
        {"ellipsoid", [](Scene& c, PathTraceSettings&) { c.clouds[0].ellipsoids[0].radii.y = 151; }},
        {"object", [](Scene& c, PathTraceSettings&) { c.objects[0].color.b = 0.9; }},
        {"object_light", [](Scene& c, PathTraceSettings&) { c.objectLight = ObjectLight::All; }},
    };
    std::uint64_t expected = before + 1;
    for (const auto& [what, change] : changes) {
        Scene s = scene;
        PathTraceSettings p = settings;
        change(s, p);
        renderPathTracedCached(s, makeView(s.camera), p, nullptr, dir.string());
        EXPECT_EQ(detail::pathTracedImagesComputed(), ++expected) << what << " did not miss the cache";
    }
    // A corrupt file is recomputed, not trusted.
    for (const auto& f : std::filesystem::directory_iterator(dir)) std::filesystem::resize_file(f.path(), 40);
    const Image again = renderPathTracedCached(scene, makeView(scene.camera), settings, nullptr, dir.string());
    EXPECT_EQ(detail::pathTracedImagesComputed(), ++expected);
    EXPECT_TRUE(again.pixels == first.pixels);
    std::filesystem::remove_all(dir);
}

// The orders 0..k plus the orders k+1..n, with the same seed, are the image with maxBounces n:
// what the accuracy bench's reference relies on to trace the high orders apart
// (bench/accuracy_reference.cpp).
TEST(PathTraceTest, ScatteringOrdersSplitExactly) {
    Scene scene = cloudScene(16, 12);
    scene.medium.extinction = 0.05;  // optical depth about 12 through the centre: many orders
    const View view = makeView(scene.camera);
    const Image all = renderPathTraced(scene, view, {.spp = 4, .maxBounces = 40}, nullptr);
    const Image low = renderPathTraced(scene, view, {.spp = 4, .maxBounces = 5}, nullptr);
    const Image high = renderPathTraced(scene, view, {.spp = 4, .maxBounces = 40, .firstBounce = 6}, nullptr);
    double worst = 0, highSum = 0, allSum = 0;
    for (std::size_t i = 0; i < all.pixels.size(); ++i) {
        if (i % 4 == 3) {
            EXPECT_EQ(high.pixels[i], all.pixels[i]);  // the opacity along the primary ray is every order's
            continue;
        }
        worst = std::max(worst, double(std::fabs(all.pixels[i] - (low.pixels[i] + high.pixels[i]))));
        highSum += high.pixels[i], allSum += all.pixels[i];
    }
    std::printf("[ figure ] orders 6-40 carry %.1f%% of the light; |all - (low + high)| <= %.1e\n",
                100 * highSum / allSum, worst);
    EXPECT_LT(worst, 1e-5);             // float images of double sums: round-off (radiances are O(1))
    EXPECT_GT(highSum, 0.01 * allSum);  // the split is not trivially empty
}

// The default maxBounces holds all the light of deep matter. The path tracer is the reference
// every method is measured against; until 2026-12-03 it stopped at 32 scattering events, which
// left out 4% of the light 100 m under a deck of optical depth about 15 (the accuracy bench's
// references are now its orders 0-32 plus the rest traced apart).
TEST(PathTraceTest, TheDefaultBouncesHoldTheLightOfDeepMatter) {
    Scene scene = cloudScene(12, 9);
    scene.medium.extinction = 0.5;  // optical depth about 120 through the centre (at 0.15, 36: 1.3% past 32)
    const View view = makeView(scene.camera);
    auto share = [&](int first) {  // of the orders first.. (to 20000) in the image of them all
        const Image all = renderPathTraced(scene, view, {.spp = 64, .maxBounces = 20000}, nullptr);
        const Image past =
            renderPathTraced(scene, view, {.spp = 64, .maxBounces = 20000, .firstBounce = first}, nullptr);
        double a = 0, p = 0;
        for (std::size_t i = 0; i < all.pixels.size(); ++i)
            if (i % 4 != 3) a += all.pixels[i], p += past.pixels[i];
        return p / a;
    };
    const double past32 = share(33), pastDefault = share(PathTraceSettings{}.maxBounces + 1);
    std::printf(
        "[ figure ] a cloud of optical depth 120: the orders past 32 carry %.2f%% of the light, past %d %.4f%%\n",
        100 * past32, PathTraceSettings{}.maxBounces, 100 * pastDefault);
    EXPECT_GT(past32, 0.03);       // deep enough that the old default lost light (measured 7.5%)
    EXPECT_LT(pastDefault, 1e-4);  // the default loses none that shows
}

TEST(PathTraceTest, RejectsBadSettings) {
    const Scene scene = cloudScene(4, 3);
    const View view = makeView(scene.camera);
    EXPECT_THROW(renderPathTraced(scene, view, {.spp = 0}, nullptr), std::invalid_argument);
    EXPECT_THROW(renderPathTraced(scene, view, {.maxBounces = -1}, nullptr), std::invalid_argument);
    EXPECT_THROW(renderPathTraced(scene, view, {.maxBounces = 4, .firstBounce = 5}, nullptr), std::invalid_argument);
    EXPECT_THROW(renderPathTraced(scene, view, {.firstBounce = -1}, nullptr), std::invalid_argument);
}

// Graded majorants (detail::chordPieces) on an optically deep chord: they bound the field
// everywhere, delta tracking's first collisions follow the exact distribution 1 - exp(-tau(t)),
// and a free flight takes a few tentative collisions where uniform pieces took ~bound^(2/3).
TEST(PathTraceTest, GradedMajorantsAreTightAndUnbiasedOnDeepChords) {
    // A chord through the centre of a unit sphere (a = 1) from t = 0 to 2 m: u = t - 1.
    const detail::Chord chord{0, 2, 1, 1, 1};
    auto depth = [](double bound, double t) {  // integral of bound (1 - u^2)^2 du from u = -1
        auto f = [](double u) { return u - 2 * u * u * u / 3 + std::pow(u, 5) / 5; };
        return bound * (f(t - 1) - f(-1));
    };
    for (double bound : {2e4, 1e12}) {
        auto sigma = [&](double t) {
            const double h = 1 - (t - 1) * (t - 1);
            return h > 0 ? bound * h * h : 0.0;
        };
        std::vector<double> breaks;
        std::vector<MajorantPiece> pieces;
        detail::chordPieces(chord, bound, breaks, pieces);
        EXPECT_GT(pieces.size(), std::size_t(detail::kPieces)) << "graded";
        for (const MajorantPiece& p : pieces)  // the bound holds at 1000 points of each piece
            for (int k = 0; k <= 1000; ++k) EXPECT_LE(sigma(p.t0 + (p.t1 - p.t0) * k / 1000), p.bound * (1 + 1e-12));
        std::vector<std::pair<double, double>> events;
        std::vector<MajorantSegment> segs;
        detail::buildMajorant(pieces, events, segs);
        detail::Pcg32 rng(99, 7);
        long evaluations = 0;
        auto counted = [&](double t) {
            ++evaluations;
            return sigma(t);
        };
        const int n = 20000;
        // At t where the exact CDF is 0.25, 0.5 and 0.75 (found by bisection on depth()).
        double at[3];
        for (int q = 0; q < 3; ++q) {
            double lo = 0, hi = 1;
            for (int it = 0; it < 200; ++it) {
                const double mid = 0.5 * (lo + hi);
                (1 - std::exp(-depth(bound, mid)) < 0.25 * (q + 1) ? lo : hi) = mid;
            }
            at[q] = lo;
        }
        int below[3] = {0, 0, 0};
        for (int i = 0; i < n; ++i) {
            const double t = detail::deltaTrack(segs, counted, rng);
            for (int q = 0; q < 3; ++q) below[q] += t < at[q];
        }
        for (int q = 0; q < 3; ++q) {
            // Binomial standard error sqrt(p (1 - p) / n) <= 0.0035; 4 of them.
            EXPECT_NEAR(below[q] / double(n), 0.25 * (q + 1), 0.014) << "bound " << bound << ", quartile " << q + 1;
        }
        const double perFlight = double(evaluations) / n;
        std::printf("[ figure ] bound %.0e: %zu pieces, %.1f tentative collisions per free flight\n", bound,
                    pieces.size(), perFlight);
        // Uniform pieces take about 10^3 (bound 2e4) and 10^8 (bound 1e12) per flight.
        EXPECT_LT(perFlight, 20) << bound;
    }
}

// Ratio tracking's Russian roulette below kRouletteBelow keeps it unbiased: on a homogeneous
// slab of optical depth 26 (T = 5.1e-12, under the roulette's threshold) the mean estimate is
// the exact transmittance. (A majorant of 10 sigma: ratio tracking's own relative variance is
// exp(sigma^2 L / majorant) - 1, so a loose majorant keeps the error small enough to see a bias.)
TEST(PathTraceTest, RatioTrackingRouletteIsUnbiased) {
    const double sigma = 1, length = 26, exact = std::exp(-26.0);
    const std::vector<MajorantSegment> segs{{0, length, 10 * sigma}};
    detail::Pcg32 rng(5, 11);
    const MeanAndError m = meanOf(200000, [&](int) {
        return detail::ratioTrack(
            segs, [&](double) { return sigma; }, rng);
    });
    std::printf("[ figure ] roulette: exact %.3e, ratio %.3e +- %.1e\n", exact, m.mean, m.error);
    EXPECT_NEAR(m.mean, exact, 4 * m.error);
    EXPECT_LT(m.error, 0.03 * exact);  // the test can see a bias of a few percent
}

// Whatever Scene it is given, the path tracer ends in bounded time: densities of 1e12, an
// extinction of 1e308 and the densest noisy medium render at 16x12 in well under the bound
// (each took under 2 s here, 10^8 tentative collisions a free flight before), opaque where
// the cloud is and finite everywhere; a noise it cannot bound is refused by name.
TEST(PathTraceTest, HugeDensitiesFinishInBoundedTime) {
    const NoiseVolume volume = makeNoiseVolume(16, 4, 2, 3);
    struct Case {
        const char* what;
        double extinction, density, noise;
    };
    for (const Case& c :
         {Case{"density 1e12", 0.04, 1e12, 0}, Case{"extinction 1e308", 1e308, 1, 0},
          Case{"extinction 1e308, density 1e300", 1e308, 1e300, 0}, Case{"density 1e12, noise 1", 0.04, 1e12, 1}}) {
        Scene scene = cloudScene(16, 12);
        scene.medium.extinction = c.extinction;
        scene.medium.noise = c.noise;
        scene.clouds[0].ellipsoids[0].density = c.density;
        const auto start = std::chrono::steady_clock::now();
        const Image image = renderPathTraced(scene, makeView(scene.camera), {.spp = 4, .maxBounces = 32}, &volume);
        const double took = seconds(start);
        std::printf("[ figure ] %s: %.2f s\n", c.what, took);
        EXPECT_LT(took, 60.0) << c.what;  // a bound for a loaded 2-core machine, not a performance claim
        for (std::size_t i = 0; i < image.pixels.size(); ++i)
            ASSERT_TRUE(std::isfinite(image.pixels[i])) << c.what << " at " << i << ": " << image.pixels[i];
        EXPECT_GT(image.at(8, 6, 3), 0.999f) << c.what;  // the cloud fills the centre: opaque
    }
    Scene scene = cloudScene(8, 6);
    scene.medium.noise = 1e308;
    try {
        renderPathTraced(scene, makeView(scene.camera), {.spp = 1}, &volume);
        ADD_FAILURE() << "noise 1e308 rendered";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("medium.noise"), std::string::npos) << e.what();
    }
}

// The estimate comes before the work, from a pilot, and is in the right range: within a
// factor of 3 of what the render costs. Both are CPU time shared among the render's threads
// (the estimate is for an otherwise idle machine: wall time on a shared one would be longer).
TEST(PathTraceTest, EstimatesItsTimeBeforeItStarts) {
    const Scene scene = cloudScene(160, 120);  // about 0.2 s of CPU here: long enough to time
    const View view = makeView(scene.camera);
    const PathTraceSettings settings{.spp = 32};
    const double estimate = estimatePathTraceSeconds(scene, view, settings, nullptr);
    auto processCpu = [] {
        rusage u{};
        ::getrusage(RUSAGE_SELF, &u);
        return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
    };
    const double before = processCpu();
    renderPathTraced(scene, view, settings, nullptr);
    const int threads = std::max(1, std::min<int>(scene.camera.height, int(std::thread::hardware_concurrency())));
    const double took = (processCpu() - before) / threads;
    std::printf("[ figure ] estimated %.2f s, took %.2f s of CPU per thread\n", estimate, took);
    // Under the sanitizers the pilot's sparse rows pay each row's fixed cost (ASan's allocator)
    // for an eighth of the pixels: measured 1.8x (alone) to 3.5x (beside another test) over.
    const double factor = test::kSanitized ? 6 : 3;
    EXPECT_GT(estimate, took / factor);
    EXPECT_LT(estimate, took * factor);
}

// A cache file with its last 4 KiB overwritten, with a NaN, truncated or replaced by a FIFO
// is never used: the image is rendered again (the same image), with a warning through the log
// callback, and the FIFO does not block.
TEST(PathTraceTest, DamagedCacheFilesAreRenderedAgainWithAWarning) {
    const std::filesystem::path dir = test::freshProcessDir("nephele_pathtrace_damaged_", false);
    const Scene scene = cloudScene(40, 30);  // 19 kB of floats
    const View view = makeView(scene.camera);
    const PathTraceSettings settings{.spp = 1};
    const Image good = renderPathTracedCached(scene, view, settings, nullptr, dir.string());
    std::filesystem::path file;
    for (const auto& e : std::filesystem::directory_iterator(dir)) file = e.path();
    test::WarningCapture log;
    auto expectRenderedAgain = [&](const char* what) {
        log.warnings.clear();
        const std::uint64_t computed = detail::pathTracedImagesComputed();
        const Image again = renderPathTracedCached(scene, view, settings, nullptr, dir.string());
        EXPECT_EQ(detail::pathTracedImagesComputed(), computed + 1) << what << ": the damaged file was used";
        EXPECT_TRUE(again.pixels == good.pixels) << what;
        ASSERT_FALSE(log.warnings.empty()) << what;
        EXPECT_NE(log.warnings[0].find(file.filename().string()), std::string::npos) << log.warnings[0];
    };
    test::overwriteTail(file, 4096, '\x7f');
    expectRenderedAgain("last 4 KiB overwritten");
    // A NaN under a valid checksum (what a faulty writer would leave): the values are checked too.
    std::string why;
    std::string payload = *cache::read(file.string(), 1 << 20, why);
    const float nan = NAN;
    std::memcpy(payload.data() + payload.size() - 8 * sizeof(float), &nan, sizeof nan);
    ASSERT_EQ(cache::write(file.string(), payload), "");
    expectRenderedAgain("a NaN");
    std::filesystem::resize_file(file, std::filesystem::file_size(file) - 100);
    expectRenderedAgain("truncated");
    ASSERT_TRUE(test::replaceWithFifo(file));
    expectRenderedAgain("a FIFO");
    std::filesystem::remove_all(dir);
}
