// Weather transitions through the host API (Weather::transitionSeconds, SkyRenderer::update): a
// change ramps over the host's time instead of popping, near cells included; a new layer fades
// in from its first frames, drawn with the nearest lighting made while its own is made; a
// disabled one fades out; a new weather mid-way starts from what is shown; 0 s is the change at
// once, and a ramp ends exactly where the change at once is; one lighting job per change.
#include "gl_test_util.hpp"
#include "layered_test_util.hpp"

#include "nephele/host_view.hpp"
#include "nephele/opaque.hpp"
#include "nephele/sky.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

using namespace nephele;

namespace {

constexpr double kDt = 0.1;    // s per frame
constexpr double kRamp = 1.0;  // s: 10 frames
constexpr int kRampFrames = 10;

// The eye 1 km under a layer (1500-2100 m), looking 35 degrees up: the layer fills the frame. No
// wind, so that only the weather changes from frame to frame.
Scene layerScene(bool nearLod) {
    Scene s;
    s.camera.position = Vec3(0, 0, 500);
    s.camera.direction = Vec3(std::cos(glm::radians(35.0)), 0, std::sin(glm::radians(35.0)));
    s.camera.width = 64, s.camera.height = 40;
    s.camera.fovYDeg = 60;
    Layer l;
    l.base = 1500, l.thickness = 600, l.coverage = 0.35, l.density = 1, l.seed = 5, l.extent = 30000;
    l.nearLod = nearLod;
    s.layers.push_back(l);
    return s;
}

// Small textures and grids; cellsPerUpdate as given (0: every cell due in each update).
SkySettings settings(int cellsPerUpdate = kCellsPerUpdate) {
    SkySettings s = test::smallSky();
    s.cellsPerUpdate = cellsPerUpdate;
    return s;
}

// The layer lit as the library's default (test::busyLighting): a job is still running in the
// frames right after the change that queued it.
SkySettings slowLighting() {
    SkySettings s = settings();
    s.layered.lighting = test::busyLighting();
    return s;
}

// One frame of the host's: its sky, then the clouds; the image and the draw's stats.
struct Frame {
    Image image;
    SkyStats stats;
    double opacity = 0;  // mean alpha: the share of the frame the clouds cover
};

Frame draw(SkyRenderer& sky, const Scene& scene, FrameTarget& target) {
    const View view = makeView(scene.camera);
    OpaquePass().draw(scene, view, target.framebuffer());
    Frame f;
    f.stats = sky.draw(viewDescOf(view, target.framebuffer()));
    f.image = target.readColor();
    for (int y = 0; y < f.image.height; ++y)
        for (int x = 0; x < f.image.width; ++x) f.opacity += f.image.at(x, y, 3);
    f.opacity /= double(f.image.width) * f.image.height;
    return f;
}

// The opacity of each frame from the one a change lands in (s = 0) to the end of its ramp and
// one more, after `before` frames of the starting weather.
struct Ramp {
    double start = 0;             // the last frame before the change
    std::vector<double> opacity;  // from the frame of the change on
    std::vector<SkyUpdateStats> updates;
};

class TransitionGLTest : public test::EglTest {};

// Largest step between neighbours, and whether the sequence moves one way (within `slack`).
double largestStep(double start, const std::vector<double>& v) {
    double step = std::abs(v.front() - start);
    for (std::size_t k = 1; k < v.size(); ++k) step = std::max(step, std::abs(v[k] - v[k - 1]));
    return step;
}
bool monotonic(double start, const std::vector<double>& v, int sign, double slack) {
    double last = start;
    for (double x : v) {
        if (sign * (x - last) < -slack) return false;
        last = x;
    }
    return true;
}

// A host drawing `scene` with its weather: prepared, one frame of the scene's own weather
// updated; step() is the next frame of `weather`, drawn.
struct Host {
    Scene scene;
    SkyRenderer sky;
    FrameTarget target;
    Weather weather;
    Host(const Scene& s, const SkySettings& settings)
        : scene(s), sky(settings), target(s.camera.width, s.camera.height), weather(Weather::of(s)) {
        sky.prepare(scene);
        sky.update(kDt, weather, scene.camera.position);
    }
    Frame frame() { return draw(sky, scene, target); }
    Frame step(SkyUpdateStats* update = nullptr) {
        const SkyUpdateStats u = sky.update(kDt, weather, scene.camera.position);
        if (update) *update = u;
        return frame();
    }
    // The opacity of `frames` frames; by default to the end of a kRamp transition (ten steps
    // of 0.1 s sum to just under 1 s: one frame more).
    Ramp ramp(int frames = kRampFrames + 2) {
        Ramp r;
        for (int k = 0; k < frames; ++k) {
            SkyUpdateStats u;
            r.opacity.push_back(step(&u).opacity);
            r.updates.push_back(u);
        }
        return r;
    }
};

// A coverage change 0.35 -> 0.7 over kRamp, frame by frame.
Ramp coverageRamp(bool nearLod, int cellsPerUpdate, double transition) {
    Host h(layerScene(nearLod), settings(cellsPerUpdate));
    for (int k = 0; k < 2; ++k) h.step();
    h.sky.waitForBackgroundWork();
    const double start = h.step().opacity;
    h.weather.layers.at(1).layer.coverage = 0.7;
    h.weather.transitionSeconds = transition;
    Ramp r = h.ramp();
    r.start = start;
    return r;
}

}  // namespace

