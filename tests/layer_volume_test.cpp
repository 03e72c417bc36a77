// The layers as volumes in the path tracer (nephele/layer_volume.hpp): a uniform test layer
// against the analytic slab (trackers, opacity, single scattering), the layer's opacity against
// the CPU integral of the layered sky's density, the majorant bounding the extinction, wind,
// scenes without layers unchanged bit for bit, and the cache key.
#include "nephele/layer_volume.hpp"
#include "nephele/gardner.hpp"
#include "nephele/pathtrace.hpp"
#include "pathtrace_hooks.hpp"
#include "temp_dir.hpp"
#include "stats_test_util.hpp"
#include "layered_test_util.hpp"

#include "../reference/src/layer_tracking.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <numbers>
#include <unistd.h>

using namespace nephele;

namespace {

constexpr double kBase = 1000, kThickness = 200;

Scene layerScene(int width, int height, double coverage, double density) {
    Scene s;
    s.camera.position = {0, 0, 500};
    s.camera.direction = glm::normalize(Vec3(0, 1, 0.8));
    s.camera.fovYDeg = 40;
    s.camera.width = width, s.camera.height = height;
    s.medium.noise = 0;
    s.medium.extinction = 0.04;
    Layer l;
    l.base = kBase, l.thickness = kThickness, l.coverage = coverage, l.density = density, l.extent = 1e5;
    s.layers.push_back(l);
    return s;
}

// A = 1 everywhere and r = 0 everywhere: eq. (16) gives the uniform density D C.
std::shared_ptr<const LayerVolumes> uniformLayer(const Scene& scene) {
    LightingVolume light;
    light.settings.width = light.settings.height = 4, light.settings.depth = 2;
    light.texels.assign(4 * 4 * 2 * 4, 255);
    ModulationTexture m;
    m.size = 8;
    m.texels.assign(8 * 8 * 2, 0.0f);
    return std::make_shared<LayerVolumes>(scene, std::vector<LightingVolume>{light}, std::vector<ModulationTexture>{m},
                                          ModulationSettings{}, 0.0, 0.0);
}

// Small real textures: the lighting volume and modulation of the layered sky at low resolution.
LayeredSettings smallTextures() { return test::smallLayered(64); }

using test::MeanAndError;
using test::meanOf;

}  // namespace

TEST(LayerVolumeTest, UniformLayerTrackersMatchTheAnalyticSlab) {
    const Scene scene = layerScene(4, 3, 0.5, 0.8);
    const auto layers = uniformLayer(scene);
    const double sigma = 0.04 * 0.8 * 0.5;
    EXPECT_NEAR(layers->extinction(Vec3(30, 40, kBase + 50), scene.camera.position), sigma, 1e-12);
    EXPECT_EQ(layers->extinction(Vec3(30, 40, kBase - 1), scene.camera.position), 0.0);
    // A slanted ray from below through the slab: T = exp(-sigma thickness / d.z).
    const Vec3 o(0, 0, 500), d = glm::normalize(Vec3(0.3, 0.5, 0.6));
    detail::LayerRay ray;
    detail::prepareLayerRay(*layers, o, o, d, 0, 1e30, ray);
    const double exact = std::exp(-sigma * kThickness / d.z);
    detail::Pcg32 rng(7, 11);
    const int n = 100000;
    const MeanAndError free = meanOf(n, [&](int) {
        return detail::layerFreeFlight(*layers, o, o, d, ray, rng) == detail::kNoCollision ? 1.0 : 0.0;
    });
    const MeanAndError ratio = meanOf(n, [&](int) { return detail::layerTransmittance(*layers, o, o, d, ray, rng); });
    std::printf("[ figure ] uniform slab: exact T %.5f, delta %.5f +- %.5f, ratio %.5f +- %.5f\n", exact, free.mean,
                free.error, ratio.mean, ratio.error);
    EXPECT_NEAR(free.mean, exact, 3 * free.error);
    EXPECT_NEAR(ratio.mean, exact, 3 * ratio.error);
}

