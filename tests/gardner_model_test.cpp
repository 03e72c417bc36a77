// The shared Gardner model (shaders/gardner_model.glsl compiled as C++) against numerical
// integration of the format's density field, and the exact CPU renderer's bookkeeping; the
// light model every method shares (shaders/cloud_light.glsl) against quadrature and its limits.
#include "nephele/gardner.hpp"
#include "nephele/projection.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"
#include "nephele/camera.hpp"
#include "scene_test_util.hpp"

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

TEST(GardnerModelTest, EquationTwoIsTheOpacityOfTheNoisyDensityField) {
    auto alphaOf = [](float ac, float a, float amp, float n) {
        const glm::vec2 t = model::gardnerTerms(ac, a, amp, n);
        return model::gardnerAlpha(t.x, t.y);
    };
    for (float ac : {0.05f, 0.4f, 0.99f})
        for (float g : {0.0f, 0.3f, 1.0f}) {
            // Without noise, the exact opacity A = Ac g of the smooth field.
            const float a = ac * g;
            const float alpha = alphaOf(ac, a, 0.0f, 0.7f);
            EXPECT_NEAR(alpha, a, 1e-6);
            // With noise, the opacity of density (1 + noise n): optical depth scaled by it; both
            // terms stay in [0, 1] (the 8-bit atlas).
            for (float n : {-1.0f, -0.4f, 0.0f, 0.5f, 1.0f}) {
                const float amp = 0.3f;
                const glm::vec2 t = model::gardnerTerms(ac, a, amp, n);
                const float iOverD = t.x, gTerm = t.y;
                EXPECT_GE(iOverD, 0.0f);
                EXPECT_LE(iOverD, 1.0f + 1e-6f);
                EXPECT_GE(gTerm, -1e-6f);
                EXPECT_LE(gTerm, 1.0f);
                const double expected = 1.0 - std::pow(1.0 - double(a), 1.0 + amp * n);
                EXPECT_NEAR(model::gardnerAlpha(iOverD, gTerm), expected, 2e-6)
                    << "ac " << ac << " A " << a << " n " << n;
            }
        }
    // No matter, no opacity, whatever the noise; and noise above 1 cannot make density negative.
    for (float n : {-1.0f, 0.0f, 1.0f}) EXPECT_NEAR(alphaOf(0.8f, 0.0f, 0.3f, n), 0.0f, 1e-6f);
    EXPECT_NEAR(alphaOf(0.8f, 0.5f, 2.0f, -1.0f), 0.0f, 1e-6f);
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

TEST(CloudLightModelTest, PhaseFunctionIsNormalised) {
    // HG integrates to 1 over the sphere (midpoint rule in cos theta; 2 pi from the azimuth).
    for (float g : {0.0f, 0.5f, 0.85f}) {
        const int n = 200000;
        double sum = 0;
        for (int i = 0; i < n; ++i) sum += model::hgPhase(float(-1 + (i + 0.5) * 2.0 / n), g);
        EXPECT_NEAR(sum * 2.0 / n * 2 * std::numbers::pi, 1.0, 2e-3) << g;  // float HG, sharp peak at 0.85
    }
}

namespace {
// A direction on the sphere by (cos theta, phi) about z.
glm::vec3 polar(double c, double phi) {
    const double s = std::sqrt(std::max(0.0, 1 - c * c));
    return glm::vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(c));
}
}  // namespace

// J_sun = phi0 HG(-d . m; g g_L) must be the in-scattering of a radiance field that IS a
// Henyey-Greenstein lobe of mean cosine g_L about m: integral of p(w . o) L(w) over the sphere,
// by quadrature (HG convolved with HG is HG with the product of the asymmetries).
TEST(CloudLightModelTest, SunInScatterIsTheExactConvolutionOfAnHgLobe) {
    const float g = 0.85f, gL = 0.6f, phi0 = 2.0f;
    const glm::vec3 m = glm::normalize(glm::vec3(0.3f, -0.2f, -0.9f));
    const glm::vec4 field(phi0 * gL * m, phi0);  // phi1 = phi0 g_L m for a lobe
    for (const glm::vec3 d : {glm::vec3(0, 1, 0), glm::normalize(glm::vec3(0.3f, -0.2f, 0.9f)), -m}) {
        const glm::vec3 o = -d;  // the direction light leaves towards the eye
        const int nc = 2000, np = 256;
        double sum = 0;
        for (int i = 0; i < nc; ++i)
            for (int j = 0; j < np; ++j) {
                const glm::vec3 w = polar(-1 + (i + 0.5) * 2.0 / nc, (j + 0.5) * 2 * std::numbers::pi / np);
                sum += model::hgPhase(glm::dot(w, o), g) * phi0 * model::hgPhase(glm::dot(w, m), gL);
            }
        sum *= (2.0 / nc) * (2 * std::numbers::pi / np);
        EXPECT_NEAR(model::sunInScatter(field, d, g), sum, 0.01 * sum) << d.x << " " << d.y << " " << d.z;
    }
    // No flux: isotropic, phi0 / 4 pi whatever the direction; no light, none.
    EXPECT_NEAR(model::sunInScatter(glm::vec4(0, 0, 0, phi0), glm::vec3(0, 0, 1), g), phi0 / (4 * std::numbers::pi),
                1e-6);
    EXPECT_EQ(model::sunInScatter(glm::vec4(0.0f), glm::vec3(0, 0, 1), g), 0.0f);
}

