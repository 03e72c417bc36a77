// The layered sky's cloud shadows, Wang et al. eq. (19): the GPU pass (shaders/layered_shadow.frag)
// against its CPU twin sunTransmittance() at every pixel of a box top and of the ground, shadow
// where the modulation says cloud and none where it is clear, and the host's GL state.
#include "gl_test_util.hpp"
#include "layered_test_util.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/layered.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"

#include <cmath>
#include <cstdio>

using namespace nephele;
using namespace nephele::gl;

namespace {

LayeredSettings testSettings() {
    LayeredSettings s = test::smallLayered();
    s.modulation.period = 6000;  // 1 km cloud features, 47 m texels: several shadows across the box
    return s;
}

// The eye at 1000 m looking 60 degrees down (no ray reaches the layer at 2000-2600 m), a
// white-ish 1.6 km box top at 50 m, the ground around it, the sun tilted (its rays cross the
// layer's middle 400-500 m away from the point they light), wind at t = 40 s.
Scene shadowScene() {
    Scene s;
    s.camera.position = Vec3(0, 0, 1000);
    const double p = glm::radians(-60.0);
    s.camera.direction = Vec3(0, std::cos(p), std::sin(p));
    s.camera.width = 160, s.camera.height = 120;
    s.sun.direction = glm::normalize(Vec3(0.3, 0.2, 0.93));
    Layer l;
    l.base = 2000, l.thickness = 600, l.extent = 20000, l.coverage = 0.5, l.density = 1.0;
    l.wind = Vec2(12, -5);
    s.layers.push_back(l);
    Object box;
    box.type = Object::Type::Box;
    box.center = Vec3(0, 900, 25);
    box.size = Vec3(1600, 1600, 50);
    box.color = Vec3(0.8);
    s.objects.push_back(box);
    return s;
}

constexpr double kTime = 40;

struct Shadowed {
    Image rgba;
    ModulationTexture modulation;
    LayeredStats stats;
};

Shadowed renderShadowed(const Scene& scene, const LayeredSettings& settings, double time = kTime) {
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    LayeredRenderer sky(settings);
    Shadowed r;
    r.stats = sky.render(scene, view, target.framebuffer(), time);
    r.rgba = target.readColor();
    r.modulation = *sky.modulation(0);
    return r;
}

class LayeredShadowGLTest : public test::EglTest {};

}  // namespace

// At full resolution the shadows are a pass of their own; at half resolution they are fused
// into the upsampling of the layers: both must match the CPU twin.
class LayeredShadowResolutionGLTest : public LayeredShadowGLTest, public ::testing::WithParamInterface<int> {};
INSTANTIATE_TEST_SUITE_P(Downsample, LayeredShadowResolutionGLTest, ::testing::Values(1, 2));

