// The shared Gardner model (shaders/gardner_model.glsl compiled as C++) against numerical
// integration of the format's density field, and the exact CPU renderer's bookkeeping; the
// colour terms (diffuse reflectance, environment ambient); and the ray-marcher's shared light
// model (shaders/raymarch_model.glsl, header-only, so no GL and no nephele_volume needed).
#include "nephele/gardner.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"
#include "nephele/camera.hpp"

#include "../volume/include/nephele/raymarch_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <iostream>
#include <random>

using namespace nephele;

namespace {

// Midpoint rule of density (1 - q)^2 along the ray over [t0, t1], in double.
double integrate(const Ellipsoid& e, const Vec3& o, const Vec3& d, double t0, double t1, int steps = 200000) {
    const glm::dmat3 m = ellipsoidToUnit(e);
    double sum = 0;
    const double dt = (t1 - t0) / steps;
    for (int i = 0; i < steps; ++i) {
        const Vec3 p = m * (o + (t0 + (i + 0.5) * dt) * d - e.center);
        const double q = glm::dot(p, p);
        if (q < 1) sum += (1 - q) * (1 - q);
    }
    return sum * dt;
}

TEST(GardnerModelTest, SegmentDepthMatchesNumericalIntegration) {
    std::mt19937 rng(3);
    auto u = [&](double lo, double hi) { return lo + (hi - lo) * double(rng() >> 5) * 0x1.0p-27; };
    for (int k = 0; k < 40; ++k) {
        Ellipsoid e;
        e.center = {u(-500, 500), u(-500, 500), u(1000, 2000)};
        e.radii = {u(50, 400), u(50, 400), u(50, 300)};
        e.rotationDeg = {u(0, 360), u(0, 360), u(0, 360)};
        // Rays from outside through the ellipsoid, and from inside it.
        const bool inside = k % 4 == 0;
        const Vec3 target = e.center + Vec3(u(-0.5, 0.5), u(-0.5, 0.5), u(-0.5, 0.5)) * e.radii;
        const Vec3 origin = inside ? e.center + rotationFromDegrees(e.rotationDeg) * (0.3 * e.radii)
                                   : target - glm::normalize(Vec3(u(-1, 1), u(-1, 1), u(-1, 1))) * u(1000, 3000);
        const Vec3 d = glm::normalize(target - origin);
        const double t1 = glm::length(target - origin) + 1500;
        const glm::dmat3 m = ellipsoidToUnit(e);
        const glm::vec3 o(m * (origin - e.center)), du(m * d);
        for (double cut : {0.0, 0.4}) {  // the whole ray, and from part way along it
            const double t0 = cut * glm::length(target - origin);
            const double exact = integrate(e, origin, d, t0, t1);
            const double model = model::segmentDepth(o, du, float(t0), float(t1));
            EXPECT_NEAR(model, exact, 1e-3 * std::max(1.0, exact)) << "case " << k << " cut " << cut;
        }
    }
}

TEST(GardnerModelTest, WholeChordIsSixteenFifteenthsOfTheRadialProfile) {
    Ellipsoid e;
    e.radii = {200, 100, 50};
    const glm::dmat3 m = ellipsoidToUnit(e);
    for (double b : {0.0, 0.3, 0.7, 0.95}) {
        const Vec3 origin(-5000, b * 100, 0), d(1, 0, 0);  // along x, impact parameter b
        const glm::vec3 o(m * origin), du(m * d);
        const double expected = model::kChordScale * model::radialProfile(float(b * b)) / glm::length(du);
        EXPECT_NEAR(model::segmentDepth(o, du, 0.0f, 1e30f), expected, 1e-4 * 200) << b;
        EXPECT_NEAR(model::kChordScale * std::pow(1 - b * b, 2.5) * 200, expected, 1e-3);
    }
    // A miss has no depth.
    EXPECT_EQ(model::segmentDepth(glm::vec3(m * Vec3(-5000, 120, 0)), glm::vec3(m * Vec3(1, 0, 0)), 0.0f, 1e30f), 0.0f);
}

TEST(GardnerModelTest, WithoutNoiseEquationTwoIsTheExactOpacity) {
    for (float ac : {0.05f, 0.4f, 0.99f})
        for (float g : {0.0f, 0.3f, 1.0f}) {
            const float alpha = model::gardnerAlpha(model::termIOverD(ac, 0.0f, 0.7f), model::termG(ac, 0.0f, g));
            EXPECT_NEAR(alpha, ac * g, 1e-6);
        }
    // With noise the rim (g = 0) stays transparent whatever the noise says.
    for (float n : {-1.0f, 0.0f, 1.0f})
        EXPECT_LE(model::gardnerAlpha(model::termIOverD(0.8f, 0.3f, n), model::termG(0.8f, 0.3f, 0.0f)), 1e-6f);
}

TEST(GardnerModelTest, OpacityInFrontScalesOpticalDepth) {
    EXPECT_EQ(model::opacityInFront(0.8f, 0.0f, 2.0f), 0.0f);
    EXPECT_NEAR(model::opacityInFront(0.8f, 2.0f, 2.0f), 0.8f, 1e-6);
    // Half the optical depth: 1 - sqrt(1 - alpha).
    EXPECT_NEAR(model::opacityInFront(0.75f, 1.0f, 2.0f), 0.5f, 1e-6);
    // An opaque ellipsoid half in front still lets nothing through the front half.
    EXPECT_GT(model::opacityInFront(1.0f, 1.0f, 2.0f), 0.999f);
}

TEST(GardnerModelTest, ExactDensityOpacityOfOneEllipsoid) {
    Scene s;
    s.camera.position = {0, -2000, 0};
    s.camera.direction = {0, 1, 0};
    s.camera.width = 9;
    s.camera.height = 9;
    s.camera.fovYDeg = 20;
    Ellipsoid e;
    e.radii = {300, 200, 250};
    e.density = 0.5;
    s.clouds.push_back({"c", {e}});
    const View v = makeView(s.camera);
    const Image img = exactDensityOpacity(s, v);
    // The centre pixel looks straight through the centre: tau = ext * density * 16/15 * r_y.
    const double tau = s.medium.extinction * 0.5 * 16.0 / 15.0 * 200.0;
    EXPECT_NEAR(img.at(4, 4, 0), 1 - std::exp(-tau), 1e-4);
    const Vec3 corner = v.rayDirection(0.5, 0.5);
    EXPECT_NEAR(img.at(0, 0, 0), 1 - std::exp(-s.medium.extinction * 0.5 * integrate(e, v.eye, corner, 0, 4000)), 1e-4);
}

}  // namespace

