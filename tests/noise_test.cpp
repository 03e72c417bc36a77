// Periodic Perlin noise, fBm and the tileable noise volume (no GL): determinism,
// periodicity, lattice zeros, continuity, rescaling and GL_LINEAR + GL_REPEAT sampling.
#include "nephele/noise.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

using namespace nephele;

namespace {

// Random points in [-range, range]^3 from raw mt19937 output (same on every platform).
std::vector<glm::vec3> randomPoints(int n, float range, unsigned seed = 7) {
    std::mt19937 rng(seed);
    const auto r = [&] { return (float(rng()) / 4294967296.0f * 2.0f - 1.0f) * range; };
    std::vector<glm::vec3> points(n);
    for (auto& p : points) p = {r(), r(), r()};
    return points;
}

const glm::vec3 kAxes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

TEST(NoiseTest, PerlinIsDeterministicAndDependsOnSeed) {
    int differ = 0;
    for (const auto& p : randomPoints(200, 20)) {
        EXPECT_EQ(perlinNoise(p, 8, 42), perlinNoise(p, 8, 42));
        if (std::abs(perlinNoise(p, 8, 42) - perlinNoise(p, 8, 43)) > 1e-3f) ++differ;
    }
    EXPECT_GT(differ, 180);  // another seed is another field, not a near copy
}

TEST(NoiseTest, PinnedValuesStayTheSame) {
    // Integer hash + float arithmetic: these must not change between platforms or
    // compilers (the tolerance allows for FMA contraction). A change here changes every
    // cloud rendered with a given seed, so it has to be deliberate.
    EXPECT_NEAR(perlinNoise({0.3f, 1.7f, 2.2f}, 8, 1), 0.0231955722, 1e-5);
    EXPECT_NEAR(perlinNoise({-5.25f, 3.5f, 0.125f}, 4, 123456789u), 0.368702799, 1e-5);
    EXPECT_NEAR(fbm({1.1f, 2.2f, 3.3f}, 5, 8, 7), 0.157833189, 1e-5);
}

TEST(NoiseTest, PerlinIsZeroAtLatticePoints) {
    for (int i = -3; i <= 9; ++i)
        for (int j = -3; j <= 9; j += 3)
            for (int k = -3; k <= 9; k += 4) EXPECT_EQ(perlinNoise(glm::vec3(i, j, k), 8, 5), 0.0f);
    EXPECT_NE(perlinNoise({0.5f, 0.5f, 0.5f}, 8, 5), 0.0f);
}

TEST(NoiseTest, PerlinIsPeriodic) {
    for (int period : {1, 3, 8}) {
        for (const auto& p : randomPoints(100, 10)) {
            const float v = perlinNoise(p, period, 9);
            for (const auto& a : kAxes) {
                EXPECT_NEAR(perlinNoise(p + a * float(period), period, 9), v, 1e-4f);
                EXPECT_NEAR(perlinNoise(p - a * float(2 * period), period, 9), v, 1e-4f);
            }
        }
    }
    // ...and not periodic with a shorter shift: the check above can fail.
    int differ = 0;
    for (const auto& p : randomPoints(100, 10))
        if (std::abs(perlinNoise(p + glm::vec3(3, 0, 0), 8, 9) - perlinNoise(p, 8, 9)) > 1e-3f) ++differ;
    EXPECT_GT(differ, 80);
}

TEST(NoiseTest, PerlinRangeAndStatistics) {
    double sum = 0, sum2 = 0;
    float lo = 1e9f, hi = -1e9f;
    const auto points = randomPoints(100000, 32);
    for (const auto& p : points) {
        const float v = perlinNoise(p, 16, 3);
        sum += v;
        sum2 += double(v) * v;
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    const double mean = sum / points.size(), sd = std::sqrt(sum2 / points.size() - mean * mean);
    EXPECT_GE(lo, -1.05f);
    EXPECT_LE(hi, 1.05f);
    EXPECT_LT(lo, -0.5f);  // uses a good part of the range
    EXPECT_GT(hi, 0.5f);
    EXPECT_NEAR(mean, 0.0, 0.02);
    EXPECT_GT(sd, 0.1);
}

TEST(NoiseTest, PerlinIsContinuous) {
    // Small steps anywhere, and across cell faces and the period seam (x = 8 = 0).
    for (const auto& p : randomPoints(500, 12))
        for (const auto& a : kAxes) EXPECT_NEAR(perlinNoise(p + a * 1e-3f, 8, 11), perlinNoise(p, 8, 11), 1e-2f);
    for (const auto& p : randomPoints(100, 12)) {
        for (float face : {-1.0f, 0.0f, 3.0f, 8.0f}) {
            const glm::vec3 q(face, p.y, p.z);
            EXPECT_NEAR(perlinNoise(q - glm::vec3(1e-3f, 0, 0), 8, 11), perlinNoise(q + glm::vec3(1e-3f, 0, 0), 8, 11),
                        1e-2f);
        }
    }
}

TEST(NoiseTest, FbmOfOneOctaveIsPerlin) {
    for (const auto& p : randomPoints(100, 10)) EXPECT_EQ(fbm(p, 1, 8, 21), perlinNoise(p, 8, 21));
}

TEST(NoiseTest, FbmIsDeterministicPeriodicAndContinuous) {
    int differ = 0;
    for (const auto& p : randomPoints(200, 10)) {
        const float v = fbm(p, 5, 4, 17);
        EXPECT_EQ(fbm(p, 5, 4, 17), v);
        if (std::abs(fbm(p, 5, 4, 18) - v) > 1e-3f) ++differ;
        if (std::abs(fbm(p, 4, 4, 17) - v) > 1e-3f) ++differ;  // octaves matter
        EXPECT_LE(std::abs(v), 1.05f);
        // Every octave repeats every 4 (octave o: period 4 * 2^o at frequency 2^o).
        for (const auto& a : kAxes) EXPECT_NEAR(fbm(p + a * 4.0f, 5, 4, 17), v, 2e-4f);
        // The finest octave has frequency 16: a step of 1e-4 is 1.6e-3 of its cell.
        for (const auto& a : kAxes) EXPECT_NEAR(fbm(p + a * 1e-4f, 5, 4, 17), v, 5e-3f);
    }
    EXPECT_GT(differ, 360);
}

TEST(NoiseTest, InvalidArgumentsThrow) {
    EXPECT_THROW(perlinNoise({0, 0, 0}, 0, 1), std::invalid_argument);
    EXPECT_THROW(fbm({0, 0, 0}, 0, 4, 1), std::invalid_argument);
    EXPECT_THROW(fbm({0, 0, 0}, 30, 4, 1), std::invalid_argument);  // period 4 * 2^29 overflows
    EXPECT_THROW(makeNoiseVolume(1, 4, 3, 1), std::invalid_argument);
    EXPECT_THROW(makeNoiseVolume(16, 0, 3, 1), std::invalid_argument);
    EXPECT_THROW(makeNoiseVolume(16, 4, 0, 1), std::invalid_argument);
}

// A volume built once for the tests below: 16^3 texels over 4 lattice cells, 3 octaves.
const NoiseVolume& volume16() {
    static const NoiseVolume v = makeNoiseVolume(16, 4, 3, 99);
    return v;
}
float texel(const NoiseVolume& v, int i, int j, int k) {
    const auto w = [&](int a) { return ((a % v.size) + v.size) % v.size; };
    return v.texels[w(i) + v.size * (w(j) + v.size * w(k))];
}

TEST(NoiseTest, VolumeIsDeterministicAndDependsOnSeed) {
    const NoiseVolume& a = volume16();
    ASSERT_EQ(a.size, 16);
    ASSERT_EQ(a.texels.size(), 16u * 16 * 16);
    EXPECT_EQ(makeNoiseVolume(16, 4, 3, 99).texels, a.texels);
    EXPECT_NE(makeNoiseVolume(16, 4, 3, 100).texels, a.texels);
}

TEST(NoiseTest, VolumeIsRescaledFbmWithZeroMeanAndUnitMax) {
    // Where size is a multiple of cells, the texels sit symmetrically around every lattice
    // point and Perlin noise (odd about each lattice point) already averages to 0; with
    // 12 texels over 5 cells the raw mean is about 1e-3, so that the centring is tested.
    for (const NoiseVolume& w : {volume16(), makeNoiseVolume(12, 5, 3, 99)}) {
        double sum = 0;
        float largest = 0;
        for (float t : w.texels) {
            sum += t;
            largest = std::max(largest, std::abs(t));
        }
        EXPECT_NEAR(sum / w.texels.size(), 0.0, 1e-6) << "size " << w.size;
        EXPECT_EQ(largest, 1.0f) << "size " << w.size;
    }
    const NoiseVolume& v = volume16();
    // texel = (fbm(((i,j,k) + 0.5) * cells / size) - mean) * s with one s > 0 for all texels.
    const auto raw = [](int i, int j, int k) { return fbm((glm::vec3(i, j, k) + 0.5f) * 0.25f, 3, 4, 99); };
    const float s = (texel(v, 3, 5, 7) - texel(v, 0, 0, 0)) / (raw(3, 5, 7) - raw(0, 0, 0));
    EXPECT_GT(s, 0.0f);
    for (int n = 0; n < 50; ++n) {
        const int i = (n * 7) % 16, j = (n * 5 + 3) % 16, k = (n * 11 + 1) % 16;
        EXPECT_NEAR(texel(v, i, j, k) - texel(v, 0, 0, 0), s * (raw(i, j, k) - raw(0, 0, 0)), 1e-4f)
            << i << " " << j << " " << k;
    }
}

TEST(NoiseTest, SampleMatchesTexelsAtCentresAndMeansMidway) {
    const NoiseVolume& v = volume16();
    const float n = float(v.size);
    for (int k = 0; k < v.size; k += 3)
        for (int j = 0; j < v.size; j += 2)
            for (int i = 0; i < v.size; ++i) {
                const glm::vec3 centre = (glm::vec3(i, j, k) + 0.5f) / n;
                EXPECT_EQ(v.sample(centre), texel(v, i, j, k));
                // Midway to the next centre along each axis, including from texel 15 to
                // texel 0 across the repeat seam (uvw = 1 = 0).
                for (int a = 0; a < 3; ++a) {
                    glm::ivec3 next(i, j, k);
                    next[a] += 1;
                    const float mean = 0.5f * (texel(v, i, j, k) + texel(v, next.x, next.y, next.z));
                    EXPECT_FLOAT_EQ(v.sample(centre + kAxes[a] * (0.5f / n)), mean)
                        << i << " " << j << " " << k << " axis " << a;
                }
            }
}

TEST(NoiseTest, SampleIsLinearRepeatOnARamp) {
    // Hand-computed GL_LINEAR + GL_REPEAT on a 4^3 ramp texel(i,j,k) = i: centres at
    // u = 0.125, 0.375, ...; between the last centre (0.875) and the first (1.125 = 0.125)
    // it interpolates 3 -> 0 through the seam.
    NoiseVolume ramp{4, {}};
    for (int n = 0; n < 64; ++n) ramp.texels.push_back(float(n % 4));
    const struct {
        float u, expected;
    } cases[] = {{0.125f, 0},  {0.25f, 0.5f},    {0.5f, 1.5f}, {0.875f, 3},      {0.9375f, 2.25f}, {1.0f, 1.5f},
                 {0.0f, 1.5f}, {0.0625f, 0.75f}, {-0.125f, 3}, {2.3125f, 0.75f}, {-1.75f, 0.5f}};
    for (const auto& c : cases)
        for (float yz : {0.1f, 0.6f, -3.3f}) EXPECT_FLOAT_EQ(ramp.sample({c.u, yz, yz}), c.expected) << "u " << c.u;
    EXPECT_EQ(NoiseVolume{}.sample({0.5f, 0.5f, 0.5f}), 0.0f);
}

TEST(NoiseTest, VolumeTilesAndSampleIsContinuous) {
    const NoiseVolume& v = volume16();
    for (const auto& p : randomPoints(300, 2)) {
        const float s = v.sample(p);
        for (const auto& a : kAxes) {
            EXPECT_NEAR(v.sample(p + a), s, 1e-5f);
            EXPECT_NEAR(v.sample(p - a * 3.0f), s, 1e-5f);
            EXPECT_NEAR(v.sample(p + a * 1e-4f), s, 1e-2f);
        }
    }
    // The seam is no edge: the largest step between neighbouring texels across it
    // (texel 15 -> texel 0) is no larger than the largest step inside the volume.
    float inside = 0, seam = 0;
    for (int k = 0; k < 16; ++k)
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i)
                for (const glm::ivec3 d : {glm::ivec3(1, 0, 0), glm::ivec3(0, 1, 0), glm::ivec3(0, 0, 1)}) {
                    const glm::ivec3 q = glm::ivec3(i, j, k) + d;
                    const float step = std::abs(texel(v, q.x, q.y, q.z) - texel(v, i, j, k));
                    float& largest = (q.x == 16 || q.y == 16 || q.z == 16) ? seam : inside;
                    largest = std::max(largest, step);
                }
    EXPECT_GT(seam, 0.0f);
    EXPECT_LE(seam, inside);
}

}  // namespace
