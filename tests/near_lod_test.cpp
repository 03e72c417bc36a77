// The near LOD's cells without GL: determinism, which cells spawn and retire, where the
// clouds lie, wind, and the weights across the blend band.
#include "nephele/near_lod.hpp"

#include "../layered/internal/layer_assets.hpp"
#include "layered_test_util.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>

using namespace nephele;

namespace {

constexpr double kBase = 2000, kThickness = 600, kNear = 2000, kBand = 1500;

Scene layerScene(Vec2 wind = Vec2(0.0), bool nearLod = true) {
    Scene s;
    Layer l;
    l.base = kBase, l.thickness = kThickness, l.coverage = 0.6, l.density = 0.8, l.seed = 3, l.wind = wind;
    l.nearLod = nearLod;
    s.layers.push_back(l);
    return s;
}

LayeredSettings layeredSettings() {
    // 128^2 modulation (the pattern's period stays 30 km: a few ms to make), a 64 x 64 x 8
    // lighting volume (its period stays 8 km).
    LayeredSettings s = test::smallLayered(128, 64);
    s.nearRadius = kNear, s.blendBand = kBand;
    s.cacheDir = test::runCacheDir();  // under ctest, each coverage's lighting traced once per run
    return s;
}

bool sameCloud(const Cloud& a, const Cloud& b) {
    if (a.ellipsoids.size() != b.ellipsoids.size() || a.noiseId != b.noiseId) return false;
    for (std::size_t k = 0; k < a.ellipsoids.size(); ++k) {
        const Ellipsoid &x = a.ellipsoids[k], &y = b.ellipsoids[k];
        if (x.center != y.center || x.radii != y.radii || x.rotationDeg != y.rotationDeg || x.density != y.density)
            return false;
    }
    return true;
}

// One LayerAssets for every NearLod of the test: the layer's lighting volume (photons traced
// through it, most of the CPU of a first update) is made once per coverage, not once per NearLod.
const std::shared_ptr<LayerAssets>& assets() {
    static const auto shared = std::make_shared<LayerAssets>(layeredSettings());
    return shared;
}
NearLod& sharing(NearLod& lod) {
    lod.shareAssets(assets());
    return lod;
}

// The layer's lighting volume, as NearLod makes it.
std::shared_ptr<const LightingVolume> layerLight(const Scene& scene) {
    return assets()->lighting(lightingParameters(scene.medium, scene.layers[0]));
}

using Key = std::tuple<int, std::int64_t, std::int64_t>;
std::set<Key> keys(const NearLod& lod) {
    std::set<Key> out;
    for (const NearCell* c : lod.cells()) out.insert({c->layer, c->i, c->j});
    return out;
}

}  // namespace

TEST(NearLodTest, SameCellSameCloudWhateverTheEyePath) {
    const Scene scene = layerScene();
    NearLod a({}, layeredSettings()), b({}, layeredSettings());
    sharing(a), sharing(b);
    // a comes from the west in 300 m steps, b from the north-east in 700 m steps; both end at the origin.
    for (int k = 20; k >= 0; --k) a.update(scene, Vec3(-300.0 * k, 0, 1000), 0);
    for (int k = 12; k >= 0; --k) b.update(scene, Vec3(500.0 * k, 500.0 * k, 1000), 0);
    ASSERT_EQ(keys(a), keys(b));
    const auto ca = a.cells(), cb = b.cells();
    int clouds = 0;
    const auto lightHeld = layerLight(scene);
    const LightingVolume& light = *lightHeld;
    const ModulationTexture modulation = makeModulation(layeredSettings().modulation, 3);
    for (std::size_t k = 0; k < ca.size(); ++k) {
        EXPECT_TRUE(sameCloud(ca[k]->cloud, cb[k]->cloud)) << ca[k]->cloud.name;
        // and the same as a cell made from scratch
        const NearLodSettings ns;
        const NearCell fresh =
            makeNearCell(scene, 0, ca[k]->i, ca[k]->j, ns, modulation, layeredSettings().modulation, light);
        EXPECT_TRUE(sameCloud(ca[k]->cloud, fresh.cloud)) << ca[k]->cloud.name;
        clouds += !ca[k]->cloud.ellipsoids.empty();
    }
    EXPECT_GT(clouds, 5);  // coverage 0.6: many cells hold a cloud
}