// J_many: the in-scattering of a radiance field that IS its l <= 1 harmonics (the diffusion
// regime), phi0 / 4 pi + 3 / (4 pi) phi1 . w, by quadrature of p(w . o) L(w); never negative.
TEST(CloudLightModelTest, SunDiffuseInScatterIsTheExactConvolutionOfItsHarmonics) {
    const float g = 0.85f, phi0 = 2.0f;
    const glm::vec3 phi1 = 0.25f * phi0 * glm::normalize(glm::vec3(0.3f, -0.2f, -0.9f));  // |phi1| < phi0 / 3: L >= 0
    const glm::vec4 field(phi1, phi0);
    const int nc = 2000, np = 256;
    const double dA = (2.0 / nc) * (2 * std::numbers::pi / np);
    for (const glm::vec3 d : {glm::vec3(0, 1, 0), glm::normalize(phi1), -glm::normalize(phi1)}) {
        double sum = 0;
        for (int i = 0; i < nc; ++i)
            for (int j = 0; j < np; ++j) {
                const glm::vec3 w = polar(-1 + (i + 0.5) * 2.0 / nc, (j + 0.5) * 2 * std::numbers::pi / np);
                const double radiance = phi0 / (4 * std::numbers::pi) + 3 / (4 * std::numbers::pi) * glm::dot(phi1, w);
                sum += model::hgPhase(glm::dot(w, -d), g) * radiance * dA;
            }
        EXPECT_NEAR(model::sunDiffuseInScatter(field, d, g), sum, 0.01 * sum) << d.x << " " << d.y << " " << d.z;
    }
    // Looking straight down a flux the harmonics cannot hold (|phi1| = phi0): none, not negative.
    const glm::vec3 m(0, 0, -1);
    EXPECT_EQ(model::sunDiffuseInScatter(glm::vec4(phi0 * m, phi0), m, g), 0.0f);
    EXPECT_GT(model::sunDiffuseInScatter(glm::vec4(phi0 * m, phi0), -m, g), phi0 / (4 * std::numbers::pi));
}

// The sky's in-scattering from its l <= 1 harmonics and the zonal l = 2 term: exact for a
// radiance field made of exactly those, by quadrature of p(w . o) L(w).
TEST(CloudLightModelTest, SkyInScatterIsTheExactConvolutionOfItsHarmonics) {
    const float g = 0.85f;
    // L(w) = a + b . w + c (3 w_z^2 - 1): bright above and towards the horizon, as skylight is.
    const double a = 0.3, c = 0.05;
    const glm::vec3 b(0.02f, -0.01f, -0.12f);  // the light travels downwards: flux along -z
    const int nc = 2000, np = 256;
    // Its moments: phi0 = 4 pi a, phi1 = 4 pi / 3 b, c20 = integral of L Y20.
    double phi0 = 0, c20 = 0;
    glm::dvec3 phi1(0.0);
    const double dA = (2.0 / nc) * (2 * std::numbers::pi / np);
    auto field = [&](const glm::vec3& w) { return a + glm::dot(b, w) + c * (3 * w.z * w.z - 1); };
    for (int i = 0; i < nc; ++i)
        for (int j = 0; j < np; ++j) {
            const glm::vec3 w = polar(-1 + (i + 0.5) * 2.0 / nc, (j + 0.5) * 2 * std::numbers::pi / np);
            phi0 += field(w) * dA;
            phi1 += field(w) * glm::dvec3(w) * dA;
            c20 += field(w) * 0.3153916 * (3 * w.z * w.z - 1) * dA;
        }
    for (const glm::vec3 d : {glm::vec3(1, 0, 0), glm::vec3(0, 0, 1), glm::normalize(glm::vec3(0.5f, 0.2f, -0.4f))}) {
        double sum = 0;
        for (int i = 0; i < nc; ++i)
            for (int j = 0; j < np; ++j) {
                const glm::vec3 w = polar(-1 + (i + 0.5) * 2.0 / nc, (j + 0.5) * 2 * std::numbers::pi / np);
                sum += model::hgPhase(glm::dot(w, -d), g) * field(w) * dA;
            }
        const float j = model::skyInScatterLuminance(float(phi0), glm::vec4(glm::vec3(phi1), float(c20)), d, g);
        EXPECT_NEAR(j, sum, 0.01 * sum) << d.x << " " << d.y << " " << d.z;
    }
}