TEST_P(LayeredShadowResolutionGLTest, ShaderMatchesSunTransmittanceOnObjectsAndGround) {
    const Scene scene = shadowScene();
    LayeredSettings settings = testSettings();
    settings.downsample = GetParam();
    const Shadowed r = renderShadowed(scene, settings);
    EXPECT_EQ(r.stats.shadowDrawCalls, settings.downsample == 1 ? 1 : 0);
    EXPECT_EQ(r.stats.shadowLayers, 1);
    const View view = makeView(scene.camera);
    const Layer& layer = scene.layers[0];
    const double share = groundSunShare(scene.sun, scene.sky);
    auto hitAt = [&](double x, double y) {
        return intersectObjects(scene, view.eye, view.rayDirection(x, y), scene.camera.nearClip, scene.camera.farClip);
    };
    double worst = 0, worstGround = 0, cloudLit = 0, clearLit = 0;
    int boxPixels = 0, groundPixels = 0, cloudPixels = 0, clearPixels = 0;
    Image diff(r.rgba.width, r.rgba.height, 3);
    for (int y = 0; y < r.rgba.height; ++y)
        for (int x = 0; x < r.rgba.width; ++x) {
            const auto hit = hitAt(x + 0.5, y + 0.5);
            // Skip the box's silhouette: the rasteriser and the CPU ray may disagree there.
            bool edge = false;
            for (auto [dx, dy] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}})
                edge = edge || hitAt(x + 0.5 + dx, y + 0.5 + dy).has_value() != hit.has_value();
            if (edge) continue;
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            Vec3 expected, point;
            double s;
            if (hit) {
                point = view.eye + d * hit->distance;
                s = sunTransmittance(layer, r.modulation, settings.modulation, scene.sun.direction, point, kTime);
                const Vec3 lit = lambertRadiance(scene.sun, hit->albedo, hit->normal);
                expected = lit * s;
                ++boxPixels;
                if (hit->normal.z > 0.99) {
                    if (s < 0.7) cloudLit += r.rgba.at(x, y, 0) / lit.x, ++cloudPixels;
                    if (s == 1.0) clearLit += r.rgba.at(x, y, 0) / lit.x, ++clearPixels;
                }
            } else {
                ASSERT_LT(d.z, 0);
                point = view.eye + d * (-view.eye.z / d.z);
                s = sunTransmittance(layer, r.modulation, settings.modulation, scene.sun.direction, point, kTime);
                expected = scene.sky.ground * (1 - share * (1 - s));
                ++groundPixels;
            }
            for (int c = 0; c < 3; ++c) {
                const double e = std::abs(r.rgba.at(x, y, c) - expected[c]);
                diff.at(x, y, c) = float(e * 50);
                worst = std::max(worst, e);
                if (!hit) worstGround = std::max(worstGround, e);
            }
            EXPECT_EQ(r.rgba.at(x, y, 3), 0.0f);  // the shadow leaves the cloud opacity alone
        }
    std::printf(
        "box %d px, ground %d px, worst |GPU - CPU| %.2e (ground %.2e); box top under cloud (S < 0.7) %.3f of its "
        "sunlit "
        "radiance (%d px), under clear sky %.3f (%d px)\n",
        boxPixels, groundPixels, worst, worstGround, cloudPixels ? cloudLit / cloudPixels : 0.0, cloudPixels,
        clearPixels ? clearLit / clearPixels : 0.0, clearPixels);
    EXPECT_GT(boxPixels, 5000);
    EXPECT_GT(groundPixels, 1000);
    // Radiance here is at most 0.8 * 3 / pi = 0.76. Ground points are exact planes on both
    // sides: only float arithmetic differs (1e-5). Box points are reconstructed from the
    // 24-bit depth with near = 0.5 m: 0.3-0.5 m along the ray at 1.5-2 km, where the
    // threshold field of these 47 m texels changes S by up to ~3e-3 per metre, so up to ~1.5e-3
    // in S (measured 1.8e-3 in radiance, printed above); 5e-3 is 1.3/255 of an 8-bit pixel.
    EXPECT_LT(worstGround, 1e-5);
    EXPECT_LT(worst, 5e-3);
    if (worst >= 5e-3 || worstGround >= 1e-5) {
        writePng(test::outputDir() + "/layered_shadow_" + std::to_string(GetParam()) + "_actual.png", r.rgba,
                 Encoding::Srgb);
        writePng(test::outputDir() + "/layered_shadow_" + std::to_string(GetParam()) + "_diff.png", diff,
                 Encoding::Linear);
    }
    // Darker where the layer's modulation is cloud than where it is clear: at C = 0.5 and
    // D = 1, eq. (19) gives S < 0.7 where r < 0.2 and exactly 1 where r >= C.
    ASSERT_GT(cloudPixels, 100);
    ASSERT_GT(clearPixels, 100);
    EXPECT_LT(cloudLit / cloudPixels, 0.7);
    EXPECT_NEAR(clearLit / clearPixels, 1.0, 1e-3);
}

TEST_F(LayeredShadowGLTest, NoShadowWithoutTheSunOrWhenTurnedOff) {
    Scene scene = shadowScene();
    LayeredSettings off = testSettings();
    off.shadows = false;
    const Shadowed none = renderShadowed(scene, off);
    EXPECT_EQ(none.stats.shadowLayers, 0);
    // The same frame without the layer: what the opaque pass alone draws (no ray meets the layer).
    Scene bare = scene;
    bare.layers.clear();
    const View view = makeView(bare.camera);
    FrameTarget target(bare.camera.width, bare.camera.height);
    OpaquePass().draw(bare, view, target.framebuffer());
    const Image opaque = target.readColor();
    EXPECT_EQ(none.rgba.pixels, opaque.pixels);
    scene.sun.direction = glm::normalize(Vec3(0.3, 0.2, -0.1));  // night: no sun term, no shadow
    const Shadowed night = renderShadowed(scene, testSettings());
    EXPECT_EQ(night.stats.shadowLayers, 0);
}

