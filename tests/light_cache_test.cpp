// The radiance-grid cache: a translated cloud reuses its grid, moved with it; anything else
// its light depends on (shape, sun direction, sky, medium, settings) makes a new one.
#include "light_cache.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace nephele;

namespace {

Scene twoClouds() {
    Scene s;
    for (int c = 0; c < 2; ++c) {
        Cloud cloud;
        cloud.name = std::string(1, char('a' + c));  // "a", "b" (a ternary of literals trips GCC 12 -Wrestrict)
        for (int k = 0; k < 3; ++k) {
            Ellipsoid e;
            e.center = Vec3(1000.0 * c + 120.0 * k, 300.0 * c, 1500 + 40.0 * k);
            e.radii = Vec3(150 + 20 * k + 7 * c, 120, 90);  // the clouds differ in shape
            e.rotationDeg = Vec3(0, 0, 15.0 * k);
            cloud.ellipsoids.push_back(e);
        }
        s.clouds.push_back(cloud);
    }
    return s;
}

// The cache's update, waiting for every grid; `computed` receives how many it made.
std::vector<PlacedRadiance> update(CloudRadianceCache& cache, const Scene& s, const RadianceGridSettings& g, int* computed) {
    RadianceUpdateStats stats;
    auto placed = cache.update(s, g, nullptr, &stats);
    *computed = stats.computed;
    return placed;
}

RadianceGridSettings cheap() {
    RadianceGridSettings g;
    g.size = 8;
    g.sunPhotons = g.skyPhotons = 2000;
    return g;
}

// The cache's grids read at the clouds' points equal grids computed afresh for the scene as it is.
void expectSame(const std::vector<PlacedRadiance>& placed, const Scene& s, const RadianceGridSettings& g) {
    ASSERT_EQ(placed.size(), s.clouds.size());
    for (std::size_t c = 0; c < placed.size(); ++c) {
        const CloudRadiance fresh = computeCloudRadiance(s, s.clouds[c], g);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(placed[c].boxMin()[k], fresh.boxMin[k], 1e-6) << c;
        double worst = 0;
        for (const Ellipsoid& e : s.clouds[c].ellipsoids) {
            const RadianceSample a = placed[c].sample(e.center), b = sampleRadiance(fresh, e.center);
            worst = std::max({worst, double(glm::length(a.sunDiffuse - b.sunDiffuse)), double(glm::length(a.skyTau - b.skyTau)),
                              double(glm::length(a.skyFlux - b.skyFlux))});
        }
        // The same photons through the same voxels up to the rounding of world coordinates of a
        // few km (double): far below a half-float texel.
        EXPECT_LT(worst, 1e-4) << c;
    }
}

}  // namespace