// Single scattering: p(d . s) exp(-tau); looking at the sun through thin cloud is the brightest.
TEST(CloudLightModelTest, SingleScatteringIsThePhaseTimesTheSunsTransmittance) {
    const glm::vec3 s = glm::normalize(glm::vec3(0.3f, 0.2f, 0.9f));
    // (s . s of a unit float vector is 1 - 6e-8, where HG's peak falls by 5e-6 of itself.)
    EXPECT_NEAR(model::singleScatter(s, s, 0.85f, 0.0f), model::hgPhase(1.0f, 0.85f),
                1e-4f * model::hgPhase(1.0f, 0.85f));
    EXPECT_NEAR(model::singleScatter(-s, s, 0.85f, 2.0f), model::hgPhase(-1.0f, 0.85f) * std::exp(-2.0f), 1e-9f);
    EXPECT_GT(model::singleScatter(s, s, 0.85f, 1.0f),
              100 * model::singleScatter(-s, s, 0.85f, 1.0f));  // the silver lining
}

// The chord's samples stand where the opacity in front of them reaches their share of the chord's
// (by quadrature of sigma (1 - q)^2 exp(-tau(t)) along the ray), and their weights make the
// three-point Gauss-Legendre rule on those shares: exact for polynomials of degree 5 in the
// opacity seen, which the midpoint rule (1/2 of each of three equal shares) is not.
TEST(CloudLightModelTest, ChordSamplesAreGaussLegendrePointsInTheOpacitySeen) {
    for (int degree = 0; degree <= 6; ++degree) {
        double sum = 0;
        for (int k = 0; k < model::kChordSamples; ++k)
            sum += model::chordWeight(k) * std::pow(model::chordShare(k), degree);
        if (degree <= 5) EXPECT_NEAR(sum, 1.0 / (degree + 1), 1e-6) << degree;
        else EXPECT_GT(std::abs(sum - 1.0 / 7), 1e-4);  // the rule's order: degree 6 is not exact
    }
    Ellipsoid e;
    e.center = Vec3(0, 500, 0);
    e.radii = Vec3(200, 150, 100);
    e.rotationDeg = Vec3(10, 20, 30);
    const glm::dmat3 unit = ellipsoidToUnit(e);
    for (double sigma : {0.001, 0.04, 0.5}) {
        for (const Vec3 d : {Vec3(0, 1, 0), glm::normalize(Vec3(0.1, 1, 0.05))}) {
            const glm::vec3 o(unit * (-e.center)), du(unit * d);
            const float total = model::segmentDepth(o, du, 0.0f, 1e30f);
            const double alpha = 1 - std::exp(-sigma * total);
            for (int k = 0; k < model::kChordSamples; ++k) {
                const float t = model::chordSampleDepth(o, du, 0.0f, float(sigma), model::chordShare(k));
                // The share of alpha seen in front of the sample: 1 - exp(-sigma depth(0, t)).
                const double before = 1 - std::exp(-sigma * model::segmentDepth(o, du, 0.0f, t));
                EXPECT_NEAR(before / alpha, model::chordShare(k), 1e-3) << sigma << " " << k;
            }
        }
    }
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

// The part of a step's change (a0 -> a1) that the reference's change over the same step
// (r0 -> r1) does not have: mean |(a1 - a0) - (r1 - r0)| over the colour. A pop shows here;
// the light changing as the eye moves (which every order shares) does not.
double excessChange(const Image& a0, const Image& a1, const Image& r0, const Image& r1) {
    double sum = 0;
    for (std::size_t i = 0; i < a0.pixels.size(); ++i) {
        if (i % 4 == 3) continue;
        sum += std::abs((a1.pixels[i] - a0.pixels[i]) - (r1.pixels[i] - r0.pixels[i]));
    }
    return sum / (double(a0.width) * a0.height * 3);
}

// flythrough.json at 64 x 48 in one composite order.
struct FlipFrames {
    Scene scene = loadScene(std::string(NEPHELE_SCENES) + "/flythrough.json");
    NoiseSettings ns;
    NoiseVolume noise = makeNoiseVolume(ns);
    mutable ExactLight light;  // the clouds' grids, made once for every frame
    Image at(double t, CompositeOrder order) const {
        Camera c = cameraAt(scene, t);
        c.width = 64;
        c.height = 48;
        return renderGardnerExact(scene, makeView(c), noise, ns, order, model::kWeightExponent, {}, &light);
    }
    // An order-independent `order` across the flip (8.25 -> 8.5 s): its excess change over the
    // per-pixel order's, and whole-ellipsoid order's (the pop); its opacity must be back to
    // front's in both frames.
    struct Excess {
        double order, perEllipsoid;
    };
    Excess acrossTheFlip(CompositeOrder order) const {
        const Image o1 = at(8.25, order), o2 = at(8.5, order);
        const Image e1 = at(8.25, CompositeOrder::PerEllipsoid), e2 = at(8.5, CompositeOrder::PerEllipsoid);
        const Image p1 = at(8.25, CompositeOrder::PerPixel), p2 = at(8.5, CompositeOrder::PerPixel);
        EXPECT_LT(meanDifference(o1, e1, 3, 1), 1e-6);  // same opacity
        EXPECT_LT(meanDifference(o2, e2, 3, 1), 1e-6);
        return {excessChange(o1, o2, p1, p2), excessChange(e1, e2, p1, p2)};
    }
};

}  // namespace

