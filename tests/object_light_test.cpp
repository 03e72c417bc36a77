// The irradiance formulas of objects lit by the clouds (shaders/cloud_light.glsl, compiled as
// C++ in nephele::model) against closed forms and quadrature of the radiance they stand for.
#include "nephele/gardner_model.hpp"
#include "nephele/opaque.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

using namespace nephele;

namespace {

constexpr double kPi = std::numbers::pi;

// E(n) = integral of L_in(w) max(n . w, 0) dw over the directions w light comes from, by the
// midpoint rule on a 400 x 800 (theta, phi) grid about n: its error for the smooth integrands
// below is under 1e-5 of E.
double irradiance(const std::function<double(const Vec3&)>& arriving, const Vec3& n) {
    const int nt = 400, np = 800;
    const Vec3 a = std::fabs(n.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
    const Vec3 u = glm::normalize(glm::cross(a, n)), v = glm::cross(n, u);
    double sum = 0;
    for (int i = 0; i < nt; ++i) {
        const double t = (i + 0.5) / nt * kPi / 2, ct = std::cos(t), st = std::sin(t);
        for (int j = 0; j < np; ++j) {
            const double p = (j + 0.5) / np * 2 * kPi;
            const Vec3 w = st * std::cos(p) * u + st * std::sin(p) * v + ct * n;
            sum += arriving(w) * ct * st;
        }
    }
    return sum * (kPi / 2 / nt) * (2 * kPi / np);
}

const Vec3 kNormals[] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0.48, -0.6, 0.64}, {-0.36, 0.48, -0.8}};

TEST(ObjectLightTest, UniformRadianceGivesPiTimesIt) {
    // phi0 = 4 pi L, no flux, no band 2: E = pi L whatever the normal.
    const float L = 0.7f;
    for (const Vec3& n : kNormals)
        EXPECT_NEAR(model::harmonicIrradiance(4 * float(kPi) * L, glm::vec3(0), 0, glm::vec3(n)), kPi * L, 1e-5);
    // The open sky of one colour everywhere is the same uniform radiance.
    const glm::vec3 c(0.3f, 0.5f, 0.7f);
    for (const Vec3& n : kNormals) {
        const glm::vec3 e = model::openSkyIrradiance(c, c, c, glm::vec3(n));
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(e[k], kPi * c[k], 1e-5) << "normal " << n.x << " " << n.y << " " << n.z;
    }
}

TEST(ObjectLightTest, HarmonicIrradianceIsThatOfTheRadianceItsHarmonicsDescribe) {
    // L(v) = phi0 / 4 pi + 3 / (4 pi) phi1 . v + c20 Y20(v), v the direction the light travels,
    // positive everywhere (|phi1| < phi0 / 3 and a small c20); light arriving from w travels -w.
    const double phi0 = 2.0, c20 = 0.15;
    const Vec3 phi1(0.2, -0.35, 0.4);
    auto radiance = [&](const Vec3& v) {
        return phi0 / (4 * kPi) + 3 / (4 * kPi) * glm::dot(phi1, v) + c20 * 0.31539156525252 * (3 * v.z * v.z - 1);
    };
    for (const Vec3& n : kNormals) {
        const double exact = irradiance([&](const Vec3& w) { return radiance(-w); }, n);
        EXPECT_NEAR(model::harmonicIrradiance(float(phi0), glm::vec3(phi1), float(c20), glm::vec3(n)), exact,
                    1e-4 * exact)
            << "normal " << n.x << " " << n.y << " " << n.z;
    }
}

TEST(ObjectLightTest, LobeIrradianceIsAHenyeyGreensteinLobesToBandTwo) {
    // A lobe of fluence phi0 and mean cosine g about m: L(v) = phi0 HG(v . m; g), whose band l is
    // phi0 (2l + 1) / (4 pi) g^l P_l. Bands above 2 are left out: A3 = A5 = 0, and the clamped
    // cosine keeps of bands 4 and 6 A4 = pi / 24 and A6 = pi / 64, so the error is at most
    // phi0 (3/32 g^4 + 13/256 g^6) plus the smaller bands beyond (|P_l| <= 1): taken twice the
    // band-6 term, 0.0075 phi0 at g = 0.5.
    const double phi0 = 1.5, g = 0.5;
    const Vec3 m = glm::normalize(Vec3(0.3, -0.2, -0.9));
    auto radiance = [&](const Vec3& v) {
        const double d = 1 + g * g - 2 * g * glm::dot(v, m);
        return phi0 * (1 - g * g) / (4 * kPi * d * std::sqrt(d));
    };
    const glm::vec4 lobe(glm::vec3(phi0 * g * m), float(phi0));
    for (const Vec3& n : {-m, glm::normalize(glm::cross(m, Vec3(1, 0, 0))), Vec3(0, 0, -1), Vec3(1, 0, 0)}) {
        const double exact = irradiance([&](const Vec3& w) { return radiance(-w); }, n);
        const double bound = phi0 * (3.0 / 32 * std::pow(g, 4) + 2 * 13.0 / 256 * std::pow(g, 6));
        EXPECT_NEAR(model::lobeIrradiance(lobe, glm::vec3(n)), exact, bound)
            << "normal " << n.x << " " << n.y << " " << n.z;
    }
}

TEST(ObjectLightTest, OpenSkyIrradianceIsTheFormatsSkyIntegrated) {
    Sky sky;  // the format's default zenith, horizon and ground
    for (const Vec3& n : kNormals) {
        const glm::vec3 e = model::openSkyIrradiance(glm::vec3(sky.zenith), glm::vec3(sky.horizon),
                                                     glm::vec3(sky.ground), glm::vec3(n));
        for (int k = 0; k < 3; ++k) {
            // The ground's edge at the horizon is a step in the integrand: the quadrature is good
            // to about 1e-4 of E there.
            const double exact = irradiance([&](const Vec3& w) { return skyRadiance(sky, w)[k]; }, n);
            EXPECT_NEAR(e[k], exact, 1e-3 * exact) << "normal " << n.x << " " << n.y << " " << n.z << ", channel " << k;
        }
    }
}

}  // namespace
