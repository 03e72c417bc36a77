// The light volumes' sun-depth index (ellipsoid/src/sun_depth): the same bits as summing
// every ellipsoid of the cloud (cloudSunLight), for rotated ellipsoids of mixed sizes, suns
// high, low and straight up, and points inside, beside and beyond the cloud.
#include "nephele/gardner.hpp"

#include <gtest/gtest.h>

#include <random>

namespace nephele {
namespace {

TEST(SunDepthTest, LightVolumesEqualTheSumOverEveryEllipsoid) {
    std::mt19937 rng(7);
    auto u = [&](double lo, double hi) { return lo + (hi - lo) * double(rng() >> 8) / double(1 << 24); };
    for (const Vec3 sun : {Vec3(0.3, 0.2, 0.93), Vec3(0, 0, 1), Vec3(-0.9, 0.1, 0.05), Vec3(0, 1, 0)}) {
        Scene s;
        s.sun.direction = glm::normalize(sun);
        Cloud cloud{"mixed", {}};
        for (int i = 0; i < 300; ++i) {
            Ellipsoid e;
            e.center = {u(-2000, 2000), u(-2000, 2000), u(500, 2500)};
            const double r = i % 50 == 0 ? u(500, 1500) : u(20, 200);  // a few large ones among many small
            e.radii = {r, r * u(0.3, 1), r * u(0.2, 1)};
            e.rotationDeg = {u(-90, 90), u(-90, 90), u(0, 360)};
            e.density = u(0, 2);
            cloud.ellipsoids.push_back(e);
        }
        s.clouds = {cloud};
        const int size = 12;
        const CloudLight light = makeCloudLights(s, size).front();
        int checked = 0, shadowed = 0;
        for (int z = 0; z < size; ++z)
            for (int y = 0; y < size; ++y)
                for (int x = 0; x < size; ++x) {
                    const Vec3 p = light.boxMin + (Vec3(x, y, z) + 0.5) / double(size) * light.boxExtent;
                    const float want = float(cloudSunLight(s, cloud, p));
                    ASSERT_EQ(light.transmittance[(std::size_t(z) * size + y) * size + x], want) << x << " " << y << " " << z;
                    ++checked;
                    shadowed += want < 0.5f * float(cloudSunLight(s, Cloud{}, p));
                }
        EXPECT_EQ(checked, size * size * size);
        EXPECT_GT(shadowed, 0);  // the comparison covers points in shadow, not only sunlit ones
    }
}

}  // namespace
}  // namespace nephele
