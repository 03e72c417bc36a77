// The layered sky's precomputation and CPU twins (no GL): the column depths against their
// integral, the light tables (white furnace, no albedo, the flow of the sun's light, the frame's
// tables), the lighting file, the modulation texture and the near-LOD hook.
#include "nephele/layered.hpp"
#include "cache_test_util.hpp"
#include "temp_dir.hpp"

#include "../layered/src/layer_light.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

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
    s.photons = 256;  // the light tables' noise is not what most tests look at
    return s;
}

std::string tempPath(const std::string& name) {
    const auto dir = test::processPath("nephele_layered_test_");
    std::filesystem::create_directories(dir);
    return (dir / name).string();
}
}  // namespace

TEST(LayeredTest, ColumnDepthsAreTheIntegralOfTheThresholdedDensity) {
    const LightingSettings s = small();
    const LightingParameters p;
    const LightingVolume v = precomputeLighting(s, p);
    // At texel centres and at the knots' thresholds the stored depths are exact but for their
    // 8-bit encoding e = exp(-tau / 4): half a step of e is 4 (0.5 / 255) / e in tau.
    int checked = 0;
    double deepest = 0;
    for (int k = 0; k < s.depth; ++k)
        for (int j = 1; j < s.height; j += 5)
            for (int i = 2; i < s.width; i += 4)
                for (double theta : {0.25, 0.5, 0.75}) {
                    const double u = (i + 0.5) / s.width, w = (j + 0.5) / s.height, z = (k + 0.5) / s.depth;
                    const glm::dvec2 depths = v.columnDepths(u, w, z, theta, 0.7);
                    double above = 0, below = 0;  // the integral by a fine midpoint rule
                    const int steps = 4000;
                    for (int m = 0; m < steps; ++m) {
                        const double zz = (m + 0.5) / steps;
                        const double rho =
                            0.7 * p.extinction * std::max(v.sampleDensity(u, w, zz) - theta, 0.0) * p.thickness / steps;
                        (zz > z ? above : below) += rho;
                    }
                    auto tolerance = [](double tau) { return 0.7 * 4 * (0.5 / 255) * std::exp(tau / 0.7 / 4) + 0.01; };
                    EXPECT_NEAR(depths.x, above, tolerance(above)) << i << " " << j << " " << k << " theta " << theta;
                    // below = the column's depth minus the depth above: both encoded, their errors add.
                    EXPECT_NEAR(depths.y, below, tolerance(above + below) + tolerance(above))
                        << i << " " << j << " " << k << " theta " << theta;
                    deepest = std::max(deepest, above + below);
                    ++checked;
                }
    EXPECT_GT(checked, 100);
    EXPECT_GT(deepest, 3.0);  // optically thick columns are among them
    // No matter at or beyond theta = 1 (A <= 1).
    EXPECT_EQ(v.columnDepths(0.3, 0.3, 0.5, 1.0, 1.0), glm::dvec2(0.0));
}

TEST(LayeredTest, ZeroExtinctionLeavesNoDepthAndNoLight) {
    LightingParameters p;
    p.extinction = 0;
    const LightingVolume v = precomputeLighting(small(), p);
    EXPECT_EQ(v.columnDepths(0.4, 0.6, 0.3, 0.25, 1.0), glm::dvec2(0.0));
    for (const glm::vec4& x : v.tables.sun) EXPECT_EQ(x, glm::vec4(0.0f));
    for (const glm::vec4& x : v.tables.sky) EXPECT_EQ(x, glm::vec4(0.0f));
}

TEST(LayeredTest, SkyTablesConserveEnergyInAWhiteFurnace) {
    // Albedo 1 under radiance 1 from every direction (sky basis 0 from above plus basis 2 from
    // below): the radiance is 1 everywhere in the layer, so at every node the fluence is 4 pi,
    // the net flux and the zonal harmonic 0.
    LightingSettings s = small();
    s.photons = 1 << 14;  // the nodes' noise: about 1 / sqrt(scores per node)
    LightingParameters p;
    p.albedo = 1;
    const LightingVolume v = precomputeLighting(s, p);
    const LayerLightTables& t = v.tables;
    const std::size_t nodes = std::size_t(t.bins) * t.bins;
    double sum = 0, worst = 0, squares = 0;
    for (std::size_t n = 0; n < nodes; ++n) {
        const glm::vec4 a = t.sky[n], b = t.sky[2 * nodes + n];
        const double phi0 = (a.x + b.x) / (4 * kPi);
        sum += phi0;
        squares += (phi0 - 1) * (phi0 - 1);
        worst = std::max(worst, std::abs(phi0 - 1));
        EXPECT_NEAR((a.y + b.y) / (4 * kPi), 0, 0.15) << n;  // Monte Carlo noise of the nodes' few scores
        EXPECT_NEAR((a.z + b.z) / (4 * kPi), 0, 0.15) << n;
    }
    const double rms = std::sqrt(squares / nodes);
    std::printf("[ figure ] white furnace: mean fluence / 4 pi %.4f, rms %.3f, worst node %.3f off\n", sum / nodes, rms,
                worst);
    EXPECT_NEAR(sum / nodes, 1.0, 0.03);
    // The nodes' noise, as a whole and at the worst node. Both are properties of one draw of the
    // noise, not of the tables: the photons' paths change with the last bit of a sine or a log,
    // and another compiler's code draws another (same seeds; GCC -O2: rms 0.046, worst 0.224;
    // Clang -O1 + ASan: 0.076, 0.448). The bounds sit 1.5x and 1.3x over the worse draw: a
    // table gone wrong is off by far more.
    EXPECT_LT(rms, 0.12);
    EXPECT_LT(worst, 0.6);
}

