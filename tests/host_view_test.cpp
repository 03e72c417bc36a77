// The host API without GL: views from a host's matrices (any frustum and depth convention),
// display channels (off-axis frusta, rotations about the eye) and their projection of
// ellipsoids, and the CIGI-shaped weather and its transitions.
#include "nephele/host_view.hpp"
#include "nephele/projection.hpp"
#include "nephele/weather.hpp"
#include "weather_blend.hpp"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <random>

using namespace nephele;

namespace {

Camera testCamera() {
    Camera c;
    c.position = Vec3(1.5e6, -2.5e6, 900);  // far from the origin, as a simulator's world
    c.direction = glm::normalize(Vec3(0.3, 1.0, 0.15));
    c.fovYDeg = 50;
    c.width = 300;
    c.height = 200;
    c.nearClip = 0.7;
    c.farClip = 60000;
    return c;
}

// A projection of frustum f (tangents), near n and far f in a depth convention (infinite far:
// farClip = INFINITY, reversed only).
glm::dmat4 projection(const Frustum& t, double n, double f, DepthConvention dc) {
    glm::dmat4 p = glm::frustum(t.left * n, t.right * n, t.bottom * n, t.top * n, n, std::isinf(f) ? 1e9 : f);
    // Clip depth c = (P22 z + P32) / -z with c(-n), c(-f) the convention's ends.
    const double cn = dc.reversedZ ? 1 : (dc.zeroToOne ? 0 : -1), cf = dc.reversedZ ? (dc.zeroToOne ? 0 : -1) : 1;
    if (std::isinf(f)) {  // c = cf + (cn - cf) n / -z
        p[2][2] = -cf;
        p[3][2] = (cn - cf) * n;
    } else {  // -z c = P22 z + P32 at z = -n, -f
        const double a = (cf * f - cn * n) / (n - f);
        p[2][2] = a;
        p[3][2] = cn * n + a * n;
    }
    return p;
}

void expectSameView(const View& a, const View& b, double tol) {
    EXPECT_LT(glm::length(a.eye - b.eye), tol * (1 + glm::length(a.eye)));
    EXPECT_LT(glm::length(a.forward - b.forward), tol);
    EXPECT_LT(glm::length(a.right - b.right), tol);
    EXPECT_LT(glm::length(a.up - b.up), tol);
    for (double d : {a.frustum.left - b.frustum.left, a.frustum.right - b.frustum.right,
                     a.frustum.bottom - b.frustum.bottom, a.frustum.top - b.frustum.top})
        EXPECT_LT(std::abs(d), tol);
    EXPECT_NEAR(a.camera.nearClip, b.camera.nearClip, tol * a.camera.nearClip);
    EXPECT_NEAR(a.camera.farClip, b.camera.farClip, 1e-6 * a.camera.farClip);
}

}  // namespace

TEST(HostViewTest, TheSceneCameraRoundTripsThroughAViewDesc) {
    const View v = makeView(testCamera());
    const View w = makeView(viewDescOf(v, 0));
    expectSameView(v, w, 1e-9);
    EXPECT_EQ(w.camera.width, 300);
    EXPECT_EQ(w.camera.height, 200);
    // Rays agree: the host's matrices carry the whole view.
    for (auto [px, py] : {std::pair{0.5, 0.5}, {299.5, 120.25}, {150.0, 100.0}})
        EXPECT_LT(glm::length(v.rayDirection(px, py) - w.rayDirection(px, py)), 1e-9);
}

TEST(HostViewTest, ReadsNearAndFarInEveryDepthConvention) {
    const Frustum f{-0.9, 0.4, -0.3, 0.5};  // off-axis
    const View base = makeView(testCamera(), f);
    for (bool reversed : {false, true})
        for (bool zeroToOne : {false, true}) {
            const DepthConvention dc{reversed, zeroToOne};
            ViewDesc d = viewDescOf(base, 0);
            d.projection = projection(f, 0.7, 60000, dc);
            d.depth = dc;
            const View v = makeView(d);
            SCOPED_TRACE(::testing::Message() << "reversed " << reversed << " zeroToOne " << zeroToOne);
            expectSameView(base, v, 1e-9);
            // Depth parameters: 1 / z = x d + y at the near (far) plane's window depth.
            const glm::dvec3 p = v.depthParameters();
            const double dNear = reversed ? 1 : 0, dFar = reversed ? 0 : 1;
            EXPECT_NEAR(1 / (p.x * dNear + p.y), 0.7, 1e-9);
            EXPECT_NEAR(1 / (p.x * dFar + p.y), 60000, 1e-3);
            EXPECT_EQ(p.z, dFar);
        }
    // An infinite reversed-Z projection: far = kMaxFar.
    ViewDesc d = viewDescOf(base, 0);
    d.depth = {true, true};
    d.projection = projection(f, 0.7, INFINITY, d.depth);
    const View v = makeView(d);
    EXPECT_NEAR(v.camera.nearClip, 0.7, 1e-12);
    EXPECT_EQ(v.camera.farClip, kMaxFar);
}