// The far field's opacity moves from the start to the end over the ramp, one way, in steps no
// larger than 2.5 times the even share of the whole change (1/10 of it a frame: the opacity is
// not linear in coverage, so some steps are larger than others; a pop is the whole change in
// one step, 10 times the share), and the first frame of the change is still the start.
TEST_F(TransitionGLTest, ACoverageChangeRampsTheOpacitySmoothly) {
    const Ramp r = coverageRamp(false, kCellsPerUpdate, kRamp);
    const double change = r.opacity.back() - r.start;
    ASSERT_GT(change, 0.1) << "the change must show for the test to mean anything";
    EXPECT_NEAR(r.opacity.front(), r.start, 1e-6);  // s = 0: the weather shown before
    EXPECT_TRUE(monotonic(r.start, r.opacity, +1, 1e-4));
    EXPECT_LE(largestStep(r.start, r.opacity), 2.5 * change / kRampFrames)
        << "start " << r.start << ", end " << r.opacity.back() << ", frame 1 " << r.opacity[1];
    for (int k = 0; k <= kRampFrames; ++k)
        EXPECT_NEAR(r.updates[k].transition, std::min(1.0, k * kDt / kRamp), 1e-9) << k;
    EXPECT_DOUBLE_EQ(r.updates.back().transition, 1.0);
}

// Near cells included: with the near LOD on and the eye under the layer, the near clouds follow
// the ramp at most kCellsPerUpdate cells an update (the cells made longest ago first), and the
// frame's opacity moves as the far field's does, one way and in bounded steps (here 3 times the
// even share: the near cells catch up over 2-3 frames of the ramp, so their part moves in
// steps of up to three frames' worth).
TEST_F(TransitionGLTest, NearCellsFollowARampWithinTheirBudget) {
    const Ramp r = coverageRamp(true, kCellsPerUpdate, kRamp);
    const double change = r.opacity.back() - r.start;
    ASSERT_GT(change, 0.1);
    EXPECT_TRUE(monotonic(r.start, r.opacity, +1, 2e-3));
    EXPECT_LE(largestStep(r.start, r.opacity), 3 * change / kRampFrames)
        << "start " << r.start << ", end " << r.opacity.back();
    int made = 0;
    for (const SkyUpdateStats& u : r.updates) {
        EXPECT_LE(u.nearLod.generated, kCellsPerUpdate);
        made += u.nearLod.generated;
    }
    EXPECT_GT(made, kRampFrames);  // the cells were made again during the ramp, not once at its end
}

namespace {
// Whatever the updates queued made and taken: the target's lighting, then the near cells made
// again with it (they were made with the nearest volume meanwhile), then those cells' grids.
void settle(SkyRenderer& sky, const Weather& w) {
    const Vec3 eye = layerScene(true).camera.position;
    for (int k = 0; k < 2; ++k) {
        sky.waitForBackgroundWork();
        sky.update(0, w, eye);
    }
}
}  // namespace