TEST(NearLodTest, OnlyCellsWithinReachSpawnAndTheyRetire) {
    const Scene scene = layerScene();
    const NearLodSettings ns;
    NearLod lod(ns, layeredSettings());
    sharing(lod);
    const double reach = kNear + kBand;
    NearLodStats st;
    lod.update(scene, Vec3(123, -456, 500), 0, &st);
    EXPECT_EQ(st.generated, st.cells);
    EXPECT_EQ(st.retired, 0);
    // Every cell within reach and no other: check a wider grid of spawn points.
    const auto have = keys(lod);
    const auto modulation = makeModulation(layeredSettings().modulation, 3);
    const auto lightHeld = layerLight(scene);
    const LightingVolume& light = *lightHeld;
    int inside = 0;
    for (std::int64_t j = -8; j <= 8; ++j)
        for (std::int64_t i = -8; i <= 8; ++i) {
            const NearCell c = makeNearCell(scene, 0, i, j, ns, modulation, layeredSettings().modulation, light);
            const bool near = glm::length(c.spawn - Vec2(123, -456)) < reach;
            inside += near;
            EXPECT_EQ(have.count({0, i, j}) == 1, near) << i << "," << j;
        }
    EXPECT_EQ(inside, st.cells);
    // 10 km east: nothing in common; every old cell retires, every new one is generated.
    const int before = st.cells;
    lod.update(scene, Vec3(10123, -456, 500), 0, &st);
    EXPECT_EQ(st.retired, before);
    EXPECT_EQ(st.generated, st.cells);
    for (const NearCell* c : lod.cells()) EXPECT_LT(glm::length(c->spawn - Vec2(10123, -456)), reach);
    // A small step: only the cells crossing the reach change; the others are kept, not remade.
    lod.update(scene, Vec3(10323, -456, 500), 0, &st);
    EXPECT_LT(st.generated, st.cells / 2);
    EXPECT_GT(st.generated + st.retired, 0);
}

TEST(NearLodTest, CloudsLieInTheLayerWhereItHasCloud) {
    const Vec2 wind(6, 2);
    const Scene scene = layerScene(wind);
    NearLod lod({}, layeredSettings());
    sharing(lod);
    const auto modulation = makeModulation(layeredSettings().modulation, 3);
    for (double t : {0.0, 250.0}) {
        NearLodStats st;
        const Vec3 eye(-700, 300, 1500);
        const std::vector<Cloud> clouds = lod.update(scene, eye, t, &st);
        ASSERT_GT(st.clouds, 5);
        EXPECT_EQ(int(clouds.size()), st.clouds);
        const auto cells = lod.cells();
        std::size_t k = 0;
        for (const NearCell* c : cells) {
            if (c->cloud.ellipsoids.empty()) {
                EXPECT_EQ(c->cover, 0.0);
                continue;
            }
            EXPECT_GT(c->cover, 0.0);
            const Cloud& cloud = clouds.at(k++);
            // where the layer has cloud, at the time of the frame (the pattern moved with the wind)
            const Vec2 world = c->center + t * wind;
            EXPECT_LE(
                std::max(std::abs(c->center.x / 1000 - (c->i + 0.5)), std::abs(c->center.y / 1000 - (c->j + 0.5))), 0.5)
                << "the centre lies in its cell";
            EXPECT_GT(layerModulation(scene.layers[0], modulation, layeredSettings().modulation, world.x, world.y, t),
                      0);
            double lo = 1e30, hi = -1e30;
            for (const Ellipsoid& e : cloud.ellipsoids) {
                lo = std::min(lo, e.center.z - e.radii.z), hi = std::max(hi, e.center.z + e.radii.z);
                // each column's ellipsoid centred in its cell (drifted by t * wind)
                const Vec2 pattern = Vec2(e.center) - t * wind;
                EXPECT_GE(pattern.x, c->i * 1000.0 - 1e-6);
                EXPECT_LE(pattern.x, (c->i + 1) * 1000.0 + 1e-6);
                EXPECT_GE(pattern.y, c->j * 1000.0 - 1e-6);
                EXPECT_LE(pattern.y, (c->j + 1) * 1000.0 + 1e-6);
            }
            // one ellipsoid per column (stack 1) takes the height of its column's matter, inside the slab
            EXPECT_GE(lo, kBase - 1e-6) << cloud.name;
            EXPECT_LE(hi, kBase + kThickness + 1e-6) << cloud.name;
            EXPECT_LT(lo, hi) << cloud.name;
        }
    }
}