TEST(LayerVolumeTest, UniformLayerOpacityIsTheAnalyticSlab) {
    Scene scene = layerScene(8, 6, 0.5, 0.6);
    PathTraceSettings s{.spp = 400, .maxBounces = 0};
    s.layers = uniformLayer(scene);
    const View view = makeView(scene.camera);
    const Image image = renderPathTraced(scene, view, s, nullptr);
    const double sigma = 0.04 * 0.6 * 0.5;
    // The majorant equals the uniform extinction, so ratio tracking's estimate of T is 0 or 1:
    // per pixel a binomial mean of `spp` samples, standard deviation sqrt(T (1 - T) / spp).
    double worstZ = 0, sum = 0, variance = 0;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            const double t = std::exp(-sigma * kThickness / d.z), sd = std::sqrt(t * (1 - t) / s.spp);
            const double diff = image.at(x, y, 3) - (1 - t);
            worstZ = std::max(worstZ, std::fabs(diff) / std::max(sd, 1e-3));
            sum += diff, variance += sd * sd;
        }
    const double meanZ = sum / std::sqrt(variance);
    std::printf("[ figure ] uniform slab opacity: worst pixel %.2f sd, the sum of differences %.2f sd\n", worstZ,
                meanZ);
    EXPECT_LT(worstZ, 4.5);  // 48 pixels: beyond 4.5 sd has odds below 1e-3 for an unbiased estimate
    EXPECT_LT(std::fabs(meanZ), 3.5);
}

TEST(LayerVolumeTest, UniformLayerSingleScatteringMatchesQuadrature) {
    // One pixel looking up through the slab, lit by the sun only (black sky), one scattering:
    // L = integral of T_view sigma_s p(theta) E T_sun dt, both transmittances in closed form.
    Scene scene = layerScene(1, 1, 0.4, 0.5);
    scene.medium.albedo = 0.9;
    scene.sky = {Vec3(0.0), Vec3(0.0), Vec3(0.0)};
    scene.sun.direction = glm::normalize(Vec3(0.2, 0.6, 0.5));
    scene.sun.intensity = 3;
    const View view = makeView(scene.camera);
    const Vec3 d = view.rayDirection(0.5, 0.5), l = scene.sun.direction;
    const double sigma = 0.04 * 0.5 * 0.4, g = scene.medium.hgG, c = glm::dot(d, l);
    const double phase = (1 - g * g) / (4 * std::numbers::pi * std::pow(1 + g * g - 2 * g * c, 1.5));
    const double t0 = (kBase - view.eye.z) / d.z, t1 = (kBase + kThickness - view.eye.z) / d.z;
    double expected = 0;
    const int steps = 20000;
    for (int i = 0; i < steps; ++i) {
        const double t = t0 + (i + 0.5) * (t1 - t0) / steps, z = view.eye.z + t * d.z;
        expected += std::exp(-sigma * (t - t0)) * scene.medium.albedo * sigma * phase * 3 *
                    std::exp(-sigma * (kBase + kThickness - z) / l.z) * (t1 - t0) / steps;
    }
    PathTraceSettings s{.spp = 2000, .maxBounces = 0};
    s.layers = uniformLayer(scene);
    const MeanAndError rendered = meanOf(16, [&](int k) {
        PathTraceSettings sk = s;
        sk.seed = unsigned(k + 1);
        return double(renderPathTraced(scene, view, sk, nullptr).at(0, 0, 1));
    });
    std::printf("[ figure ] uniform slab single scattering: quadrature %.6f, path traced %.6f +- %.6f\n", expected,
                rendered.mean, rendered.error);
    EXPECT_GT(expected, 0.01);
    EXPECT_NEAR(rendered.mean, expected, 3 * rendered.error);
}