TEST(HostViewTest, BadViewsAreRejectedWithTheReason) {
    const ViewDesc good = viewDescOf(makeView(testCamera()), 0);
    auto message = [](const ViewDesc& d) -> std::string {
        try {
            makeView(d);
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    ViewDesc d = good;
    d.view = glm::scale(d.view, Vec3(2.0));
    EXPECT_NE(message(d).find("not orthonormal"), std::string::npos) << message(d);
    d = good;
    d.projection = glm::ortho(-1.0, 1.0, -1.0, 1.0, 0.5, 100.0);
    EXPECT_NE(message(d).find("perspective"), std::string::npos) << message(d);
    d = good;
    d.depth.reversedZ = true;  // a standard projection read as reversed: near and far swap
    EXPECT_NE(message(d).find("depth convention"), std::string::npos) << message(d);
    d = good;
    d.viewport = {0, 0, 0, 100};
    EXPECT_NE(message(d).find("viewport"), std::string::npos) << message(d);
    d = good;
    d.viewport = {-4, 0, 100, 100};
    EXPECT_NE(message(d).find("offset"), std::string::npos) << message(d);
    d = good;
    d.view[3][0] = NAN;
    EXPECT_NE(message(d).find("non-finite"), std::string::npos) << message(d);
    EXPECT_EQ(message(good), "");
}

TEST(HostViewTest, ChannelRotationTurnsTheAxesAboutTheEye) {
    Camera c = testCamera();
    c.direction = Vec3(0, 1, 0);  // level, looking north
    const View v = makeView(c, symmetricFrustum(50, 1.5), 90, 0);
    EXPECT_LT(glm::length(v.forward - Vec3(1, 0, 0)), 1e-12);  // yaw 90: east
    EXPECT_LT(glm::length(v.up - Vec3(0, 0, 1)), 1e-12);
    const View p = makeView(c, symmetricFrustum(50, 1.5), 0, 30);
    EXPECT_NEAR(glm::degrees(std::asin(p.forward.z)), 30, 1e-9);  // pitch 30: up
    EXPECT_NEAR(glm::dot(p.up, p.forward), 0, 1e-12);
    EXPECT_THROW(makeView(c, Frustum{1, -1, -1, 1}), std::invalid_argument);
}

// An off-axis channel sees the wide view's ellipsoids where the wide view sees them: its NDC
// rectangle is the wide one's mapped onto the channel (and clipped to it), and a channel's
// rectangle is never smaller than the part of the wide one it covers.
TEST(HostViewTest, ChannelsProjectEllipsoidsWhereTheWideViewDoes) {
    Camera c = testCamera();
    c.width = 600;
    c.height = 200;
    const Frustum wide{-1.5, 1.5, -0.5, 0.5};
    const View w = makeView(c, wide);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    int checked = 0;
    for (int k = 0; k < 400; ++k) {
        Ellipsoid e;
        e.center = w.eye + w.forward * (2000 + 1500 * u(rng)) + w.right * (2500 * u(rng)) + w.up * (800 * u(rng));
        e.radii = Vec3(150 + 100 * u(rng), 200 + 100 * u(rng), 80 + 50 * u(rng));
        e.rotationDeg = Vec3(40 * u(rng), 40 * u(rng), 180 * u(rng));
        const EllipsoidProjection pw = projectEllipsoid(e, w);
        for (int ch = 0; ch < 3; ++ch) {
            Camera cc = c;
            cc.width = 200;
            const Frustum f{-1.5 + ch, -0.5 + ch, -0.5, 0.5};
            const View v = makeView(cc, f);
            const EllipsoidProjection pc = projectEllipsoid(e, v);
            // The wide rectangle in this channel's NDC (x: 3 x - 2 (ch - 1) ... as an affine map).
            const double x0 = 3 * pw.rect.x0 - 2 * (ch - 1), x1 = 3 * pw.rect.x1 - 2 * (ch - 1);
            const bool inside = pw.visible && x1 > -1 && x0 < 1;
            EXPECT_EQ(pc.visible, inside) << k << " channel " << ch;
            if (!(pc.visible && inside)) continue;
            EXPECT_NEAR(pc.rect.x0, std::max(x0, -1.0), 1e-9);
            EXPECT_NEAR(pc.rect.x1, std::min(x1, 1.0), 1e-9);
            EXPECT_NEAR(pc.rect.y0, pw.rect.y0, 1e-9);
            EXPECT_NEAR(pc.rect.y1, pw.rect.y1, 1e-9);
            ++checked;
        }
    }
    EXPECT_GT(checked, 100);
}

TEST(WeatherTest, CigiFieldsBecomeTheLayer) {
    Weather w;
    CloudLayerControl c;
    c.layerId = 2;
    c.cloudType = CigiCloudType::Stratus;
    c.coverage = 75;
    c.baseElevation = 1800;
    c.thickness = 450;
    c.horizontalWindSpeed = 10;
    c.windDirection = 90;  // from the east: the clouds move west
    w.apply(c);
    ASSERT_EQ(w.layers.count(2), 1u);
    const Layer& l = w.layers.at(2).layer;
    EXPECT_DOUBLE_EQ(l.coverage, 0.75);
    EXPECT_DOUBLE_EQ(l.base, 1800);
    EXPECT_DOUBLE_EQ(l.thickness, 450);
    EXPECT_NEAR(l.wind.x, -10, 1e-12);
    EXPECT_NEAR(l.wind.y, 0, 1e-12);
    EXPECT_EQ(l.density, cloudTypeLook(CigiCloudType::Stratus).density);
    EXPECT_FALSE(l.nearLod);  // a sheet: drawn all the way in
    EXPECT_EQ(l.seed, 2u);
    c.windDirection = 0;  // from the north: south
    c.cloudType = CigiCloudType::Cumulus;
    w.apply(c);
    EXPECT_NEAR(w.layers.at(2).layer.wind.y, -10, 1e-12);
    EXPECT_TRUE(w.layers.at(2).layer.nearLod);
    // Other types keep the layer's look; None and disabled layers are not drawn but kept.
    w.layers.at(2).layer.density = 0.42;
    c.cloudType = CigiCloudType::Other3;
    w.apply(c);
    EXPECT_EQ(w.layers.at(2).layer.density, 0.42);
    c.cloudType = CigiCloudType::None;
    w.apply(c);
    EXPECT_TRUE(w.enabledLayers().empty());
    c.cloudType = CigiCloudType::Cumulus;
    c.weatherEnable = false;
    w.apply(c);
    EXPECT_TRUE(w.enabledLayers().empty());
    EXPECT_EQ(w.layers.size(), 1u);
}

TEST(WeatherTest, LayersFollowTheirIdsAndTheScene) {
    Scene s;
    for (int i = 0; i < 5; ++i) {
        Layer l;
        l.base = 1000 * (i + 1);
        l.thickness = 300;
        s.layers.push_back(l);
    }
    const Weather w = Weather::of(s);
    std::vector<int> ids;
    for (const auto& [id, l] : w.layers) ids.push_back(id);
    EXPECT_EQ(ids, (std::vector<int>{1, 2, 3, 10, 11}));
    const std::vector<Layer> layers = w.enabledLayers();
    ASSERT_EQ(layers.size(), 5u);
    for (int i = 0; i < 5; ++i) EXPECT_EQ(layers[i].base, 1000 * (i + 1));
}

TEST(WeatherTest, BadControlsNameTheLayerAndTheField) {
    auto message = [](CloudLayerControl c) -> std::string {
        try {
            Weather().apply(c);
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    CloudLayerControl c;
    EXPECT_EQ(message(c), "");
    c.layerId = 0;
    EXPECT_NE(message(c).find("ground fog"), std::string::npos) << message(c);
    c.layerId = 5;
    EXPECT_NE(message(c).find("layer 5"), std::string::npos) << message(c);
    c = {};
    c.coverage = 120;
    EXPECT_NE(message(c).find("coverage"), std::string::npos) << message(c);
    c = {};
    c.thickness = 0;
    EXPECT_NE(message(c).find("thickness"), std::string::npos) << message(c);
    c = {};
    c.horizontalWindSpeed = -1;
    EXPECT_NE(message(c).find("horizontal wind speed"), std::string::npos) << message(c);
    c = {};
    c.scope = CigiWeatherScope::Regional;
    EXPECT_NE(message(c).find("scope"), std::string::npos) << message(c);
    c = {};
    c.baseElevation = INFINITY;
    EXPECT_NE(message(c).find("base elevation"), std::string::npos) << message(c);
}

TEST(WeatherTest, ValidateNamesTheLayerAndTheField) {
    Scene s;
    Layer l;
    l.base = 1000, l.thickness = 300;
    s.layers.push_back(l);
    Weather w = Weather::of(s);
    EXPECT_NO_THROW(w.validate());
    w.layers.at(1).layer.thickness = -5;
    try {
        w.validate();
        ADD_FAILURE() << "a negative thickness passed";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("layer 1: thickness"), std::string::npos) << e.what();
    }
    w = Weather::of(s);
    w.sun.direction = Vec3(0.0);
    EXPECT_THROW(w.validate(), std::invalid_argument);
}

// ---- Transitions (blendWeather, weather_blend.hpp): what SkyRenderer::update shows between two weathers.
namespace {
Weather twoLayers() {
    Scene s;
    Layer a;
    a.base = 1000, a.thickness = 300, a.coverage = 0.4, a.density = 0.8, a.wind = Vec2(4, 0), a.seed = 3;
    Layer b = a;
    b.base = 4000, b.thickness = 200, b.seed = 9;
    s.layers = {a, b};
    s.sun.direction = glm::normalize(Vec3(1, 0, 1));
    return Weather::of(s);
}
}  // namespace

TEST(WeatherTest, BlendMovesEachFieldLinearlyAndEndsAtTheTarget) {
    const Weather from = twoLayers();
    Weather to = from;
    Layer& l = to.layers.at(1).layer;
    l.coverage = 0.8, l.density = 0.4, l.base = 1400, l.thickness = 500, l.extent = 10000, l.wind = Vec2(-4, 8),
    l.seed = 7;
    to.sun.intensity = 1, to.sun.color = Vec3(1, 0.5, 0.25);
    to.sky.zenith = Vec3(0.3);
    const Weather half = blendWeather(from, to, 0.5);
    const Layer& h = half.layers.at(1).layer;
    EXPECT_DOUBLE_EQ(h.coverage, 0.6);
    EXPECT_DOUBLE_EQ(h.density, 0.6);
    EXPECT_DOUBLE_EQ(h.base, 1200);
    EXPECT_DOUBLE_EQ(h.thickness, 400);
    EXPECT_DOUBLE_EQ(h.extent, 15000);
    EXPECT_EQ(h.wind, Vec2(0, 4));
    EXPECT_EQ(h.seed, 7u);                       // the pattern's identity: the target's at once
    EXPECT_DOUBLE_EQ(h.lightingThickness, 500);  // lit for the thickness it goes to: one volume per change
    EXPECT_DOUBLE_EQ(half.sun.intensity, 2);
    EXPECT_EQ(half.sun.color, Vec3(1, 0.75, 0.625));
    EXPECT_LT(glm::length(half.sky.zenith - (from.sky.zenith + Vec3(0.3)) * 0.5), 1e-12);
    // What does not change stays bit for bit (cells and grids are keyed on exact values).
    EXPECT_TRUE(half.layers.at(2).layer.coverage == from.layers.at(2).layer.coverage);
    EXPECT_EQ(half.sun.direction, to.sun.direction);
    // The ends: s = 0 is `from` in every continuous field, s >= 1 is `to` exactly.
    const Weather start = blendWeather(from, to, 0);
    EXPECT_DOUBLE_EQ(start.layers.at(1).layer.coverage, 0.4);
    EXPECT_DOUBLE_EQ(start.layers.at(1).layer.base, 1000);
    EXPECT_TRUE(blendWeather(from, to, 1).sameAs(to));
    EXPECT_TRUE(blendWeather(from, to, 7).sameAs(to));
}

TEST(WeatherTest, NewLayersFadeInAndDisabledOnesFadeOut) {
    Weather from = twoLayers();
    from.layers.at(2).enabled = false;
    Weather to = twoLayers();
    to.layers.at(1).enabled = false;
    for (double s : {0.0, 0.25, 0.5, 0.75}) {
        const Weather w = blendWeather(from, to, s);
        ASSERT_TRUE(w.layers.at(1).enabled) << s;  // fading out: from's layer, density x (1 - s)
        EXPECT_NEAR(w.layers.at(1).layer.density, 0.8 * (1 - s), 1e-12) << s;
        EXPECT_DOUBLE_EQ(w.layers.at(1).layer.coverage, 0.4) << s;
        ASSERT_TRUE(w.layers.at(2).enabled) << s;  // fading in: to's layer, density x s
        EXPECT_NEAR(w.layers.at(2).layer.density, 0.8 * s, 1e-12) << s;
        EXPECT_DOUBLE_EQ(w.layers.at(2).layer.base, 4000) << s;
    }
    const Weather end = blendWeather(from, to, 1);
    EXPECT_FALSE(end.layers.at(1).enabled);
    EXPECT_TRUE(end.layers.at(2).enabled);
    EXPECT_DOUBLE_EQ(end.layers.at(2).layer.density, 0.8);
}

TEST(WeatherTest, TheSunTurnsAlongTheGreatCircleAtAConstantRate) {
    Weather from = twoLayers(), to = from;
    from.sun.direction = Vec3(1, 0, 0);
    to.sun.direction = Vec3(0, 0, 2);  // not normalised: the host's; the way is still the great circle
    double last = 0;
    for (int k = 1; k <= 8; ++k) {
        const double s = k / 8.0;
        const Vec3 d = blendWeather(from, to, s).sun.direction;
        const double angle = std::acos(std::clamp(glm::dot(glm::normalize(d), Vec3(1, 0, 0)), -1.0, 1.0));
        EXPECT_NEAR(glm::length(d), s < 1 ? 1.0 : 2.0, 1e-12) << s;
        EXPECT_NEAR(angle - last, 3.14159265358979 / 2 / 8, 1e-9) << s;  // the same turn every step
        EXPECT_NEAR(d.y, 0, 1e-12) << s;                                 // in the plane of the two
        last = angle;
    }
    to.sun.direction = Vec3(-1, 0, 0);  // opposite: some great circle, still a unit vector half way
    EXPECT_NEAR(glm::length(blendWeather(from, to, 0.5).sun.direction), 1.0, 1e-12);
    EXPECT_NEAR(glm::dot(blendWeather(from, to, 0.5).sun.direction, Vec3(1, 0, 0)), 0.0, 1e-9);
}

TEST(WeatherTest, ARetargetStartsFromWhatIsShown) {
    const Weather a = twoLayers();
    Weather b = a, c = a;
    b.layers.at(1).layer.coverage = 0.8;
    b.layers.at(2).enabled = false;
    c.layers.at(1).layer.coverage = 0.2;
    const ShownWeather mid = blendShown(shownOf(a), b, 0.5);  // layer 2 half faded out
    EXPECT_DOUBLE_EQ(mid.layers.at(2).fade, 0.5);
    const ShownWeather again = blendShown(mid, c, 0);  // the new transition's first frame: where it was
    EXPECT_DOUBLE_EQ(again.layers.at(1).layer.coverage, mid.layers.at(1).layer.coverage);
    EXPECT_DOUBLE_EQ(again.layers.at(2).fade, 0.5);
    const ShownWeather on = blendShown(mid, c, 0.5);  // layer 2 back on: from its fade to 1
    EXPECT_DOUBLE_EQ(on.layers.at(2).fade, 0.75);
    EXPECT_DOUBLE_EQ(on.layers.at(1).layer.coverage, 0.4);
}

TEST(WeatherTest, ABadTransitionTimeIsRefusedByName) {
    Weather w = twoLayers();
    EXPECT_NO_THROW(w.validate());
    for (double bad : {-1.0, double(INFINITY), double(NAN)}) {
        w.transitionSeconds = bad;
        try {
            w.validate();
            ADD_FAILURE() << "transitionSeconds " << bad << " passed";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("transitionSeconds"), std::string::npos) << e.what();
        }
    }
    w.transitionSeconds = 2.5;
    EXPECT_NO_THROW(w.validate());
    Weather other = twoLayers();
    EXPECT_TRUE(w.sameAs(other));  // a change of the transition time alone is no change of weather
    other.layers.at(2).layer.coverage = 0.41;
    EXPECT_FALSE(w.sameAs(other));
}