// Failure case: the eye flies through two overlapping ellipsoids (flythrough.json, t = 8.25 s
// -> 8.5 s). Both cover the whole view; their centre distances cross between the two frames,
// so whole-ellipsoid back-to-front order (what tiles must use) swaps which colour lies on
// top everywhere at once: a pop. Per-pixel depth order changes smoothly, and is the reference:
// inside the cloud the light itself changes quickly as the eye goes deeper (every order
// shares that), so the pop is the change the per-pixel order does not have. Opacity is the
// same in both orders ("over" of opacities commutes).
TEST(GardnerExactTest, OrderFlipOfOverlappingEllipsoidsPopsOnlyInPerEllipsoidOrder) {
    const FlipFrames f;
    const Image e0 = f.at(8.0, CompositeOrder::PerEllipsoid), e1 = f.at(8.25, CompositeOrder::PerEllipsoid),
                e2 = f.at(8.5, CompositeOrder::PerEllipsoid);
    const Image p0 = f.at(8.0, CompositeOrder::PerPixel), p1 = f.at(8.25, CompositeOrder::PerPixel),
                p2 = f.at(8.5, CompositeOrder::PerPixel);
    EXPECT_LT(meanDifference(e1, p1, 3, 1), 1e-6);  // same opacity
    EXPECT_LT(meanDifference(e2, p2, 3, 1), 1e-6);
    const double before = excessChange(e0, e1, p0, p1), flip = excessChange(e1, e2, p1, p2);
    std::cout << "per-ellipsoid order's excess change over per-pixel order: " << before << " before the flip, " << flip
              << " across it\n";
    // Measured 0.0061 across the flip, 6e-6 before it: the flip is a change of its own. (0.034
    // while the noise thinned the rims, Gardner's threshold, until 2026-12-02.)
    EXPECT_GT(flip, 0.003);
    EXPECT_GT(flip, 5 * before);
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
        EXPECT_FLOAT_EQ(model::compositeWeight(0.5f * tRef, tRef, k), 1.0f);       // nearer than tRef: clamped
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

// The grids an ExactLight keeps light a frame exactly as grids made for it would: after the sun
// turns, the medium thickens or the cloud moves, the kept light is the scene's as it is now (a
// key that missed one of them would draw the old light: the images would differ).
TEST(GardnerExactTest, KeptLightIsTheLightOfTheSceneAsItIsNow) {
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns);
    Scene scene = loadScene(std::string(NEPHELE_SCENES) + "/single.json");
    scene.camera.width = 32, scene.camera.height = 24;
    ExactLight kept;
    auto render = [&](const Scene& s, ExactLight* light) {
        return renderGardnerExact(s, makeView(s.camera), noise, ns, CompositeOrder::PerEllipsoid,
                                  model::kWeightExponent, {}, light);
    };
    const Image first = render(scene, &kept);
    EXPECT_TRUE(first.pixels == render(scene, nullptr).pixels);
    EXPECT_TRUE(first.pixels == render(scene, &kept).pixels);
    Scene turned = scene;
    turned.sun.direction = glm::normalize(Vec3(-1, 0.5, 0.3));
    Scene thicker = scene;
    thicker.medium.extinction *= 3;
    Scene moved = scene;  // the cloud and the camera 500 m east: the same view of a moved cloud
    for (Ellipsoid& e : moved.clouds[0].ellipsoids) e.center += Vec3(500, 0, 0);
    moved.camera.position += Vec3(500, 0, 0);
    for (const auto& [name, changed] :
         {std::pair{"sun turned", turned}, std::pair{"medium thicker", thicker}, std::pair{"cloud moved", moved}}) {
        render(scene, &kept);  // the kept light is the first scene's again
        const Image withKept = render(changed, &kept), fresh = render(changed, nullptr);
        EXPECT_TRUE(withKept.pixels == fresh.pixels) << name << ": " << meanDifference(withKept, fresh, 0, 3);
        if (std::string(name) != "cloud moved") {
            EXPECT_GT(meanDifference(fresh, first, 0, 3), 1e-3) << name;
        }
    }
}