TEST(LayerVolumeTest, UniformLayerShadowsAnObjectBelowIt) {
    // A box under the slab seen from beside it: Lambert under the sun times the sun's
    // transmittance through the layer, exp(-sigma thickness / l.z) (ratio tracking, so a mean).
    Scene scene = layerScene(1, 1, 0.5, 0.3);
    scene.camera.position = {0, -300, 100};
    scene.camera.direction = {0, 1, 0};
    scene.sun.direction = glm::normalize(Vec3(0.3, -0.5, 0.8));
    Object box;
    box.center = {0, 0, 100};
    box.size = {100, 100, 100};
    box.color = {0.5, 0.5, 0.5};
    scene.objects.push_back(box);
    const View view = makeView(scene.camera);
    PathTraceSettings s{.spp = 4000, .maxBounces = 0};
    s.layers = uniformLayer(scene);
    const double lit = double(renderPathTraced(scene, view, {.spp = 1, .maxBounces = 0}, nullptr).at(0, 0, 0));
    const double shadowed = double(renderPathTraced(scene, view, s, nullptr).at(0, 0, 0));
    const double expected = lit * std::exp(-0.04 * 0.3 * 0.5 * kThickness / scene.sun.direction.z);
    // Binary estimates (majorant = extinction): sd = lit sqrt(T (1 - T) / 4000), about 0.006 lit.
    std::printf("[ figure ] object under the layer: unshadowed %.4f, shadowed %.4f, expected %.4f\n", lit, shadowed,
                expected);
    EXPECT_GT(lit, 0.05);
    EXPECT_NEAR(shadowed, expected, 0.025 * lit);
}

TEST(LayerVolumeTest, OpacityAlongRaysIsTheCpuIntegralOfTheLayersDensity) {
    Scene scene = layerScene(12, 9, 0.7, 0.9);
    scene.layers[0].wind = Vec2(8, -3);
    const double t = 40;  // s: the wind moves the pattern 340 m
    const LayeredSettings ls = smallTextures();
    PathTraceSettings s{.spp = 256, .maxBounces = 0};
    s.layers = std::make_shared<LayerVolumes>(scene, ls, t);
    const View view = makeView(scene.camera);
    const Image image = renderPathTraced(scene, view, s, nullptr);
    const Layer& layer = scene.layers[0];
    double worst = 0, sum = 0, largest = 0, smallest = 1;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const double tau =
                scene.medium.extinction *
                layerDensityIntegral(layer, s.layers->modulation(0), ls.modulation, s.layers->lighting(0), view.eye,
                                     view.rayDirection(x + 0.5, y + 0.5), 1e9, t, 1.0, 100000);
            const double expected = 1 - std::exp(-tau);
            worst = std::max(worst, std::fabs(image.at(x, y, 3) - expected));
            sum += image.at(x, y, 3) - expected;
            largest = std::max(largest, expected), smallest = std::min(smallest, expected);
        }
    const double bias = sum / (image.width * image.height);
    std::printf(
        "[ figure ] layer opacity against the CPU integral: max |diff| %.4f, mean diff %.5f (alpha %.3f..%.3f)\n",
        worst, bias, smallest, largest);
    EXPECT_GT(largest - smallest, 0.3);  // a varied field, not a uniform one
    // 256 ratio-tracking samples per pixel: standard deviation below about 0.02 per pixel (the
    // estimate's spread is at most about T, T <= 1, over 16); 0.06 is 3 of them. The mean of 108
    // pixels: 0.006.
    EXPECT_LT(worst, 0.06);
    EXPECT_LT(std::fabs(bias), 0.006);
}