// The shadow at time t is the time-0 shadow moved by t * wind. Three frames would agree if the
// shadows were missing altogether, so the test also asks that there is a shadow (pixels under
// S < 0.7, against the same frame with shadows off) and that it moved between t = 0 and t.
TEST_F(LayeredShadowGLTest, ShadowsMoveWithTheWind) {
    Scene scene = shadowScene();
    const Image now = renderShadowed(scene, testSettings()).rgba;
    // At time t the shadow is the time-0 shadow of the world moved by t * wind: seen from an eye
    // moved by -t * wind with the box moved alike, the two frames agree.
    Scene moved = scene;
    moved.layers[0].wind = Vec2(0);
    const Vec3 shift(scene.layers[0].wind * kTime, 0.0);
    moved.camera.position -= shift;
    moved.objects[0].center -= shift;
    const Image same = renderShadowed(moved, testSettings()).rgba;
    const ImageDifference d = compareImages(now, same, 2e-3);
    LayeredSettings off = testSettings();
    off.shadows = false;
    const Image unshadowed = renderShadowed(scene, off).rgba;
    const Image start = renderShadowed(scene, testSettings(), 0).rgba;
    int dark = 0, lit = 0;
    for (int y = 0; y < now.height; ++y)
        for (int x = 0; x < now.width; ++x)
            if (unshadowed.at(x, y, 0) > 0.01f) {
                ++lit;
                dark += now.at(x, y, 0) < 0.7f * unshadowed.at(x, y, 0);
            }
    const double darkShare = double(dark) / std::max(lit, 1);
    const ImageDifference moves = compareImages(now, start, 2e-3);
    std::printf(
        "[ figure ] wind: moved-world frame differs at %.4f of the pixels; %.3f of the lit pixels under S < 0.7; "
        "t = 0 and t = %.0f s differ at %.3f of the pixels\n",
        d.fractionOver, darkShare, kTime, moves.fractionOver);
    // Measured 0.0000 (float texture coordinates may differ in their last bits); the wind
    // ignored (tests/sabotage/12-layered-shadows-ignore-the-wind.sabotage) 0.931.
    EXPECT_LT(d.fractionOver, 0.01);
    // Measured 0.380 of the lit pixels; no shadows at all (tests/sabotage/01-layered-shadows
    // -missing.sabotage) 0.000.
    EXPECT_GT(darkShare, 0.3);
    // Measured 0.931 (40 s of 13 m/s: 520 m, half a 1 km cloud feature); the wind ignored
    // 0.000.
    EXPECT_GT(moves.fractionOver, 0.8);
}

TEST_F(LayeredShadowGLTest, ShadowPassLeavesHostStateUnchanged) {
    const Scene scene = shadowScene();
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    LayeredRenderer sky(testSettings());
    const test::HostileGlState hostile;
    test::expectStateUnchanged(
        [&](int frame) { EXPECT_EQ(sky.render(scene, view, target.framebuffer(), frame).shadowLayers, 1); }, 2);
}