// 0 s is the change in the frame it is given (as before transitions existed): the frame of a
// renderer that started with the target's weather, to the rounding of its lighting (made here in
// the calling thread's parallel loop, there on the one-core worker: sums in another order). A
// ramp ends exactly there: pixel for pixel the frame of the change at once. Near cells
// included: every cell due is made in each update here.
TEST_F(TransitionGLTest, ARampEndsWhereTheChangeAtOnceIsAndZeroSecondsIsAtOnce) {
    Scene scene = layerScene(true);
    Scene changed = scene;
    changed.layers[0].coverage = 0.7, changed.layers[0].thickness = 500, changed.layers[0].base = 1400;
    FrameTarget target(scene.camera.width, scene.camera.height);
    auto frameAfter = [&](double transition, int frames) {
        SkyRenderer sky(settings(0));
        sky.prepare(scene);
        sky.update(kDt, Weather::of(scene), scene.camera.position);
        Weather w = Weather::of(changed);
        w.transitionSeconds = transition;
        for (int k = 0; k < frames; ++k) sky.update(kDt, w, scene.camera.position);
        settle(sky, w);
        return draw(sky, scene, target).image;
    };
    auto largestDifference = [](const Image& a, const Image& b) {
        float d = 0;
        for (std::size_t i = 0; i < a.pixels.size(); ++i) d = std::max(d, std::abs(a.pixels[i] - b.pixels[i]));
        return d;
    };
    SkyRenderer reference(settings(0));
    reference.prepare(changed);
    reference.update(kDt, Weather::of(changed), scene.camera.position);
    settle(reference, Weather::of(changed));
    const Image expected = draw(reference, scene, target).image;
    const Image atOnce = frameAfter(0, 1);
    // The rounding moves a pixel by 4.2e-5 at most here; half the change, by more than 0.02.
    EXPECT_LE(largestDifference(atOnce, expected), 1e-3) << "0 s is not the change at once";
    const Image ramped = frameAfter(kRamp, kRampFrames + 2);  // ten steps of 0.1 s sum to just under 1 s
    EXPECT_TRUE(ramped.pixels == atOnce.pixels)
        << "the ramp did not end at the target: " << largestDifference(ramped, atOnce);
    const Image midway = frameAfter(kRamp, kRampFrames / 2);
    EXPECT_GT(largestDifference(midway, atOnce), 0.02) << "half way is already the target";
}

// A new layer fades in from its first frames, drawn with the nearest lighting made (the other
// layer's thickness) while its own is still being made: not withheld. The lighting takes about
// 0.3 s and the frames are a few ms, so the first frames draw before it is ready (asserted: the
// draw reports the layer waiting). Its opacity grows frame by frame; the jobs queued are its
// lighting and its modulation, not one a frame.
TEST_F(TransitionGLTest, ANewLayerFadesInWhileItsLightingIsMade) {
    Scene scene = layerScene(false);
    scene.layers[0].coverage = 0;  // invisible, but its lighting is made: the nearest there is
    Host h(scene, slowLighting());
    EXPECT_EQ(h.frame().opacity, 0.0);
    CloudLayerControl c;
    c.layerId = 2, c.cloudType = CigiCloudType::Cumulus, c.coverage = 60, c.baseElevation = 1600, c.thickness = 300;
    h.weather.apply(c);
    h.weather.layers.at(2).layer.nearLod = false;  // the far field alone: cumulus would be near clouds over the eye
    h.weather.transitionSeconds = kRamp;
    std::vector<double> opacity;
    std::string frames;  // each frame's opacity, * where the layer still waited: said on a failure
    int mostJobs = 0;
    bool drawnWhileWaiting = false;
    for (int k = 0; k <= kRampFrames; ++k) {
        SkyUpdateStats u;
        const Frame f = h.step(&u);
        mostJobs = std::max(mostJobs, u.backgroundJobs);
        opacity.push_back(f.opacity);
        frames += " " + std::to_string(f.opacity) + (f.stats.layered.pendingLayers > 0 ? "*" : "");
        if (k >= 1 && f.stats.layered.pendingLayers > 0 && f.opacity > 0) drawnWhileWaiting = true;
    }
    EXPECT_EQ(opacity[0], 0.0);  // s = 0: density x 0
    EXPECT_GT(opacity[1], 0.0) << "withheld while its lighting is made";
    EXPECT_TRUE(drawnWhileWaiting) << "the lighting was ready before the first frames: the test needs it pending";
    EXPECT_TRUE(monotonic(0, opacity, +1, 1e-3)) << "opacity by frame:" << frames;
    // Its own pattern (from the first frame, at a quarter of the resolution until the full one is
    // made) covers 9% of this view at the fade's end: measured 0.091.
    EXPECT_GT(opacity.back(), 0.05);
    EXPECT_LE(mostJobs, 2) << "jobs queued a frame: a lighting volume per frame?";
}