TEST(LayeredTest, SunTablesHoldOnlyScatteredLightFlowingAwayFromTheSun) {
    LightingSettings s = small();
    s.photons = 1 << 11;
    LightingParameters p;
    p.albedo = 0;  // nothing is scattered: no diffuse light at all
    const LightingVolume dark = precomputeLighting(s, p);
    for (const auto* table : {&dark.tables.sun, &dark.tables.sunMany})
        for (const glm::vec4& x : *table) EXPECT_EQ(x, glm::vec4(0.0f));
    p.albedo = 0.99;
    const LightingVolume v = precomputeLighting(s, p);
    const LayerLightTables& t = v.tables;
    const std::size_t nodes = std::size_t(t.bins) * t.bins;
    // Per elevation, extinction-weighted over the nodes, the two parts together: the scattered
    // sunlight flows down and away from the sun (the sun lies along +x), and a higher sun lights
    // the layer more. (Overhead the horizontal flux is 0 but for the photons' noise: the two
    // parts' sum is negative, the few-times scattered part's alone was not.)
    double previous = 0;
    for (std::size_t k = 0; k < t.sunMu.size(); ++k) {
        glm::dvec3 sum(0.0), many(0.0);
        for (std::size_t n = 0; n < nodes; ++n) {
            sum += glm::dvec3(t.sun[k * nodes + n] + t.sunMany[k * nodes + n]);
            many += glm::dvec3(t.sunMany[k * nodes + n]);
        }
        EXPECT_GT(many.x, 0) << "mu " << t.sunMu[k];  // light scattered more than kFewScatterings times
        EXPECT_GT(sum.x, 0) << "mu " << t.sunMu[k];
        EXPECT_LT(sum.y, 0) << "mu " << t.sunMu[k];
        EXPECT_LT(sum.z, 0) << "mu " << t.sunMu[k];
        EXPECT_GT(sum.x, previous) << "mu " << t.sunMu[k];
        previous = sum.x;
    }
}

TEST(LayeredTest, FrameTablesFollowTheSunAndTheSky) {
    LightingSettings s = small();
    s.photons = 1 << 9;
    const LightingVolume v = precomputeLighting(s, LightingParameters{});
    const LayerLightTables& t = v.tables;
    const std::size_t nodes = std::size_t(t.bins) * t.bins;
    Scene scene;
    scene.sun.direction = glm::normalize(Vec3(0.6, 0.0, 0.8));
    scene.sun.direction.z = t.sunMu[3];  // exactly a tabulated elevation
    scene.sun.direction.x = std::sqrt(1 - t.sunMu[3] * t.sunMu[3]);
    const LayerFrameTables f = layerFrameTables(t, scene);
    for (std::size_t n = 0; n < nodes; n += 7) {
        EXPECT_NEAR(f.sun[n].x, t.sun[3 * nodes + n].x, 1e-6);
        EXPECT_NEAR(f.sun[n].z, t.sun[3 * nodes + n].z, 1e-6);
    }
    // Below the horizon: the column seen upside down (above and below swapped, flux up).
    Scene under = scene;
    under.sun.direction.z = -scene.sun.direction.z;
    const LayerFrameTables g = layerFrameTables(t, under);
    for (int j = 0; j < t.bins; j += 3)
        for (int i = 0; i < t.bins; i += 2) {
            EXPECT_NEAR(g.sun[t.node(i, j)].x, f.sun[t.node(j, i)].x, 1e-6);
            EXPECT_NEAR(g.sun[t.node(i, j)].z, -f.sun[t.node(j, i)].z, 1e-6);
        }
    // The sky's table is linear in the sky's colours; a black sky gives none.
    Scene bright = scene;
    bright.sky.zenith *= 2.0, bright.sky.horizon *= 2.0, bright.sky.ground *= 2.0;
    Scene black = scene;
    black.sky = {Vec3(0.0), Vec3(0.0), Vec3(0.0)};
    const LayerFrameTables b = layerFrameTables(t, bright), k = layerFrameTables(t, black);
    for (std::size_t n = 0; n < nodes; n += 5) {
        EXPECT_NEAR(b.sky[n].x, 2 * f.sky[n].x, 1e-5 * (1 + std::abs(f.sky[n].x)));  // (zenith - horizon can be < 0)
        EXPECT_NEAR(b.sun[n].w, 2 * f.sun[n].w, 1e-5 * (1 + std::abs(f.sun[n].w)));
        EXPECT_EQ(k.sky[n], glm::vec4(0.0f));
    }
    // A skylight adds its scattered light to the sun's fluence.
    Scene dusk = scene;
    dusk.skylight = Skylight{Vec3(0, 0, 1), Vec3(1.0), 1.5};
    const LayerFrameTables d = layerFrameTables(t, dusk);
    double more = 0;
    for (std::size_t n = 0; n < nodes; ++n) more += d.sun[n].x - f.sun[n].x;
    EXPECT_GT(more, 0);
}