TEST(LayerVolumeTest, MajorantBoundsTheExtinctionAndCoversAllMatter) {
    Scene scene = layerScene(1, 1, 0.8, 1.0);
    scene.layers[0].wind = Vec2(-5, 7);
    scene.layers[0].extent = 6000;
    const LayerVolumes layers(scene, smallTextures(), 123.0);
    const Vec3 eye(100, -200, 1100);
    detail::Pcg32 rng(3, 5);
    int inside = 0, matter = 0;
    std::vector<LayerVolumes::Bound> bounds;
    for (int ray = 0; ray < 200; ++ray) {
        const double z = ray % 3 == 0 ? kBase + kThickness * rng.uniform() : kBase - 400 + 1000 * rng.uniform();
        const Vec3 o(8000 * (rng.uniform() - 0.5), 8000 * (rng.uniform() - 0.5), z);
        const double elevation = ray % 4 == 0 ? 0.02 * (rng.uniform() - 0.5) : 2 * rng.uniform() - 1;
        const double azimuth = 2 * std::numbers::pi * rng.uniform();
        const Vec3 d = glm::normalize(Vec3(std::cos(azimuth), std::sin(azimuth), elevation));
        bounds.clear();
        layers.majorant(o, d, 0, 20000, eye, bounds);
        for (int k = 0; k < 400; ++k) {
            const double t = 20000 * rng.uniform();
            const double sigma = layers.extinction(o + t * d, eye);
            double bound = 0;
            for (const LayerVolumes::Bound& b : bounds)
                if (t >= b.t0 && t < b.t1) bound += b.bound;
            if (sigma > 0) ++matter;
            inside += bound > 0;
            ASSERT_LE(sigma, bound * (1 + 1e-12)) << "ray " << ray << " at t = " << t;
        }
    }
    std::printf("[ figure ] majorant: %d of 80000 points under a bound, %d with matter\n", inside, matter);
    EXPECT_GT(matter, 500);  // the rays do cross matter
}

TEST(LayerVolumeTest, ExtinctionIsTheLayeredSkysDensityMovedByTheWind) {
    Scene scene = layerScene(1, 1, 0.7, 0.9);
    scene.layers[0].wind = Vec2(6, 2);
    const LayeredSettings ls = smallTextures();
    const LayerVolumes now(scene, ls, 0.0), later(scene, ls, 250.0);
    const Vec3 eye(0.0);
    int nonZero = 0;
    for (int i = 0; i < 500; ++i) {
        const Vec3 p(37.0 * i, -23.0 * i + 400, kBase + 0.4 * i);
        const double sigma = now.extinction(p, eye);
        EXPECT_NEAR(sigma,
                    scene.medium.extinction *
                        layerDensity(scene.layers[0], now.modulation(0), ls.modulation, now.lighting(0), p, 0),
                    1e-12);
        EXPECT_NEAR(later.extinction(p + Vec3(250.0 * scene.layers[0].wind, 0.0), eye), sigma, 1e-9);
        nonZero += sigma > 0;
    }
    EXPECT_GT(nonZero, 50);
    // The rim: nothing beyond the extent, faded within the last extentFade of it. The fade is
    // held by its ends and middle, not by its formula: whole just inside the band, half at the
    // band's middle (a smoothstep's), under 3% in the last 1% of the extent (measured 0.028,
    // the smoothstep at 0.9 of a 10% band, exact up to rounding), and never rising
    // outward. Broken (no fade, tests/sabotage/15-layer-volume-no-rim-fade.sabotage): 1.0 at
    // the middle.
    EXPECT_EQ(now.extinction(Vec3(scene.layers[0].extent + 1, 0, kBase + 100), eye), 0.0);
    const double extent = scene.layers[0].extent, band = extent * ls.extentFade;
    int checkedRim = 0;
    for (int a = 0; a < 360; ++a) {
        const Vec2 dir(std::cos(glm::radians(double(a))), std::sin(glm::radians(double(a))));
        auto ratioAt = [&](double h) {
            const Vec3 p(h * dir, kBase + 100);
            const double whole = scene.medium.extinction *
                                 layerDensity(scene.layers[0], now.modulation(0), ls.modulation, now.lighting(0), p, 0);
            return whole > 0 ? now.extinction(p, eye) / whole : -1.0;
        };
        const double inside = ratioAt(extent - band - 1), middle = ratioAt(extent - 0.5 * band),
                     rim = ratioAt(extent - 0.01 * extent);
        if (inside < 0 || middle < 0 || rim < 0) continue;  // no matter at one of the three: another direction
        ++checkedRim;
        EXPECT_NEAR(inside, 1.0, 1e-9) << a;
        EXPECT_NEAR(middle, 0.5, 1e-9) << a;
        EXPECT_LT(rim, 0.03) << a;
        EXPECT_GE(middle, rim) << a;
    }
    EXPECT_GT(checkedRim, 5) << "the directions must cross matter at all three distances";
}