// The near LOD does not wait for a new cumulus layer's lighting either: its cells are made with
// the nearest volume made (the other layer's thickness) from the first frame of the ramp, and
// made again with its own when that is ready.
TEST_F(TransitionGLTest, ANewLayersNearCloudsAreMadeWhileItsLightingIsMade) {
    Scene scene = layerScene(true);
    scene.layers[0].coverage = 0;  // no near cloud of its own, but its lighting is made
    SkySettings s = slowLighting();
    s.cellsPerUpdate = 0;
    Host h(scene, s);
    CloudLayerControl c;
    c.layerId = 2, c.cloudType = CigiCloudType::Cumulus, c.coverage = 60, c.baseElevation = 1600, c.thickness = 300;
    h.weather.apply(c);
    h.weather.transitionSeconds = kRamp;
    SkyUpdateStats first;
    h.step(&first);
    ASSERT_GT(first.backgroundJobs, 0) << "the lighting was made before the first frame: the test needs it pending";
    EXPECT_GT(first.nearLod.clouds, 0) << "no near cloud while the new layer's lighting is made";
}

// A new near_lod layer's near clouds fade in with it: their cells made once at the layer's own
// density, their weights times the fade, so the matter they hold near the eye (what densityAt
// reads: the near clouds times their weights; the far field leaves the near disc to them) is
// the final matter times s, frame by frame. Made again at each frame's faded density instead,
// the faint columns would be left out (minColumnDepth) and the matter would not be linear in s.
// The layer shares the seed and thickness of the first, so its data is made and its cells are
// its own from the first frame.
TEST_F(TransitionGLTest, ANewLayersNearCloudsFadeInWithIt) {
    Scene scene = layerScene(true);
    SkyRenderer sky(settings(0));
    sky.prepare(scene);
    Weather w = Weather::of(scene);
    sky.update(kDt, w, scene.camera.position);
    Weather::CloudLayer second = w.layers.at(1);
    second.layer.base = 3000, second.layer.coverage = 0.6;
    w.layers[2] = second;
    w.transitionSeconds = kRamp;
    // The matter on a grid of points in the new layer within 1.4 km of the eye (inside the near disc).
    auto matter = [&] {
        double sum = 0;
        for (int j = -7; j <= 7; ++j)
            for (int i = -7; i <= 7; ++i)
                for (double z : {3150.0, 3300.0, 3450.0}) sum += sky.densityAt(Vec3(100.0 * i, 100.0 * j, z));
        return sum;
    };
    std::vector<double> m, s;
    for (int k = 0; k <= kRampFrames + 1; ++k) {
        s.push_back(sky.update(kDt, w, scene.camera.position).transition);
        m.push_back(matter());
    }
    ASSERT_EQ(s.back(), 1.0);
    ASSERT_GT(m.back(), 0.0) << "no near cloud of the new layer on the grid";
    for (std::size_t k = 0; k < m.size(); ++k)
        EXPECT_NEAR(m[k], s[k] * m.back(), 1e-9 * m.back()) << "frame " << k << ", s " << s[k];
}

// A layer disabled with a transition fades out (density x (1 - s)) and is gone at its end.
TEST_F(TransitionGLTest, ADisabledLayerFadesOut) {
    Host h(layerScene(false), settings());
    const double start = h.frame().opacity;
    ASSERT_GT(start, 0.1);
    h.weather.layers.at(1).enabled = false;
    h.weather.transitionSeconds = kRamp;
    const std::vector<double> opacity = h.ramp().opacity;
    EXPECT_TRUE(monotonic(start, opacity, -1, 1e-4));
    EXPECT_NEAR(opacity[0], start, 1e-6);
    EXPECT_GT(opacity[kRampFrames / 2], 0.2 * start);  // half way, half the matter: still there
    EXPECT_LT(opacity[kRampFrames / 2], 0.9 * start);
    EXPECT_EQ(opacity.back(), 0.0);
}