TEST(LayeredTest, LightingFileRoundTripsAndRefusesMismatches) {
    const LightingSettings s = small();
    const LightingParameters p;
    const LightingVolume v = precomputeLighting(s, p);
    const std::string path = tempPath("light.bin");
    v.save(path);
    const LightingVolume w = LightingVolume::load(path, s, p);
    EXPECT_EQ(w.texels, v.texels);
    EXPECT_EQ(w.columns, v.columns);
    EXPECT_EQ(w.tables.sunMu, v.tables.sunMu);
    EXPECT_TRUE(w.tables.sun == v.tables.sun && w.tables.sky == v.tables.sky);

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
    EXPECT_NE(message(path, bigger, p).find("size is 16x16x8, expected 32x16x8"), std::string::npos)
        << message(path, bigger, p);
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
        EXPECT_NEAR(layerModulation(layer, a, ms, x + 60, 700 - 20, 10), layerModulation(layer, a, ms, x, 700, 0),
                    1e-6);
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
        // S = 1 - modulation where the sun ray crosses the layer's middle (sunTransmittance works
        // in float, as the shader it is compiled with: shaders/layer_shadow.glsl).
        const Vec3 q = ground + sun * (2200.0 / sun.z);
        EXPECT_NEAR(t, 1 - layerModulation(layer, m, ms, q.x, q.y, 0), 1e-6);
        shadowed += t < 1;
    }
    EXPECT_GT(shadowed, 5);
    EXPECT_EQ(sunTransmittance(layer, m, ms, sun, Vec3(0, 0, 3000), 0), 1.0);         // above the layer
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

// Optical depth past kMaxLightingOpticalDepth (extinction x thickness 1000) costs no more: a
// 10^9 m layer at extinction 10^4 (10^13, built in code; its photons' null collisions did not
// end in minutes before) is lit exactly as a layer of that thickness at the cap, in bounded
// time, and is dark inside (the knots above mid-height saturated).
TEST(LayeredTest, OpticalDepthsPastTheCapAreLitAsIt) {
    const LightingSettings s = small();
    LightingParameters huge;
    huge.extinction = 1e4;
    huge.thickness = 1e9;
    const auto start = std::chrono::steady_clock::now();
    const LightingVolume v = precomputeLighting(s, huge);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // 16x16x8 texels and 256 photons per source and threshold take well under a second alone;
    // 30 s leaves room for a machine shared by several test runs, and fails a hang.
    EXPECT_LT(seconds, 30.0);
    LightingParameters largest = huge;
    largest.extinction = kMaxLightingOpticalDepth / huge.thickness;
    const LightingVolume w = precomputeLighting(s, largest);
    EXPECT_TRUE(v.texels == w.texels);
    EXPECT_TRUE(v.columns == w.columns);
    EXPECT_TRUE(v.tables.sun == w.tables.sun);
    EXPECT_TRUE(v.tables.sky == w.tables.sky);
    for (double u : {0.1, 0.4, 0.7}) {
        const glm::dvec2 depths = v.columnDepths(u, 0.5, 0.5, 0.25, 1.0);
        EXPECT_GT(depths.x, 20.0) << u;  // the encoding's largest is 4 ln 512 = 24.95
    }
    for (const glm::vec4& x : v.tables.sun) EXPECT_TRUE(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z));
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
    expectRebuilt("a FIFO");                      // would block forever if opened as a file
    EXPECT_TRUE(std::filesystem::is_fifo(file));  // left alone: not a file to replace
    std::filesystem::remove_all(dir);
}