TEST(GardnerModelTest, DiffuseReflectanceOfASemiInfiniteCloud) {
    // No absorption: every photon comes back out of a semi-infinite medium, whatever g.
    EXPECT_NEAR(model::diffuseReflectance(1.0f, 0.85f), 1.0f, 1e-6f);
    EXPECT_NEAR(model::diffuseReflectance(1.0f, 0.0f), 1.0f, 1e-6f);
    // The format's default medium: s = sqrt(0.01 / 0.1585) = 0.25118, (1 - s)(1 - 0.139 s) / (1 + 1.17 s)
    // = 0.72268 / 1.29388 = 0.55853 (by hand, in double; float round-off is far below 1e-4).
    EXPECT_NEAR(model::diffuseReflectance(0.99f, 0.85f), 0.55853f, 1e-4f);
    // Forward scattering carries light deeper, where more of it is absorbed: less comes back.
    EXPECT_LT(model::diffuseReflectance(0.99f, 0.85f), model::diffuseReflectance(0.99f, 0.0f));
    // More absorption, less reflected; black matter reflects nothing.
    EXPECT_LT(model::diffuseReflectance(0.9f, 0.85f), model::diffuseReflectance(0.99f, 0.85f));
    EXPECT_NEAR(model::diffuseReflectance(0.0f, 0.85f), 0.0f, 1e-6f);
}

