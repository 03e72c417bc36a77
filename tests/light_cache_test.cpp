// The light-volume cache: a translated cloud reuses its volume, moved with it; anything else
// its light depends on (shape, sun, medium, size) makes a new one.
#include "nephele/light_cache.hpp"

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

void expectSame(const std::vector<CloudLight>& a, const std::vector<CloudLight>& b, double boxTol) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t c = 0; c < a.size(); ++c) {
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(a[c].boxMin[k], b[c].boxMin[k], boxTol) << c;
            EXPECT_NEAR(a[c].boxExtent[k], b[c].boxExtent[k], boxTol) << c;
        }
        ASSERT_EQ(a[c].transmittance.size(), b[c].transmittance.size());
        double worst = 0;
        for (std::size_t i = 0; i < a[c].transmittance.size(); ++i)
            worst = std::max(worst, double(std::abs(a[c].transmittance[i] - b[c].transmittance[i])));
        // Voxel centres of a translated box are the same points of the cloud up to rounding of
        // world coordinates of a few km (double): far below a 16-bit float texel.
        EXPECT_LT(worst, 1e-5) << c;
    }
}

}  // namespace

TEST(CloudLightCacheTest, TranslatedCloudsReuseTheirVolumes) {
    CloudLightCache cache;
    Scene s = twoClouds();
    int computed = -1;
    expectSame(cache.lights(s, 8, &computed), makeCloudLights(s, 8), 1e-9);
    EXPECT_EQ(computed, 2);
    // The wind moves both clouds: nothing is computed, the boxes move with them.
    for (Cloud& c : s.clouds)
        for (Ellipsoid& e : c.ellipsoids) e.center += Vec3(123.4, -56.7, 0.0);
    expectSame(cache.lights(s, 8, &computed), makeCloudLights(s, 8), 1e-6);
    EXPECT_EQ(computed, 0);
    // One cloud changes shape: only it is computed.
    s.clouds[1].ellipsoids[0].radii.x += 10;
    expectSame(cache.lights(s, 8, &computed), makeCloudLights(s, 8), 1e-6);
    EXPECT_EQ(computed, 1);
}

TEST(CloudLightCacheTest, SunMediumOrSizeChangesRecomputeEverything) {
    CloudLightCache cache;
    Scene s = twoClouds();
    int computed = -1;
    cache.lights(s, 8, &computed);
    s.sun.direction = glm::normalize(Vec3(-0.5, 0.1, 0.8));
    expectSame(cache.lights(s, 8, &computed), makeCloudLights(s, 8), 1e-9);
    EXPECT_EQ(computed, 2);
    s.medium.extinction *= 2;
    cache.lights(s, 8, &computed);
    EXPECT_EQ(computed, 2);
    cache.lights(s, 4, &computed);
    EXPECT_EQ(computed, 2);
    // A cloud that leaves and another that arrives: the old volume is dropped, not kept forever.
    s.clouds.pop_back();
    cache.lights(s, 4, &computed);
    EXPECT_EQ(computed, 0);
}