// The weighted composite's exact model: the opacity of the back-to-front order, one
// ellipsoid exactly as "over", and through the order flip of the test above no pop.
TEST(GardnerExactTest, WeightedOrderKeepsOpacityAndDoesNotPop) {
    const FlipFrames f;
    NoiseSettings ns;
    auto still = [&](const Scene& scene, CompositeOrder order) {
        Camera c = scene.camera;
        c.width = 64;
        c.height = 48;
        return renderGardnerExact(scene, makeView(c), f.noise, ns, order);
    };
    const Scene one = loadScene(std::string(NEPHELE_SCENES) + "/single.json");
    EXPECT_LT(meanDifference(still(one, CompositeOrder::Weighted), still(one, CompositeOrder::PerEllipsoid), 0, 4),
              1e-6);
    const auto [weighted, popping] = f.acrossTheFlip(CompositeOrder::Weighted);
    const double before = excessChange(f.at(8.0, CompositeOrder::Weighted), f.at(8.25, CompositeOrder::Weighted),
                                       f.at(8.0, CompositeOrder::PerPixel), f.at(8.25, CompositeOrder::PerPixel));
    std::cout << "excess change over per-pixel order: weighted " << before << " the step before the flip, " << weighted
              << " across it; per-ellipsoid " << popping << " across it\n";
    // Measured 2026-12-04: weighted 0.0044 the step before and 0.0033 across, per-ellipsoid 0.0061
    // across. The weighted composite differs from the per-pixel order a little in every step (its
    // colour is a weighted mean), but the flip adds nothing of its own. (Weighted across the flip
    // was 0.0030 with the chord's midpoint rule, 0.013 against 0.034 while the noise thinned
    // the rims, until 2026-12-02.)
    EXPECT_LT(weighted, before);
    EXPECT_LT(weighted, 0.75 * popping);
}

namespace {

// The root mean square of the colour difference of two images, over the pixels either covers.
double colourRms(const Image& a, const Image& b) {
    double sum = 0;
    int n = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            if (a.at(x, y, 3) <= 0 && b.at(x, y, 3) <= 0) continue;
            for (int k = 0; k < 3; ++k) sum += (a.at(x, y, k) - b.at(x, y, k)) * (a.at(x, y, k) - b.at(x, y, k));
            ++n;
        }
    return n ? std::sqrt(sum / (3.0 * n)) : 0.0;
}

}  // namespace