TEST(GardnerModelTest, AmbientIsTheMeanOfTheEnvironmentOverTheSphere) {
    Sky sky;
    // Midpoint quadrature over mu = d.z of the format's sky (uniform in mu is uniform in solid angle).
    const int n = 100000;
    Vec3 sum(0.0);
    for (int i = 0; i < n; ++i) {
        const double mu = -1 + (i + 0.5) * 2.0 / n;
        sum += mu < 0 ? sky.ground : sky.horizon + (sky.zenith - sky.horizon) * mu;
    }
    const Vec3 mean = sum / double(n), ambient = cloudAmbient(sky);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(ambient[k], mean[k], 1e-6) << k;
    // A uniform environment is seen as it is (the furnace limit of a non-absorbing cloud).
    sky.zenith = sky.horizon = sky.ground = Vec3(0.3, 0.4, 0.5);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(cloudAmbient(sky)[k], 0.3 + 0.1 * k, 1e-12);
}

TEST(GardnerModelTest, LightVolumeHoldsReflectanceTimesTransmittance) {
    Scene scene;
    Ellipsoid e;
    e.radii = {300, 200, 150};
    scene.clouds.push_back({"c", {e}});
    const Cloud& cloud = scene.clouds[0];
    const double r = model::diffuseReflectance(float(scene.medium.albedo), float(scene.medium.hgG)) / scene.medium.albedo;
    // Sunward of the cloud nothing shadows: the volume holds R / albedo, which the model's
    // albedo factor turns into R.
    EXPECT_NEAR(cloudSunLight(scene, cloud, 1000.0 * scene.sun.direction), r, 1e-6);
    // At the centre: R / albedo times the reduced-extinction transmittance.
    EXPECT_NEAR(cloudSunLight(scene, cloud, Vec3(0.0)), r * sunTransmittance(scene, cloud, Vec3(0.0)), 1e-9);
    EXPECT_LT(sunTransmittance(scene, cloud, Vec3(0.0)), 0.9);
    // The grid stores the same values at its texel centres.
    const CloudLight grid = makeCloudLights(scene, 4)[0];
    const Vec3 p = grid.boxMin + (Vec3(1, 2, 3) + 0.5) / 4.0 * grid.boxExtent;
    EXPECT_NEAR(grid.transmittance[(3 * 4 + 2) * 4 + 1], cloudSunLight(scene, cloud, p), 1e-6);
}

TEST(RaymarchModelTest, PhaseFunctionIsNormalised) {
    // HG integrates to 1 over the sphere (midpoint rule in cos theta; 2 pi from the azimuth).
    for (float g : {0.0f, 0.5f, 0.85f}) {
        const int n = 200000;
        double sum = 0;
        for (int i = 0; i < n; ++i) sum += rmodel::rmHenyeyGreenstein(float(-1 + (i + 0.5) * 2.0 / n), g);
        EXPECT_NEAR(sum * 2.0 / n * 2 * std::numbers::pi, 1.0, 2e-3) << g;  // float HG, sharp peak at 0.85
    }
}

TEST(RaymarchModelTest, OctavesAddMultipleScatteringToSingleScattering) {
    const float g = 0.85f;
    // Outside the cloud (no optical depth) the sum is sum_k b^k HG(c^k g): more than single
    // scattering, and sideways far more (HG with g = 0.85 sends little at 90 degrees).
    const float single90 = rmodel::rmHenyeyGreenstein(0.0f, g), octaves90 = rmodel::rmSunPhase(0.0f, g, 0.0f);
    EXPECT_GT(octaves90, 2 * single90);
    float expected = 0, w = 1, gk = g;
    for (int k = 0; k < rmodel::kRmOctaves; ++k, w *= rmodel::kRmOctaveContribution, gk *= rmodel::kRmOctaveEccentricity)
        expected += w * rmodel::rmHenyeyGreenstein(0.3f, gk);
    EXPECT_NEAR(rmodel::rmSunPhase(0.3f, g, 0.0f), expected, 1e-6f);
    // Deep inside, the first octave has died out and the later, less attenuated ones remain.
    const float tau = 20.0f;
    EXPECT_LT(rmodel::rmHenyeyGreenstein(0.3f, g) * std::exp(-tau), 1e-8f);
    EXPECT_GT(rmodel::rmSunPhase(0.3f, g, tau), 1e-3f);
    // More depth, less light.
    EXPECT_LT(rmodel::rmSunPhase(0.3f, g, 5.0f), rmodel::rmSunPhase(0.3f, g, 1.0f));
}