TEST(NearLodTest, CloudsDriftWithTheWind) {
    const Vec2 wind(6, 2);
    const Scene scene = layerScene(wind);
    NearLod lod({}, layeredSettings());
    sharing(lod);
    // The eye moves with the wind: the same cells, each cloud moved by dt * wind exactly.
    const std::vector<Cloud> c0 = lod.update(scene, Vec3(0, 0, 1000), 0);
    const std::vector<Cloud> c1 = lod.update(scene, Vec3(Vec2(0.0) + 100.0 * wind, 1000), 100);
    ASSERT_EQ(c0.size(), c1.size());
    for (std::size_t k = 0; k < c0.size(); ++k) {
        ASSERT_EQ(c0[k].ellipsoids.size(), c1[k].ellipsoids.size());
        EXPECT_NEAR(c0[k].weight, c1[k].weight, 1e-9);
        for (std::size_t e = 0; e < c0[k].ellipsoids.size(); ++e) {
            const Vec3 d = c1[k].ellipsoids[e].center - c0[k].ellipsoids[e].center;
            EXPECT_NEAR(d.x, 600, 1e-6);
            EXPECT_NEAR(d.y, 200, 1e-6);
            EXPECT_EQ(d.z, 0);
        }
        // Each is lit as a tile of the layer: its cell, moved with it.
        ASSERT_TRUE(c0[k].tiled());
        EXPECT_NEAR(c0[k].tileMax.x - c0[k].tileMin.x, NearLodSettings{}.cellSize, 1e-9);
        EXPECT_NEAR(c0[k].tileMax.y - c0[k].tileMin.y, NearLodSettings{}.cellSize, 1e-9);
        EXPECT_NEAR(c1[k].tileMin.x - c0[k].tileMin.x, 600, 1e-6);
        EXPECT_NEAR(c1[k].tileMin.y - c0[k].tileMin.y, 200, 1e-6);
        for (const Ellipsoid& e : c0[k].ellipsoids) {  // its columns lie in its cell
            EXPECT_GT(e.center.x, c0[k].tileMin.x);
            EXPECT_LT(e.center.x, c0[k].tileMax.x);
        }
    }
    NearLodSettings alone;
    alone.tiledLight = false;
    NearLod lone(alone, layeredSettings());
    for (const Cloud& c : sharing(lone).update(scene, Vec3(0, 0, 1000), 0)) EXPECT_FALSE(c.tiled());
}

TEST(NearLodTest, WeightsAreOneInsideTheNearRadiusAndZeroAtTheBandsOuterEdge) {
    const Scene scene = layerScene();
    const LayeredSettings ls = layeredSettings();
    NearLod lod({}, ls);
    sharing(lod).update(scene, Vec3(0, 0, 1000), 0);
    const NearCell* cell = nullptr;
    for (const NearCell* c : lod.cells())
        if (!c->cloud.ellipsoids.empty()) cell = c;
    ASSERT_NE(cell, nullptr);
    // Put the eye at distance d (east) of that cell's spawn point; read that cloud's weight.
    auto weightAt = [&](double d) {
        NearLod probe({}, ls);
        sharing(probe);
        const Vec3 eye(cell->spawn.x + d, cell->spawn.y, 1000);
        for (const Cloud& c : probe.update(scene, eye, 0))
            if (c.name == cell->cloud.name) return c.weight;
        return -1.0;  // not spawned
    };
    EXPECT_EQ(weightAt(0), 1.0);
    EXPECT_EQ(weightAt(kNear - 1), 1.0);
    EXPECT_NEAR(weightAt(kNear + 0.5 * kBand), 0.5, 1e-9);  // smoothstep's midpoint
    EXPECT_LT(weightAt(kNear + kBand - 0.01), 1e-9);        // spawns with weight ~0 ...
    EXPECT_EQ(weightAt(kNear + kBand + 0.01), -1.0);        // ... and not beyond
    // The cloud and the layer share the optical depth: weight + nearFade = 1 across the band.
    for (double d = 0; d < kNear + kBand; d += 250) EXPECT_NEAR(weightAt(d) + nearFade(ls, d), 1.0, 1e-12) << d;
}