// The moment composite's transmittance: exact for one contribution and for two far apart in
// depth (the front one sees kMomentOverestimation of its own absorbance in front of it, the
// back one the whole of the front's and that share of its own), and continuous in depth.
TEST(GardnerModelTest, MomentTransmittanceReconstructsTheOrder) {
    struct Sums {  // b0 and b1..b4 / b0 of contributions (alpha, depth)
        float b[5] = {0, 0, 0, 0, 0};
        explicit Sums(std::initializer_list<std::pair<float, float>> layers) {
            for (auto [alpha, d] : layers)
                for (int k = 0; k < 5; ++k) b[k] += model::absorbanceOf(alpha) * std::pow(d, float(k));
            for (int k = 1; k < 5; ++k) b[k] /= b[0];
        }
    };
    auto moments = [](std::initializer_list<std::pair<float, float>> layers, float z) {
        const Sums m(layers);
        return model::momentTransmittance(m.b[0], m.b[1], m.b[2], m.b[3], m.b[4], z);
    };
    const float a = model::absorbanceOf(0.6f);  // ln 2.5
    EXPECT_NEAR(moments({{0.6f, 0.2f}}, 0.2f), std::exp(-model::kMomentOverestimation * a), 1e-3);
    EXPECT_NEAR(moments({{0.6f, -0.5f}, {0.6f, 0.5f}}, -0.5f), std::exp(-model::kMomentOverestimation * a), 0.02);
    EXPECT_NEAR(moments({{0.6f, -0.5f}, {0.6f, 0.5f}}, 0.5f), std::exp(-(1 + model::kMomentOverestimation) * a), 0.02);
    float last = moments({{0.6f, -0.5f}, {0.6f, 0.5f}}, -1.0f);
    for (float z = -0.99f; z <= 1.0f; z += 0.01f) {  // non-increasing with depth, no jump
        const float t = moments({{0.6f, -0.5f}, {0.6f, 0.5f}}, z);
        EXPECT_LE(t, last + 1e-5f) << z;
        last = t;
    }
    // The weight leaves out the contribution's own share: 1 alone, the front's transmittance
    // behind it, whatever the opacities (an opaque one too).
    auto weight = [](std::initializer_list<std::pair<float, float>> layers, float z, float alpha) {
        const Sums m(layers);
        return model::momentWeight(m.b[0], m.b[1], m.b[2], m.b[3], m.b[4], z, alpha);
    };
    EXPECT_NEAR(weight({{1.0f, 0.3f}}, 0.3f, 1.0f), 1.0f, 1e-3);
    EXPECT_NEAR(weight({{0.6f, -0.5f}, {1.0f, 0.5f}}, -0.5f, 0.6f), 1.0f, 0.02);
    EXPECT_NEAR(weight({{0.6f, -0.5f}, {1.0f, 0.5f}}, 0.5f, 1.0f), 0.4f, 0.02);
    EXPECT_NEAR(model::momentDepth(100.0f, 100.0f, 10000.0f), -1.0f, 1e-6);
    EXPECT_NEAR(model::momentDepth(1000.0f, 100.0f, 10000.0f), 0.0f, 1e-6);
    EXPECT_NEAR(model::momentDepth(1e6f, 100.0f, 10000.0f), 1.0f, 1e-6);
}

// The moment composite keeps the opacity of every order, does not pop where the ellipsoids'
// order flips (flythrough.json, as WeightedOrderKeepsOpacityAndDoesNotPop), and is much nearer
// the per-pixel order than the weighted composite where the order matters most: a back-lit
// cumulus, whose bright far rims the weighted mean lets through its dark front.
TEST(GardnerExactTest, MomentOrderKeepsOpacityFollowsThePixelOrderAndDoesNotPop) {
    const FlipFrames f;
    const auto [moments, popping] = f.acrossTheFlip(CompositeOrder::Moments);
    std::cout << "[ figure ] excess change across the flip over per-pixel order: moments " << moments
              << ", per-ellipsoid " << popping << "\n";
    EXPECT_LT(moments, 0.5 * popping);

    const Scene backLit = test::backLit(loadScene(std::string(NEPHELE_SCENES) + "/cumulus27.json"));
    Camera c = backLit.camera;
    c.width = 96;
    c.height = 64;
    const View view = makeView(c);
    auto render = [&](CompositeOrder order) { return renderGardnerExact(backLit, view, f.noise, f.ns, order); };
    const Image pixel = render(CompositeOrder::PerPixel);
    const double weighted = colourRms(render(CompositeOrder::Weighted), pixel),
                 moment = colourRms(render(CompositeOrder::Moments), pixel),
                 ellipsoid = colourRms(render(CompositeOrder::PerEllipsoid), pixel);
    std::cout << "[ figure ] back-lit cumulus27 from 2 km, rms colour difference from the per-pixel order: weighted "
              << weighted << ", moments " << moment << ", per-ellipsoid " << ellipsoid << "\n";
    // Measured: weighted 0.103, moments 0.012, per-ellipsoid 0.015 (the flip: moments 0.014,
    // per-ellipsoid 0.032, weighted 0.013).
    EXPECT_LT(moment, 0.25 * weighted);
}