TEST(RaymarchModelTest, EnvironmentTermKeepsTheFurnaceAndLeansToTheNearerSide) {
    const glm::vec3 sky(0.3f, 0.4f, 0.6f), ground(0.1f, 0.1f, 0.1f), none(0.0f);
    // A uniform environment is returned as it is, wherever the point is.
    for (float up : {0.0f, 3.0f}) {
        const glm::vec3 l = rmodel::rmInScatter(none, sky, sky, 0.0f, 0.85f, 0.16f, 5.0f, up, 10.0f - up);
        EXPECT_NEAR(l.z, sky.z, 1e-6f);
    }
    // Near the top (no matter above) the sky weighs more; near the bottom the ground.
    const float top = rmodel::rmSkyWeight(0.0f, 30.0f), bottom = rmodel::rmSkyWeight(30.0f, 0.0f);
    EXPECT_NEAR(top, 0.75f, 1e-6f);
    EXPECT_NEAR(bottom, 0.25f, 1e-6f);
    EXPECT_NEAR(rmodel::rmSkyWeight(2.0f, 2.0f), 0.5f, 1e-6f);
}

namespace {

// Mean |a - b| over channels [c0, c0 + n) of two same-sized images, unclamped (the exact
// model's radiance).
double meanDifference(const Image& a, const Image& b, int c0, int n) {
    double sum = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = c0; c < c0 + n; ++c) sum += std::abs(a.at(x, y, c) - b.at(x, y, c));
    return sum / (double(a.width) * a.height * n);
}

}  // namespace

// Failure case: the eye flies through two overlapping ellipsoids (flythrough.json, t = 8.25 s
// -> 8.5 s). Both cover the whole view; their centre distances cross between the two frames,
// so whole-ellipsoid back-to-front order (what tiles must use) swaps which colour lies on
// top everywhere at once: a pop. Per-pixel depth order changes smoothly. Opacity is the same
// in both orders ("over" of opacities commutes).
TEST(GardnerExactTest, OrderFlipOfOverlappingEllipsoidsPopsOnlyInPerEllipsoidOrder) {
    Scene s = loadScene(std::string(NEPHELE_SCENES) + "/flythrough.json");
    s.camera.width = 64;
    s.camera.height = 48;
    NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns.size, ns.cells, ns.octaves, ns.seed);
    auto frame = [&](double t, CompositeOrder order) {
        Camera c = cameraAt(s, t);
        c.width = s.camera.width;
        c.height = s.camera.height;
        return renderGardnerExact(s, makeView(c), noise, ns, order);
    };
    const Image e0 = frame(8.25, CompositeOrder::PerEllipsoid), e1 = frame(8.5, CompositeOrder::PerEllipsoid);
    const Image p0 = frame(8.25, CompositeOrder::PerPixel), p1 = frame(8.5, CompositeOrder::PerPixel);
    EXPECT_LT(meanDifference(e0, p0, 3, 1), 1e-6);  // same opacity
    EXPECT_LT(meanDifference(e1, p1, 3, 1), 1e-6);
    const double popping = meanDifference(e0, e1, 0, 3), smooth = meanDifference(p0, p1, 0, 3);
    std::cout << "frame change: per-ellipsoid order " << popping << ", per-pixel order " << smooth << "\n";
    // Measured 0.048 against 0.018 (160 px wide): the flip more than doubles the change.
    EXPECT_GT(popping, 2 * smooth);
}