// A new weather mid-way starts its own ramp from what is shown: no jump at the retarget.
TEST_F(TransitionGLTest, ANewWeatherMidwayStartsFromWhatIsShown) {
    Host h(layerScene(false), settings());
    const double start = h.frame().opacity;
    h.weather.layers.at(1).layer.coverage = 0.7;
    h.weather.transitionSeconds = kRamp;
    const double halfway = h.ramp(kRampFrames / 2 + 1).opacity.back();
    ASSERT_GT(halfway - start, 0.04);
    h.weather.layers.at(1).layer.coverage = 0.2;
    const Ramp down = h.ramp();
    EXPECT_EQ(down.updates[0].transition, 0.0);
    EXPECT_NEAR(down.opacity[0], halfway, 1e-6) << "the retarget jumped";
    EXPECT_TRUE(monotonic(halfway, down.opacity, -1, 1e-4));
    EXPECT_LT(down.opacity.back(), start);
}

// A thickness change needs a new lighting volume: one job for the target's thickness, not one
// per frame of the ramp (each frame's thickness is new). The volume takes about 0.3 s, the
// frames a few ms: jobs a frame would pile up.
TEST_F(TransitionGLTest, AThicknessRampQueuesOneLightingJob) {
    Host h(layerScene(false), slowLighting());
    h.weather.layers.at(1).layer.thickness = 900;
    h.weather.transitionSeconds = kRamp;
    int mostJobs = 0, mostPending = 0;
    for (int k = 0; k <= kRampFrames; ++k) {
        SkyUpdateStats u;
        EXPECT_GT(h.step(&u).opacity, 0.05) << k;  // drawn all along
        mostJobs = std::max(mostJobs, u.backgroundJobs);
        mostPending = std::max(mostPending, h.sky.backgroundJobs());
    }
    EXPECT_LE(mostJobs, 1);
    EXPECT_LE(mostPending, 1);
}

// A sun ramp lights the clouds for the sun it goes to: each cloud's radiance grid is made once
// for the change, not once a frame (every frame's sun is new, and a grid a frame never finishes
// while the sun moves). With the worker waited for after each update, the whole ramp makes one
// grid per cloud (measured 2; without the target's lighting 20, two a frame from the second),
// and its last frame is that of a renderer that started with the new sun. (A grid finished but
// not yet taken is not made again by a channel's draw: before that, 3 in some runs.)
TEST_F(TransitionGLTest, ASunRampMakesEachCloudsGridOnce) {
    Scene scene = layerScene(false);
    scene.layers.clear();
    for (double y : {-400.0, 400.0}) {  // two shapes (a translated cloud shares its grid)
        Cloud c;
        Ellipsoid e;
        e.center = Vec3(2000, y, 1700), e.radii = y < 0 ? Vec3(300, 300, 200) : Vec3(250, 350, 180);
        c.ellipsoids.push_back(e);
        scene.clouds.push_back(c);
    }
    scene.sun.direction = glm::normalize(Vec3(1, 0.3, 0.8));
    Scene turned = scene;
    turned.sun.direction = glm::normalize(Vec3(-0.5, 0.5, 0.6));
    Host h(scene, settings());
    for (int k = 0; k < 3; ++k) {  // whatever the first updates queued, made and taken
        h.sky.waitForBackgroundWork();
        h.step();
    }
    ASSERT_GT(h.frame().opacity, 0.01) << "the clouds must be in view";
    h.weather.sun.direction = turned.sun.direction;
    h.weather.transitionSeconds = kRamp;
    int made = 0;
    std::string perFrame;  // grids taken by each update
    Frame last;
    for (int k = 0; k <= kRampFrames + 1; ++k) {
        SkyUpdateStats u;
        last = h.step(&u);
        made += u.lightVolumes;
        perFrame += " " + std::to_string(u.lightVolumes);
        h.sky.waitForBackgroundWork();
    }
    EXPECT_EQ(made, 2) << "grids taken frame by frame:" << perFrame;
    Host fresh(turned, settings());
    fresh.sky.waitForBackgroundWork();
    fresh.step();
    const Frame expected = fresh.frame();
    EXPECT_LT(compareImages(last.image, expected.image, 1.0).meanAbs, 1e-5)
        << "the ramp did not end in the new sun's light";
}

// transitionSeconds must be a finite number >= 0: update() refuses one that is not, by name.
TEST_F(TransitionGLTest, ABadTransitionTimeIsRefusedByName) {
    Host h(layerScene(false), settings());
    h.weather.transitionSeconds = -2;
    try {
        h.step();
        ADD_FAILURE() << "a negative transition time passed";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("transitionSeconds"), std::string::npos) << e.what();
    }
}