// The layers drawn at half resolution and upsampled with the frame's depth against the same
// frame at full resolution: no cloud on an object in front of the layer, not even at its
// silhouette (nearest-depth upsampling), and the layer itself alike elsewhere.
TEST_F(LayeredShadowGLTest, HalfResolutionMatchesFullResolutionAndKeepsSilhouettes) {
    Scene scene;
    scene.camera.position = Vec3(0, 0, 500);
    const double p = glm::radians(20.0);
    scene.camera.direction = Vec3(0, std::cos(p), std::sin(p));
    scene.camera.width = 160, scene.camera.height = 90;
    Layer l;
    l.base = 2000, l.thickness = 600, l.extent = 20000, l.coverage = 0.8, l.density = 1.0;
    scene.layers.push_back(l);
    Object box;  // an aircraft-sized box 300 m ahead, its edges across the cloud deck
    box.type = Object::Type::Box;
    box.center = Vec3(0, 300, 500 + 300 * std::tan(p));
    box.size = Vec3(120, 10, 40);
    box.rotationDeg = Vec3(0, 0, 15);
    scene.objects.push_back(box);
    LayeredSettings full = testSettings(), half = testSettings();
    full.downsample = 1, half.downsample = 2;
    const Image a = renderShadowed(scene, full).rgba, b = renderShadowed(scene, half).rgba;
    const View view = makeView(scene.camera);
    int boxPixels = 0, boxClouded = 0, sky = 0;
    double alphaDiff = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            const bool onBox = intersectObjects(scene, view.eye, view.rayDirection(x + 0.5, y + 0.5),
                                                scene.camera.nearClip, scene.camera.farClip)
                                   .has_value();
            if (onBox) {
                ++boxPixels;
                boxClouded += b.at(x, y, 3) != 0.0f;
            } else {
                ++sky;
                alphaDiff += std::abs(a.at(x, y, 3) - b.at(x, y, 3));
            }
        }
    std::printf("box %d px (%d with cloud at half resolution), mean |alpha difference| elsewhere %.4f\n", boxPixels,
                boxClouded, alphaDiff / sky);
    EXPECT_GT(boxPixels, 200);
    EXPECT_EQ(boxClouded, 0);
    // Half resolution blurs the layer's edges over a full-resolution pixel, and this frame is
    // all edges (160 x 90, 2 km cloud features; the opacity of a 1280 x 720 near_and_far.json
    // frame changes by 0.006 on average): measured 0.024 here, 0.05 bounds it.
    EXPECT_LT(alphaDiff / sky, 0.05);
    if (boxClouded != 0 || alphaDiff / sky >= 0.05) {
        writePng(test::outputDir() + "/layered_half_actual.png", b, Encoding::Srgb);
        writePng(test::outputDir() + "/layered_full_actual.png", a, Encoding::Srgb);
    }
}

// City glow is compiled into a program of its own (CITY_GLOW): a layer with glow is drawn with
// it and lit from below where the city map is, a layer without is drawn as before. Where: the
// red the glow adds to a pixel follows the city map (the modulation's green channel, fixed to
// the ground: the wind carries the clouds over the cities, not the cities) where the pixel's
// ray enters the layer's base.
class LayeredGlowGLTest : public LayeredShadowGLTest {};
TEST_F(LayeredGlowGLTest, GlowingLayerIsLitFromBelowOnlyWithGlow) {
    Scene scene;
    scene.camera.position = Vec3(0, 0, 500);
    scene.camera.direction = glm::normalize(Vec3(0, 1, 0.6));
    scene.camera.width = 160, scene.camera.height = 90;
    scene.sun.direction = glm::normalize(Vec3(0.3, 0.2, -0.5));  // night
    Layer l;
    l.base = 2000, l.thickness = 600, l.extent = 20000, l.coverage = 1.0, l.density = 1.0;
    l.wind = Vec2(40, 0);  // 1.6 km at kTime: a quarter of the city map's 6 km period
    scene.layers.push_back(l);
    const LayeredSettings settings = testSettings();
    const Image dark = renderShadowed(scene, settings).rgba;
    scene.layers[0].cityGlow = CityGlow{Vec3(1.0, 0.6, 0.3), 2.0};
    const Shadowed glowing = renderShadowed(scene, settings);
    const Image& lit = glowing.rgba;
    const View view = makeView(scene.camera);
    const double period = settings.modulation.period;
    double gain = 0, sg = 0, sc = 0, sgg = 0, scc = 0, sgc = 0, gainNoCity = 0, gainCity = 0;
    int brighter = 0, darker = 0, n = 0, noCity = 0, city = 0;
    for (int y = 0; y < dark.height; ++y)
        for (int x = 0; x < dark.width; ++x) {
            const double d = lit.at(x, y, 0) - dark.at(x, y, 0);
            gain += d;
            brighter += d > 1e-3;
            darker += d < -1e-6;
            const Vec3 ray = view.rayDirection(x + 0.5, y + 0.5);
            if (ray.z < 0.05) continue;
            const Vec3 p = view.eye + ray * ((l.base - view.eye.z) / ray.z);  // where the ray enters the layer
            const double c = glowing.modulation.sample(p.x / period, p.y / period, 1);
            sg += d, sc += c, sgg += d * d, scc += c * c, sgc += d * c, ++n;
            if (c < 0.02) gainNoCity += d, ++noCity;
            if (c > 0.1) gainCity += d, ++city;
        }
    const double r = (sgc / n - sg / n * sc / n) / std::sqrt((sgg / n - sg * sg / n / n) * (scc / n - sc * sc / n / n));
    std::printf(
        "glow: mean red gain %.4f, %d pixels brighter; against the city map at the layer's base: correlation %.3f, "
        "mean gain %.4f where no city (%d px), %.4f where city > 0.1 (%d px)\n",
        gain / (dark.width * dark.height), brighter, r, gainNoCity / std::max(noCity, 1), noCity,
        gainCity / std::max(city, 1), city);
    EXPECT_GT(brighter, dark.width * dark.height / 10);  // the city map covers part of the layer's view
    EXPECT_EQ(darker, 0);
    // Measured: correlation 0.921; mean gain 0.0052 where the map has no city, 0.2338 where it has
    // more than 0.1 (a ratio of 0.022). The city map read from the threshold channel
    // (tests/sabotage/19-city-glow-reads-the-threshold.sabotage): correlation -0.167, ratio 1.26;
    // the map carried by the wind (99-city-glow-moves-with-the-wind.sabotage): -0.068, 2.45.
    ASSERT_GT(noCity, 100);
    ASSERT_GT(city, 100);
    EXPECT_GT(r, 0.88);
    EXPECT_LT(gainNoCity / noCity, 0.03 * gainCity / city);
}

