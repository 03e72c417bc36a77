// The layered sky's precomputation and CPU twins (no GL): the phase function, the
// scattering recurrences on known cases, the 8-bit vector encoding, the lighting file, the
// modulation texture and the near-LOD hook.
#include "nephele/layered.hpp"
#include "cache_test_util.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

using namespace nephele;

namespace {
constexpr double kPi = 3.14159265358979323846;

LightingSettings small() {
    LightingSettings s;
    s.width = 16, s.height = 16, s.depth = 8;
    return s;
}

std::string tempPath(const std::string& name) {
    const auto dir = std::filesystem::temp_directory_path() / ("nephele_layered_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
    std::filesystem::create_directories(dir);
    return (dir / name).string();
}
}  // namespace

TEST(LayeredTest, CornetteShanksIntegratesToOneOverTheSphere) {
    for (double f : {0.0, 0.3, 0.6, 0.85}) {
        // Midpoint rule in mu = cos(theta); the peak at mu = 1 for f = 0.85 is narrow, so many
        // steps: 1e6 keeps the error far below the 1e-3 asked for.
        const int n = 1000000;
        double sum = 0;
        for (int i = 0; i < n; ++i) {
            const double mu = -1 + (i + 0.5) * 2.0 / n;
            sum += cornetteShanks(mu, f) * 2 * kPi * (2.0 / n);
        }
        EXPECT_NEAR(sum / (4 * kPi), 1.0, 1e-3) << "f = " << f;
    }
    // f = 0 is Rayleigh: 3/4 (1 + cos^2).
    EXPECT_NEAR(cornetteShanks(0.0, 0.0), 0.75, 1e-12);
    EXPECT_NEAR(cornetteShanks(1.0, 0.0), 1.5, 1e-12);
}

TEST(LayeredTest, ZeroExtinctionTransmitsEverythingAndScattersNothing) {
    const std::vector<double> taus(20, 0.0);
    double exit = 0;
    const std::vector<double> inc = forwardScatter(taus, 0.7, 1.0, &exit);
    for (double i : inc) EXPECT_DOUBLE_EQ(i, 1.0);
    EXPECT_DOUBLE_EQ(exit, 1.0);
    EXPECT_DOUBLE_EQ(eyeScatter(taus, inc, 0.99, 50.0), 0.0);

    // The whole volume with zero extinction: intensity 1 everywhere (the vector is the
    // zenith of length 1), no eye scattering.
    LightingParameters p;
    p.extinction = 0;
    const LightingVolume v = precomputeLighting(small(), p);
    for (int k = 0; k < 8; ++k)
        for (int j = 0; j < 16; j += 5)
            for (int i = 0; i < 16; i += 3) {
                const glm::dvec3 n = v.vectorAt(i, j, k);
                EXPECT_NEAR(n.x, 0, 1.0 / 255) << i << " " << j << " " << k;
                EXPECT_NEAR(n.y, 0, 1.0 / 255);
                EXPECT_NEAR(n.z, 1, 1.0 / 255);  // 8-bit quantisation
            }
    EXPECT_EQ(v.eyeScatterPeak, 0.0);
}

TEST(LayeredTest, RecurrencesOnAHomogeneousSlabMatchTheClosedForm) {
    // n equal particles of depth tau: I_k = I0 q^(k-1) with q = T + c tau, and
    // E_n = a tau F / 4pi I0 (q^n - T^n) / (q - T).
    const int n = 40;
    const double tau = 0.05, c = 0.6, a = 0.9, phase = 12.0, i0 = 2.0;
    const std::vector<double> taus(n, tau);
    double exit = 0;
    const std::vector<double> inc = forwardScatter(taus, c, i0, &exit);
    const double T = std::exp(-tau), q = T + c * tau;
    for (int k = 1; k <= n; ++k) EXPECT_NEAR(inc[k - 1], i0 * std::pow(q, k - 1), 1e-12);
    EXPECT_NEAR(exit, i0 * std::pow(q, n), 1e-12);
    const double e = eyeScatter(taus, inc, a, phase);
    const double closed = a * tau * phase / (4 * kPi) * i0 * (std::pow(q, n) - std::pow(T, n)) / (q - T);
    EXPECT_NEAR(e, closed, 1e-12);
    // Forward scattering keeps more light than extinction alone.
    EXPECT_GT(exit, i0 * std::exp(-n * tau));
}

TEST(LayeredTest, ForwardCoefficientFollowsTheConeAndNeverExceedsTheAlbedo) {
    const double c10 = forwardCoefficient(0.99, 0.85, 10), c5 = forwardCoefficient(0.99, 0.85, 5);
    EXPECT_GT(c10, c5);
    const double gamma = 2 * kPi * (1 - std::cos(10 * kPi / 180));
    EXPECT_NEAR(c10, 0.99 * cornetteShanks(1, 0.85) * gamma / (4 * kPi), 1e-12);
    EXPECT_LE(forwardCoefficient(0.99, 0.85, 90), 0.99);
}

TEST(LayeredTest, VectorEncodingRoundTripsWithinEightBits) {
    for (int i = 0; i <= 2000; ++i) {
        const double n = -1 + i / 1000.0;
        EXPECT_LE(std::abs(decodeComponent(encodeComponent(n)) - n), 1.0 / 255 + 1e-12) << n;  // half a step of n/2+0.5 is 1/255 of n
    }
    EXPECT_EQ(encodeComponent(0.0), 128);  // 127.5 rounds up
    EXPECT_EQ(encodeComponent(1.0), 255);
    EXPECT_EQ(encodeComponent(-1.0), 0);
}

TEST(LayeredTest, LightDecreasesDownwardsThroughTheLayer) {
    const LightingVolume v = precomputeLighting(small(), LightingParameters{});
    // Mean intensity (vector length) per slice: the top is lit, the bottom darker.
    auto sliceMean = [&](int k) {
        double s = 0;
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i) s += glm::length(v.vectorAt(i, j, k));
        return s / 256;
    };
    EXPECT_GT(sliceMean(7), 0.95);
    EXPECT_LT(sliceMean(0), sliceMean(7) - 0.2);
    for (int k = 0; k < 7; ++k) EXPECT_LE(sliceMean(k), sliceMean(k + 1) + 2.0 / 255) << k;
    EXPECT_GT(v.eyeScatterPeak, 0);
    // phi: F(phi) = 10% of F(0).
    const double phi = std::acos(v.eyeScatterCosPhi);
    EXPECT_NEAR(cornetteShanks(std::cos(phi), 0.85) / cornetteShanks(1, 0.85), 0.1, 1e-6);
}