// The weighted composite's weight (shaders/gardner_model.glsl): a power of a depth ratio, so
// the ratio of two contributions' weights does not depend on the reference depth, it is at
// most 1 beyond the reference, continuous, and never 0 (the GPU divides by the sum).
TEST(GardnerModelTest, CompositeWeightIsAScaleFreePowerOfDepth) {
    const float k = model::kWeightExponent;
    for (float tRef : {0.5f, 30.0f, 900.0f}) {
        const float ratio = model::compositeWeight(1.5f * tRef, tRef, k) / model::compositeWeight(3.0f * tRef, tRef, k);
        EXPECT_NEAR(ratio, std::pow(2.0f, k), 1e-4f * std::pow(2.0f, k)) << tRef;
        EXPECT_FLOAT_EQ(model::compositeWeight(tRef, tRef, k), 1.0f);
        EXPECT_FLOAT_EQ(model::compositeWeight(0.5f * tRef, tRef, k), 1.0f);  // nearer than tRef: clamped
        EXPECT_NEAR(model::compositeWeight(1.001f * tRef, tRef, k), 1.0f, 0.01f);  // continuous
    }
    EXPECT_GT(model::compositeWeight(1e9f, 0.5f, k), 0.0f);
    // The shading depth is the ray's closest approach to the centre, inside the visible chord.
    const glm::vec3 o(0.0f, -3.0f, 0.0f), d(0.0f, 1.0f, 0.0f);  // unit sphere 3 radii ahead
    EXPECT_FLOAT_EQ(model::shadeDepth(o, d, 0.0f), 3.0f);
    EXPECT_FLOAT_EQ(model::shadeDepth(o, d, 3.5f), 3.5f);  // cut by the near plane beyond the centre
    EXPECT_FLOAT_EQ(model::shadeDepth(glm::vec3(0.0f, -3.0f, 0.999f), d, 0.0f), 3.0f);
    // The weight's depth is the centroid of the matter seen: the centre for a whole chord,
    // beyond it when the near plane cuts the ellipsoid past the centre (the matter left).
    EXPECT_NEAR(model::matterDepth(o, d, 0.0f), 3.0f, 1e-5f);
    EXPECT_GT(model::matterDepth(o, d, 3.5f), 3.5f);
    EXPECT_LT(model::matterDepth(o, d, 3.5f), 4.0f);
}

// The weighted composite's exact model: the opacity of the back-to-front order, one
// ellipsoid exactly as "over", and through the order flip of the test above no pop.
TEST(GardnerExactTest, WeightedOrderKeepsOpacityAndDoesNotPop) {
    Scene s = loadScene(std::string(NEPHELE_SCENES) + "/flythrough.json");
    NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns.size, ns.cells, ns.octaves, ns.seed);
    auto frame = [&](const Scene& scene, double t, CompositeOrder order) {
        Camera c = t < 0 ? scene.camera : cameraAt(scene, t);
        c.width = 64;
        c.height = 48;
        return renderGardnerExact(scene, makeView(c), noise, ns, order);
    };
    Scene one = loadScene(std::string(NEPHELE_SCENES) + "/single.json");
    EXPECT_LT(meanDifference(frame(one, -1, CompositeOrder::Weighted), frame(one, -1, CompositeOrder::PerEllipsoid), 0, 4), 1e-6);
    const Image w0 = frame(s, 8.25, CompositeOrder::Weighted), w1 = frame(s, 8.5, CompositeOrder::Weighted);
    const Image e0 = frame(s, 8.25, CompositeOrder::PerEllipsoid), e1 = frame(s, 8.5, CompositeOrder::PerEllipsoid);
    const Image p0 = frame(s, 8.25, CompositeOrder::PerPixel), p1 = frame(s, 8.5, CompositeOrder::PerPixel);
    EXPECT_LT(meanDifference(w0, e0, 3, 1), 1e-6);  // same opacity
    EXPECT_LT(meanDifference(w1, e1, 3, 1), 1e-6);
    const double weighted = meanDifference(w0, w1, 0, 3), popping = meanDifference(e0, e1, 0, 3), smooth = meanDifference(p0, p1, 0, 3);
    std::cout << "frame change: weighted " << weighted << ", per-ellipsoid " << popping << ", per-pixel " << smooth << "\n";
    // Measured (64 x 48): weighted 0.0195, per-pixel 0.024, per-ellipsoid 0.060: the weighted
    // change is about the per-pixel order's, the flip's three times as much.
    EXPECT_LT(weighted, 1.5 * smooth);
    EXPECT_GT(popping, 1.5 * weighted);
}