// Two layers: the shadow is the product of both layers' S (the fused upsampling compiled for
// two layers at half resolution, the separate pass's loop at full resolution).
TEST_P(LayeredShadowResolutionGLTest, TwoLayersMultiplyTheirShadows) {
    Scene scene = shadowScene();
    Layer upper = scene.layers[0];
    upper.base = 4000, upper.seed = 7, upper.coverage = 0.6, upper.density = 0.7;
    upper.wind = Vec2(-4, 9);
    scene.layers.push_back(upper);
    LayeredSettings settings = testSettings();
    settings.downsample = GetParam();
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    LayeredRenderer sky(settings);
    const LayeredStats stats = sky.render(scene, view, target.framebuffer(), kTime);
    EXPECT_EQ(stats.shadowLayers, 2);
    const Image rgba = target.readColor();
    const double share = groundSunShare(scene.sun, scene.sky);
    double worst = 0, minS = 1;
    int pixels = 0;
    for (int y = 0; y < rgba.height; ++y)
        for (int x = 0; x < rgba.width; ++x) {
            // Ground only (exact on both sides), away from the box's silhouette, where a pixel's
            // neighbours on the box make its texture footprint large (mipmapped there).
            bool nearBox = false;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx)
                    nearBox =
                        nearBox || intersectObjects(scene, view.eye, view.rayDirection(x + 0.5 + dx, y + 0.5 + dy),
                                                    scene.camera.nearClip, scene.camera.farClip);
            if (nearBox) continue;
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            const Vec3 point = view.eye + d * (-view.eye.z / d.z);
            double s = 1;
            for (int i = 0; i < 2; ++i)
                s *= sunTransmittance(scene.layers[i], *sky.modulation(i), settings.modulation, scene.sun.direction,
                                      point, kTime);
            minS = std::min(minS, s);
            const double expected = scene.sky.ground.x * (1 - share * (1 - s));
            worst = std::max(worst, std::abs(rgba.at(x, y, 0) - expected));
            ++pixels;
        }
    std::printf("two layers, downsample %d: %d ground px, worst |GPU - CPU| %.2e, darkest S %.3f\n", GetParam(), pixels,
                worst, minS);
    EXPECT_GT(pixels, 1000);
    EXPECT_LT(minS, 0.6);    // both layers' shadows show
    EXPECT_LT(worst, 1e-5);  // the ground plane is exact on both sides (see the first test)
}