TEST(LayeredTest, LightingFileRoundTripsAndRefusesMismatches) {
    const LightingSettings s = small();
    const LightingParameters p;
    const LightingVolume v = precomputeLighting(s, p);
    const std::string path = tempPath("light.bin");
    v.save(path);
    const LightingVolume w = LightingVolume::load(path, s, p);
    EXPECT_EQ(w.texels, v.texels);
    EXPECT_EQ(w.eyeScatterPeak, v.eyeScatterPeak);
    EXPECT_EQ(w.eyeScatterCosPhi, v.eyeScatterCosPhi);

    auto message = [&](const std::string& file, const LightingSettings& es, const LightingParameters& ep) {
        try {
            LightingVolume::load(file, es, ep);
        } catch (const LightingFileError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    LightingSettings bigger = s;
    bigger.width = 32;
    EXPECT_NE(message(path, bigger, p).find("size is 16x16x8, expected 32x16x8"), std::string::npos) << message(path, bigger, p);
    LightingParameters thicker = p;
    thicker.thickness = 900;
    EXPECT_NE(message(path, s, thicker).find("thickness is 600, expected 900"), std::string::npos);
    // Corrupt: one byte changed, truncated, a missing file. The checksum catches the first two
    // before anything in them is read.
    {
        std::string bytes;
        {
            std::ifstream in(path, std::ios::binary);
            bytes.assign(std::istreambuf_iterator<char>(in), {});
        }
        std::string bad = bytes;
        bad[0] = 'X';
        std::ofstream(tempPath("magic.bin"), std::ios::binary) << bad;
        EXPECT_NE(message(tempPath("magic.bin"), s, p).find("checksum mismatch"), std::string::npos);
        std::ofstream(tempPath("short.bin"), std::ios::binary) << bytes.substr(0, bytes.size() - 10);
        EXPECT_NE(message(tempPath("short.bin"), s, p).find("checksum mismatch"), std::string::npos);
        EXPECT_NE(message(tempPath("missing.bin"), s, p).find("cannot open"), std::string::npos);
    }
    // The cache: a second call loads what the first saved (precomputeMs 0 when loaded).
    const std::string dir = tempPath("cache");
    std::filesystem::remove_all(dir);
    const LightingVolume first = lightingCached(s, p, dir);
    EXPECT_GT(first.precomputeMs, 0);
    const LightingVolume second = lightingCached(s, p, dir);
    EXPECT_EQ(second.precomputeMs, 0);
    EXPECT_EQ(second.texels, first.texels);
    std::filesystem::remove_all(std::filesystem::path(path).parent_path());
}

TEST(LayeredTest, ModulationIsDeterministicAndCoverageFollowsC) {
    ModulationSettings ms;
    ms.size = 64;
    const ModulationTexture a = makeModulation(ms, 7), b = makeModulation(ms, 7), c = makeModulation(ms, 8);
    EXPECT_EQ(a.texels, b.texels);
    EXPECT_NE(a.texels, c.texels);
    Layer layer;
    layer.base = 2000, layer.thickness = 500;
    for (double cov : {0.0, 0.3, 0.6}) {
        layer.coverage = cov;
        int covered = 0, total = 0;
        for (int j = 0; j < 64; ++j)
            for (int i = 0; i < 64; ++i, ++total)
                covered += layerModulation(layer, a, ms, (i + 0.5) / 64 * ms.period, (j + 0.5) / 64 * ms.period, 0) > 0;
        // r is uniform on [0, maxThreshold]: the covered fraction is C / maxThreshold (2% for
        // the bilinear sampling and the discrete ranks).
        EXPECT_NEAR(double(covered) / total, std::min(cov / ms.maxThreshold, 1.0), 0.02) << cov;
    }
    // Wind: the pattern at time t is the pattern at t = 0 moved by t * wind.
    layer.coverage = 0.5;
    layer.wind = {6, -2};
    for (double x : {100.0, 2345.0})
        EXPECT_NEAR(layerModulation(layer, a, ms, x + 60, 700 - 20, 10), layerModulation(layer, a, ms, x, 700, 0), 1e-6);
}

TEST(LayeredTest, NearFadeAndShadow) {
    LayeredSettings s;
    s.nearRadius = 1000;
    s.blendBand = 500;
    EXPECT_EQ(nearFade(s, 0), 0.0);
    EXPECT_EQ(nearFade(s, 999), 0.0);
    EXPECT_NEAR(nearFade(s, 1250), 0.5, 1e-12);
    EXPECT_EQ(nearFade(s, 1500), 1.0);
    EXPECT_EQ(nearFade(s, 1e6), 1.0);
    s.blendBand = 0;
    EXPECT_EQ(nearFade(s, 1000), 1.0);

    ModulationSettings ms;
    ms.size = 32;
    const ModulationTexture m = makeModulation(ms, 3);
    Layer layer;
    layer.base = 2000, layer.thickness = 400, layer.coverage = 0.6, layer.density = 0.8;
    const Vec3 sun = glm::normalize(Vec3(0.3, 0.2, 0.9));
    int shadowed = 0;
    for (int i = 0; i < 50; ++i) {
        const Vec3 ground(i * 517.0, i * 211.0, 0.0);
        const double t = sunTransmittance(layer, m, ms, sun, ground, 0);
        EXPECT_GE(t, 1 - layer.density);
        EXPECT_LE(t, 1.0);
        // S = 1 - modulation where the sun ray crosses the layer's middle.
        const Vec3 q = ground + sun * (2200.0 / sun.z);
        EXPECT_NEAR(t, 1 - layerModulation(layer, m, ms, q.x, q.y, 0), 1e-12);
        shadowed += t < 1;
    }
    EXPECT_GT(shadowed, 5);
    EXPECT_EQ(sunTransmittance(layer, m, ms, sun, Vec3(0, 0, 3000), 0), 1.0);       // above the layer
    EXPECT_EQ(sunTransmittance(layer, m, ms, Vec3(1, 0, 0), Vec3(0, 0, 0), 0), 1.0);  // sun on the horizon
}

TEST(LayeredTest, BadSettingsAreRefusedByName) {
    LayeredSettings s;
    s.layers = 1;
    EXPECT_THROW(validate(s), std::invalid_argument);
    try {
        validate(s);
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("layers (N)"), std::string::npos);
    }
    LightingSettings ls = small();
    ls.depth = 1;
    EXPECT_THROW(precomputeLighting(ls, LightingParameters{}), std::invalid_argument);
}

// The closed form of a slice's particles (lightColumn) against the particles one by one
// (forwardScatter and eyeScatter over each slice split into ceil(tau / 0.1) equal particles,
// as the precomputation did before): the same light to round-off, from thin slices to thick.
TEST(LayeredTest, LightColumnSumsEachSlicesParticlesInClosedForm) {
    const double forward = forwardCoefficient(0.99, 0.85, 10), phase = cornetteShanks(1, 0.85);
    for (const std::vector<double>& slices : {std::vector<double>{0.05, 0.0, 0.37, 1.3}, std::vector<double>{2.9, 0.8, 7.5},
                                              std::vector<double>{0.1, 25.0, 0.2, 3.0}}) {
        std::vector<double> particles;
        std::vector<std::size_t> first;  // the first particle of each slice
        for (double tau : slices) {
            const int n = std::max(1, int(std::ceil(tau / 0.1)));
            first.push_back(particles.size());
            for (int m = 0; m < n; ++m) particles.push_back(tau / n);
        }
        const std::vector<double> inc = forwardScatter(particles, forward);
        const double eye = eyeScatter(particles, inc, 0.99, phase);
        std::vector<double> incident;
        const double got = lightColumn(slices, forward, 0.99, phase, incident);
        ASSERT_EQ(incident.size(), slices.size());
        // Relative 1e-9: the closed form's logarithms and exponentials against a product of up
        // to 250 factors, both in double.
        EXPECT_NEAR(got, eye, 1e-9 * std::fabs(eye));
        for (std::size_t k = 0; k < slices.size(); ++k) EXPECT_NEAR(incident[k], inc[first[k]], 1e-9 * inc[first[k]]) << k;
    }
}

// Optical depth does not cost time or memory: one slice of tau 1e12 (a 1e9 m thick layer at
// extinction 0.04 would have made 10^13 particles, 5 GB and minutes before) is one step, and
// the light below it is gone; an extinction of 1e4 precomputes a volume like any other.
TEST(LayeredTest, HugeOpticalDepthsCostNoMoreThanThinOnes) {
    const double forward = forwardCoefficient(0.99, 0.85, 10), phase = cornetteShanks(1, 0.85);
    std::vector<double> incident;
    const double eye = lightColumn({1e12, 1e300, 5.0}, forward, 0.99, phase, incident);
    EXPECT_TRUE(std::isfinite(eye));
    EXPECT_EQ(incident[1], 0.0);  // nothing passes 1e12 of optical depth
    EXPECT_EQ(incident[2], 0.0);
    LightingSettings s = small();
    LightingParameters p;
    p.extinction = 1e4;
    p.thickness = 1e9;
    const auto start = std::chrono::steady_clock::now();
    const LightingVolume v = precomputeLighting(s, p);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // 16x16x8 texels take milliseconds; 10 s leaves room for a loaded machine while the old
    // per-particle loop needed over 120 s for less.
    EXPECT_LT(seconds, 10.0);
    for (int k = 0; k + 1 < s.depth; ++k) EXPECT_LE(glm::length(v.vectorAt(3, 3, k)), 2.0 / 255 + 1e-9) << k;  // dark below the top
    EXPECT_TRUE(std::isfinite(v.eyeScatterPeak));
}

// A cache file damaged in its last 4 KiB, truncated, or replaced by a FIFO is not used: the
// volume is computed again (the same texels), with a warning through the log callback, and a
// FIFO in its place does not block the reader.
TEST(LayeredTest, DamagedOrSpecialCacheFilesAreRebuiltWithAWarning) {
    LightingSettings s = small();
    s.width = s.height = 64;  // a file of over 4 KiB of texels
    const LightingParameters p;
    const std::string dir = tempPath("damaged_cache");
    std::filesystem::remove_all(dir);
    const LightingVolume good = lightingCached(s, p, dir);
    std::filesystem::path file;
    for (const auto& e : std::filesystem::directory_iterator(dir)) file = e.path();
    ASSERT_FALSE(file.empty());
    test::WarningCapture log;
    auto expectRebuilt = [&](const char* what) {
        log.warnings.clear();
        const LightingVolume again = lightingCached(s, p, dir);
        EXPECT_GT(again.precomputeMs, 0) << what << ": the damaged file was used";
        EXPECT_EQ(again.texels, good.texels) << what;
        ASSERT_FALSE(log.warnings.empty()) << what;
        EXPECT_NE(log.warnings[0].find(file.filename().string()), std::string::npos) << log.warnings[0];
    };
    test::overwriteTail(file, 4096, '\x5a');
    expectRebuilt("last 4 KiB overwritten");
    std::filesystem::resize_file(file, std::filesystem::file_size(file) / 2);
    expectRebuilt("truncated");
    ASSERT_TRUE(test::replaceWithFifo(file));
    expectRebuilt("a FIFO");  // would block forever if opened as a file
    EXPECT_TRUE(std::filesystem::is_fifo(file));  // left alone: not a file to replace
    std::filesystem::remove_all(dir);
}