TEST(NearLodTest, LayersWithoutNearLodSpawnNothing) {
    Scene scene = layerScene(Vec2(0.0), false);
    NearLod lod({}, layeredSettings());
    sharing(lod);
    NearLodStats st;
    EXPECT_TRUE(lod.update(scene, Vec3(0, 0, 1000), 0, &st).empty());
    EXPECT_EQ(st.cells, 0);
    // Turned on, then the layer changes (coverage): the cells are made again.
    scene.layers[0].nearLod = true;
    lod.update(scene, Vec3(0, 0, 1000), 0, &st);
    EXPECT_GT(st.clouds, 0);
    const int cells = st.cells;
    scene.layers[0].coverage = 0.3;
    lod.update(scene, Vec3(0, 0, 1000), 0, &st);
    EXPECT_EQ(st.retired, 0);  // the same cells, made again in place
    EXPECT_EQ(st.generated, cells);
    EXPECT_EQ(st.cells, cells);
    // Zero coverage: cells, but no cloud.
    scene.layers[0].coverage = 0;
    EXPECT_TRUE(lod.update(scene, Vec3(0, 0, 1000), 0, &st).empty());
    EXPECT_GT(st.cells, 0);
}

TEST(NearLodTest, ABudgetRemakesAChangedLayerNearestFirstKeepingTheOldCloudsMeanwhile) {
    Scene scene = layerScene();
    const Vec3 eye(0, 0, 1000);
    NearLod lod({}, layeredSettings()), unbounded({}, layeredSettings());
    sharing(lod), sharing(unbounded);
    NearLodStats st;
    lod.update(scene, eye, 0, &st);  // no budget: every cell in reach
    const int cells = st.cells;
    ASSERT_GT(cells, 8);
    EXPECT_EQ(st.pending, 0);
    scene.layers[0].coverage = 0.35;
    const std::vector<Cloud> old = lod.update(scene, eye, 0, &st, 4);
    EXPECT_EQ(st.generated, 4);
    EXPECT_EQ(st.pending, cells - 4);
    EXPECT_EQ(st.cells, cells);  // none dropped: the others keep their old cloud
    // The four made first are the nearest spawn points; farther ones still hold the old layer's.
    std::vector<double> distances;
    for (const NearCell* c : lod.cells()) distances.push_back(glm::length(c->spawn));
    std::sort(distances.begin(), distances.end());
    const ModulationTexture modulation = makeModulation(layeredSettings().modulation, scene.layers[0].seed);
    const auto lightHeld = layerLight(scene);
    const LightingVolume& light = *lightHeld;
    int nearestFresh = 0, fartherStale = 0;
    for (const NearCell* c : lod.cells()) {
        const NearCell fresh = makeNearCell(scene, 0, c->i, c->j, {}, modulation, layeredSettings().modulation, light);
        const bool same = c->cover == fresh.cover && sameCloud(c->cloud, fresh.cloud);
        if (glm::length(c->spawn) <= distances[3]) nearestFresh += same;
        else fartherStale += !same;
    }
    EXPECT_EQ(nearestFresh, 4);
    EXPECT_GT(fartherStale, 0);
    EXPECT_FALSE(old.empty());
    // Until no cell is due; then the clouds are those an unbounded near LOD makes at once.
    int updates = 1;
    while (st.pending > 0 && updates < 100) lod.update(scene, eye, 0, &st, 4), ++updates;
    EXPECT_EQ(updates, (cells + 3) / 4);
    const std::vector<Cloud> a = lod.update(scene, eye, 0, &st, 4), b = unbounded.update(scene, eye, 0);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k) EXPECT_TRUE(sameCloud(a[k], b[k])) << k;
}