TEST(CloudRadianceCacheTest, TranslatedCloudsReuseTheirGrids) {
    CloudRadianceCache cache;
    Scene s = twoClouds();
    int computed = -1;
    expectSame(update(cache, s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 2);
    // The wind moves both clouds: nothing is computed, the boxes move with them.
    for (Cloud& c : s.clouds)
        for (Ellipsoid& e : c.ellipsoids) e.center += Vec3(123.4, -56.7, 0.0);
    expectSame(update(cache, s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 0);
    // One cloud changes shape: only it is computed.
    s.clouds[1].ellipsoids[0].radii.x += 10;
    expectSame(update(cache, s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 1);
}

TEST(CloudRadianceCacheTest, SunSkyMediumOrSettingsChangesRecomputeEverything) {
    CloudRadianceCache cache;
    Scene s = twoClouds();
    int computed = -1;
    update(cache, s, cheap(), &computed);
    s.sun.direction = glm::normalize(Vec3(-0.5, 0.1, 0.8));
    expectSame(update(cache, s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 2);
    s.sky.zenith *= 0.5;
    update(cache, s, cheap(), &computed);
    EXPECT_EQ(computed, 2);
    s.medium.extinction *= 2;
    update(cache, s, cheap(), &computed);
    EXPECT_EQ(computed, 2);
    RadianceGridSettings other = cheap();
    other.size = 4;
    update(cache, s, other, &computed);
    EXPECT_EQ(computed, 2);
    // The sun's colour and intensity scale the light at render time: nothing to recompute.
    s.sun.intensity *= 2;
    update(cache, s, other, &computed);
    EXPECT_EQ(computed, 0);
    // A cloud that leaves: its grid is dropped, not kept forever; it is made anew when it returns.
    const Cloud gone = s.clouds.back();
    s.clouds.pop_back();
    update(cache, s, other, &computed);
    EXPECT_EQ(computed, 0);
    s.clouds.push_back(gone);
    update(cache, s, other, &computed);
    EXPECT_EQ(computed, 1);
}

// Background: no grid is made in the call that needs it. The clouds are lit by stand-ins (the
// template: a small grid over each cloud's own box) until the worker's grids are taken, and
// those are the grids a waiting update makes.
TEST(CloudRadianceCacheTest, BackgroundGridsNeverWaitAndStandInsServeMeanwhile) {
    CloudRadianceCache cache;
    Scene s = twoClouds();
    RadianceGridSettings g = cheap();
    g.background = true;
    RadianceUpdateStats stats;
    const auto first = cache.update(s, g, nullptr, &stats);
    EXPECT_EQ(stats.computed, 0);
    EXPECT_EQ(stats.standIns, 2);
    for (std::size_t c = 0; c < first.size(); ++c) {
        EXPECT_FALSE(first[c].exact);
        EXPECT_LE(first[c].grid->size, g.size);
        Vec3 lo, hi;
        cloudBox(s.clouds[c], lo, hi);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(first[c].lo[k], lo[k], 1e-9);
        // The stand-in lights the cloud: diffuse sunlight and sky light at its first ellipsoid.
        const RadianceSample r = first[c].sample(s.clouds[c].ellipsoids[0].center);
        EXPECT_GT(r.sunDiffuse.w, 0.0f);
        EXPECT_GT(r.skyTau.x, 0.0f);
    }
    cache.waitIdle();
    const auto ready = cache.update(s, g, nullptr, &stats);
    EXPECT_EQ(stats.computed, 2);
    EXPECT_EQ(stats.standIns, 0);
    EXPECT_EQ(stats.pending, 0);
    for (const PlacedRadiance& p : ready) EXPECT_TRUE(p.exact);
    expectSame(ready, s, g);
}

// A new sun: the old grids keep lighting the clouds (the same grids, not the template) until
// the new ones are made; then the new ones are used and the old ones dropped.
TEST(CloudRadianceCacheTest, TheOldGridServesUntilTheNewOneIsReady) {
    CloudRadianceCache cache;
    Scene s = twoClouds();
    RadianceGridSettings g = cheap();
    const auto before = cache.update(s, g);
    g.background = true;
    s.sun.direction = glm::normalize(Vec3(0.6, -0.2, 0.5));
    RadianceUpdateStats stats;
    const auto during = cache.update(s, g, nullptr, &stats);
    EXPECT_EQ(stats.standIns, 2);
    for (std::size_t c = 0; c < during.size(); ++c) EXPECT_EQ(during[c].grid, before[c].grid) << c;
    cache.waitIdle();
    const auto after = cache.update(s, g, nullptr, &stats);
    EXPECT_EQ(stats.computed, 2);
    for (std::size_t c = 0; c < after.size(); ++c) {
        EXPECT_TRUE(after[c].exact);
        EXPECT_NE(after[c].grid, before[c].grid);
    }
    expectSame(after, s, g);
}

// The memory budget: room for one grid. The cloud nearer the eye gets it, the other keeps the
// template; when the eye moves to the other cloud, the grids swap.
TEST(CloudRadianceCacheTest, TheBudgetGivesGridsToTheCloudsLargestOnScreen) {
    CloudRadianceCache cache;
    Scene s = twoClouds();
    RadianceGridSettings g = cheap();
    g.megabytes = 1.5 * double(radianceGridBytes(g.size)) / 1048576.0;
    if (g.megabytes < 1) g.size = 32, g.megabytes = 1.5 * double(radianceGridBytes(32)) / 1048576.0;
    RadianceUpdateStats stats;
    const Vec3 nearFirst = s.clouds[0].ellipsoids[0].center + Vec3(-300, 0, 0);
    auto placed = cache.update(s, g, &nearFirst, &stats);
    EXPECT_TRUE(placed[0].exact);
    EXPECT_FALSE(placed[1].exact);
    EXPECT_EQ(stats.overBudget, 1);
    const Vec3 nearSecond = s.clouds[1].ellipsoids[0].center + Vec3(300, 0, 0);
    placed = cache.update(s, g, &nearSecond, &stats);
    EXPECT_FALSE(placed[0].exact);
    EXPECT_TRUE(placed[1].exact);
    EXPECT_EQ(stats.computed, 1);
    EXPECT_EQ(stats.overBudget, 1);
}

// A cloud that changes while its grid is being made: the worker drops that grid and makes the
// one of the cloud as it is now; the cache is destroyed with work queued without waiting for it.
TEST(CloudRadianceCacheTest, WorkNoLongerWantedIsDropped) {
    Scene s = twoClouds();
    RadianceGridSettings g = cheap();
    g.background = true;
    {
        CloudRadianceCache cache;
        cache.update(s, g);
        for (Cloud& c : s.clouds) c.ellipsoids[0].radii *= 1.2;
        cache.update(s, g);
        cache.waitIdle();
        RadianceUpdateStats stats;
        const auto placed = cache.update(s, g, nullptr, &stats);
        for (const PlacedRadiance& p : placed) EXPECT_TRUE(p.exact);
        expectSame(placed, s, g);
    }
    {
        CloudRadianceCache busy;
        RadianceGridSettings slow = g;
        slow.size = 32, slow.sunPhotons = slow.skyPhotons = 1 << 20;
        busy.update(s, slow);  // the destructor cancels it
    }
}

// A grid cancelled before or while it is made comes back empty (size 0), never half-summed.
TEST(CloudRadianceCacheTest, ACancelledGridIsEmpty) {
    const Scene s = twoClouds();
    std::atomic<bool> cancel{true};
    const CloudRadiance grid = computeCloudRadiance(s, s.clouds[0], cheap(), &cancel);
    EXPECT_EQ(grid.size, 0);
    EXPECT_TRUE(grid.sunDiffuse.empty());
}