TEST(LayerVolumeTest, ScenesWithoutRenderedLayersAreBitIdentical) {
    Scene withLayer = layerScene(10, 8, 0.7, 0.9);
    withLayer.medium.noise = 0.3;
    Ellipsoid e;
    e.center = {0, 600, 900};
    e.radii = {200, 150, 120};
    withLayer.clouds.push_back({"one", {e}});
    Scene without = withLayer;
    without.layers.clear();
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(16, ns.cells, 2, ns.seed);
    const View view = makeView(without.camera);
    const PathTraceSettings plain{.spp = 3};
    const Image reference = renderPathTraced(without, view, plain, &noise);
    PathTraceSettings empty = plain;  // layer volumes of a scene without layers
    empty.layers = std::make_shared<LayerVolumes>(without, smallTextures(), 0.0);
    EXPECT_TRUE(renderPathTraced(without, view, empty, &noise).pixels == reference.pixels);
    // Layers in the scene but not asked for: left out, as before.
    EXPECT_TRUE(renderPathTraced(withLayer, view, plain, &noise).pixels == reference.pixels);
    // And asked for, they change the image (the test can fail).
    PathTraceSettings layered = plain;
    layered.layers = std::make_shared<LayerVolumes>(withLayer, smallTextures(), 0.0);
    EXPECT_FALSE(renderPathTraced(withLayer, view, layered, &noise).pixels == reference.pixels);
}

TEST(LayerVolumeTest, LayersTheirTexturesAndTimeAreInTheCacheKey) {
    const std::filesystem::path dir = test::freshProcessDir("nephele_layer_cache_", false);
    Scene scene = layerScene(6, 4, 0.7, 0.9);
    scene.layers[0].wind = Vec2(5, 0);
    LayeredSettings ls = smallTextures();
    ls.cacheDir = (dir / "light").string();
    auto render = [&](const Scene& sc, const LayeredSettings& l, double t) {
        PathTraceSettings s{.spp = 1, .maxBounces = 1};
        s.layers = std::make_shared<LayerVolumes>(sc, l, t);
        return renderPathTracedCached(sc, makeView(sc.camera), s, nullptr, dir.string());
    };
    std::uint64_t expected = detail::pathTracedImagesComputed();
    render(scene, ls, 0);
    EXPECT_EQ(detail::pathTracedImagesComputed(), ++expected);
    render(scene, ls, 0);
    EXPECT_EQ(detail::pathTracedImagesComputed(), expected) << "the same layers must hit";
    const std::vector<std::pair<const char*, std::function<void(Scene&, LayeredSettings&, double&)>>> changes{
        {"time", [](Scene&, LayeredSettings&, double& t) { t = 10; }},
        {"coverage", [](Scene& s, LayeredSettings&, double&) { s.layers[0].coverage = 0.6; }},
        {"seed", [](Scene& s, LayeredSettings&, double&) { s.layers[0].seed = 9; }},
        {"wind", [](Scene& s, LayeredSettings&, double&) { s.layers[0].wind.y = 1; }},
        {"base", [](Scene& s, LayeredSettings&, double&) { s.layers[0].base += 10; }},
        {"lighting volume", [](Scene&, LayeredSettings& l, double&) { l.lighting.seed = 4; }},
        {"modulation", [](Scene&, LayeredSettings& l, double&) { l.modulation.octaves = 3; }},
        {"extent fade", [](Scene&, LayeredSettings& l, double&) { l.extentFade = 0.2; }},
    };
    for (const auto& [what, change] : changes) {
        Scene s = scene;
        LayeredSettings l = ls;
        double t = 0;
        change(s, l, t);
        render(s, l, t);
        EXPECT_EQ(detail::pathTracedImagesComputed(), ++expected) << what << " did not miss the cache";
    }
    std::filesystem::remove_all(dir);
}