TEST(NearLodTest, BadSettingsNameTheSetting) {
    auto message = [](NearLodSettings ns, LayeredSettings ls) -> std::string {
        try {
            NearLod lod(ns, ls);
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    NearLodSettings ns;
    ns.cellSize = 0;
    EXPECT_NE(message(ns, layeredSettings()).find("cellSize"), std::string::npos);
    ns = {}, ns.jitter = 0.5;
    EXPECT_NE(message(ns, layeredSettings()).find("jitter"), std::string::npos);
    ns = {}, ns.columns = 0;
    EXPECT_NE(message(ns, layeredSettings()).find("columns"), std::string::npos);
    ns = {}, ns.overlap = 3;
    EXPECT_NE(message(ns, layeredSettings()).find("overlap"), std::string::npos);
    ns = {}, ns.verticalSpread = 0.5;
    EXPECT_NE(message(ns, layeredSettings()).find("verticalSpread"), std::string::npos);
    ns = {}, ns.columnJitter = 0.6;
    EXPECT_NE(message(ns, layeredSettings()).find("columnJitter"), std::string::npos);
    ns = {}, ns.stack = 3;  // 8 levels
    EXPECT_NE(message(ns, layeredSettings()).find("levels"), std::string::npos);
    ns = {}, ns.minColumnDepth = -1;
    EXPECT_NE(message(ns, layeredSettings()).find("minColumnDepth"), std::string::npos);
    ns = {}, ns.samples = 0;
    EXPECT_NE(message(ns, layeredSettings()).find("samples"), std::string::npos);
    ns = {}, ns.columnDepth = 0;
    EXPECT_NE(message(ns, layeredSettings()).find("columnDepth"), std::string::npos);
    ns = {}, ns.cellSize = 10;  // 700 cells per axis
    EXPECT_NE(message(ns, layeredSettings()).find("cellSize"), std::string::npos);
    LayeredSettings ls = layeredSettings();
    ls.blendBand = -1;
    EXPECT_NE(message({}, ls).find("blendBand"), std::string::npos);
}

namespace {
// The optical depth of the near clouds along o + s d, s in [0, length], by the midpoint rule:
// each ellipsoid's extinction is extinction * density * (1 - r^2)^2 (r^2 = |M (x - c)|^2, the
// Gardner model's profile), times the cloud's weight.
double nearDepth(const std::vector<Cloud>& clouds, double extinction, const Vec3& o, const Vec3& d, double length) {
    const int steps = int(length / 5);
    double tau = 0;
    for (int k = 0; k < steps; ++k) {
        const Vec3 x = o + d * ((k + 0.5) * length / steps);
        for (const Cloud& c : clouds)
            for (const Ellipsoid& e : c.ellipsoids) {
                const Vec3 q = (x - e.center) / e.radii;  // axis-aligned: the near LOD's ellipsoids are
                const double r2 = glm::dot(q, q);
                if (r2 < 1) tau += c.weight * extinction * e.density * (1 - r2) * (1 - r2) * length / steps;
            }
    }
    return tau;
}
}  // namespace

TEST(NearLodTest, NearCloudsCarryTheLayersOpticalDepth) {
    // Issue #10: the near clouds must cover the sky as the layer does. Their mean opacity along
    // rays (vertical through the layer; level at a third and at half of its thickness, 1.5 km
    // long) against the layer's own (the CPU integral of its density), at coverages 0.3-0.9.
    // Tolerance 0.05 in mean opacity (the target). Rays start within 1 km of the eye, so
    // every cloud they meet lies within the near radius (weight 1).
    for (double coverage : {0.3, 0.6, 0.9}) {
        Scene scene = layerScene();
        scene.layers[0].coverage = coverage;
        LayeredSettings ls = layeredSettings();
        ls.nearRadius = 3000, ls.blendBand = 100;  // every ray below within the near radius
        NearLod lod({}, ls);
        sharing(lod);
        const Vec3 eye(0, 0, kBase - 100);
        const std::vector<Cloud> clouds = lod.update(scene, eye, 0);
        const auto lightHeld = layerLight(scene);
        const LightingVolume& light = *lightHeld;
        const ModulationTexture modulation = makeModulation(ls.modulation, scene.layers[0].seed);
        const Layer& layer = scene.layers[0];
        const double extinction = scene.medium.extinction;
        for (int kind = 0; kind < 3; ++kind) {
            double nearSum = 0, layerSum = 0;
            int rays = 0;
            for (int b = 0; b < 16; ++b)
                for (int a = 0; a < 16; ++a) {
                    const double x = -1200 + (a + 0.5) * 150, y = -1200 + (b + 0.5) * 150;
                    const double z = kind == 0 ? kBase - 10 : kBase + kThickness * (kind == 1 ? 0.33 : 0.5);
                    const Vec3 o(x, y, z);
                    const double angle = 0.7 * (a + 16 * b);
                    const Vec3 d = kind == 0 ? Vec3(0, 0, 1) : Vec3(std::cos(angle), std::sin(angle), 0);
                    const double length = kind == 0 ? kThickness + 20 : 1500;
                    nearSum += 1 - std::exp(-nearDepth(clouds, extinction, o, d, length));
                    const double layerTau = extinction * layerDensityIntegral(layer, modulation, ls.modulation, light,
                                                                              o, d, length, 0, 5.0, 100000);
                    layerSum += 1 - std::exp(-layerTau);
                    ++rays;
                }
            std::printf("[ figure ] coverage %.1f, %s rays: mean opacity near %.3f, layer %.3f\n", coverage,
                        kind == 0   ? "vertical"
                        : kind == 1 ? "level (1/3)"
                                    : "level (1/2)",
                        nearSum / rays, layerSum / rays);
            EXPECT_NEAR(nearSum / rays, layerSum / rays, 0.05) << "coverage " << coverage << " kind " << kind;
            if (coverage == 0.9) {
                EXPECT_GT(layerSum / rays, 0.2) << "a layer with matter on these rays: kind " << kind;
            }
        }
    }
}

// The columns' ellipsoids are shaken off their grid (no straight lanes between rows that the
// eye would see converge), by at most columnJitter columns, the same for the same cell.
TEST(NearLodTest, ColumnsAreShakenOffTheirGrid) {
    const Scene scene = layerScene();
    auto offsets = [&](double jitter) {
        NearLodSettings ns;
        ns.columnJitter = jitter;
        std::vector<double> out;
        const double w = ns.cellSize / ns.columns;
        NearLod lod(ns, layeredSettings());
        for (const Cloud& c : sharing(lod).update(scene, Vec3(0, 0, 1000), 0))
            for (const Ellipsoid& e : c.ellipsoids)
                for (int k = 0; k < 2; ++k) {
                    const double f = e.center[k] / w - 0.5;  // column centres at (m + 0.5) w
                    out.push_back(f - std::round(f));
                }
        return out;
    };
    const std::vector<double> still = offsets(0), shaken = offsets(NearLodSettings{}.columnJitter);
    ASSERT_GT(shaken.size(), 20u);
    double largest = 0, mean = 0;
    for (double d : still) EXPECT_NEAR(d, 0.0, 1e-9);
    for (double d : shaken) largest = std::max(largest, std::fabs(d)), mean += std::fabs(d) / double(shaken.size());
    EXPECT_LE(largest, NearLodSettings{}.columnJitter + 1e-9);
    EXPECT_GT(mean, 0.25 * NearLodSettings{}.columnJitter);  // uniform in [-j, j]: mean |d| = j / 2
    EXPECT_EQ(offsets(NearLodSettings{}.columnJitter), shaken);
}
