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
    expectSame(cache.update(s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 2);
    // The wind moves both clouds: nothing is computed, the boxes move with them.
    for (Cloud& c : s.clouds)
        for (Ellipsoid& e : c.ellipsoids) e.center += Vec3(123.4, -56.7, 0.0);
    expectSame(cache.update(s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 0);
    // One cloud changes shape: only it is computed.
    s.clouds[1].ellipsoids[0].radii.x += 10;
    expectSame(cache.update(s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 1);
}

TEST(CloudRadianceCacheTest, SunSkyMediumOrSettingsChangesRecomputeEverything) {
    CloudRadianceCache cache;
    Scene s = twoClouds();
    int computed = -1;
    cache.update(s, cheap(), &computed);
    s.sun.direction = glm::normalize(Vec3(-0.5, 0.1, 0.8));
    expectSame(cache.update(s, cheap(), &computed), s, cheap());
    EXPECT_EQ(computed, 2);
    s.sky.zenith *= 0.5;
    cache.update(s, cheap(), &computed);
    EXPECT_EQ(computed, 2);
    s.medium.extinction *= 2;
    cache.update(s, cheap(), &computed);
    EXPECT_EQ(computed, 2);
    RadianceGridSettings other = cheap();
    other.size = 4;
    cache.update(s, other, &computed);
    EXPECT_EQ(computed, 2);
    // The sun's colour and intensity scale the light at render time: nothing to recompute.
    s.sun.intensity *= 2;
    cache.update(s, other, &computed);
    EXPECT_EQ(computed, 0);
    // A cloud that leaves: its grid is dropped, not kept forever; it is made anew when it returns.
    const Cloud gone = s.clouds.back();
    s.clouds.pop_back();
    cache.update(s, other, &computed);
    EXPECT_EQ(computed, 0);
    s.clouds.push_back(gone);
    cache.update(s, other, &computed);
    EXPECT_EQ(computed, 1);
}
