// The layered far field reused across frames (LayeredSettings::reusePeriod, ReducedTarget::reuse):
// flown beside the same renderer drawing every pixel afresh, a reused frame stays within the
// issue's 40 dB of the fresh one, a refreshed block does not pop, a still view keeps its pixels
// exactly, a weather step and a moved object are drawn afresh at once.
#include "flight_test_util.hpp"
#include "gl_test_util.hpp"
#include "layered_test_util.hpp"
#include "temp_dir.hpp"
#include "test_build.hpp"

#include "nephele/camera.hpp"
#include "nephele/layered.hpp"
#include "nephele/opaque.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

using namespace nephele;

namespace {

// A deck 1.1 km above the eye, looked at 8 degrees up; 320x180 (reduced 160x90: 20x12 blocks
// of 8x8, each of the four turns spread over the image).
Scene deckScene() {
    Scene s;
    s.camera.position = Vec3(0, 0, 900);
    s.camera.direction = glm::normalize(Vec3(0, 1, std::tan(glm::radians(8.0))));
    s.camera.width = 320, s.camera.height = 180;
    Layer l;
    l.base = 2000, l.thickness = 600, l.extent = 20000;
    l.coverage = 0.6, l.density = 0.9;
    l.wind = Vec2(6, 2);
    s.layers.push_back(l);
    return s;
}

// One layered renderer kept across frames, drawing into its own target over the scene's ground and sky.
struct SkyFlight {
    SkyFlight(const LayeredSettings& s, const Scene& scene) : sky(s), target(scene.camera.width, scene.camera.height) {}
    Image frame(const Scene& scene, const View& view, double t) {
        OpaquePass().draw(scene, view, target.framebuffer());
        last = sky.render(scene, view, target.framebuffer(), t);
        return channels(target.readColor(), 0, 3);
    }
    LayeredRenderer sky;
    FrameTarget target;
    LayeredStats last;
};

LayeredSettings reuseSettings(int period = LayeredSettings{}.reusePeriod) {
    static const test::TempDir cache("nephele_far_reuse_");
    LayeredSettings s = test::smallLayered();
    s.cacheDir = test::runCacheDirOr(cache.dir().string());
    s.reusePeriod = period;
    return s;
}

// The mean |difference| between two frames in the 16x16 block (one reduced 8x8 block) at (bx, by).
double blockDiff(const Image& a, const Image& b, int bx, int by) {
    double sum = 0;
    int n = 0;
    for (int y = by; y < std::min(by + 16, a.height); ++y)
        for (int x = bx; x < std::min(bx + 16, a.width); ++x)
            for (int c = 0; c < 3; ++c) sum += std::abs(a.at(x, y, c) - b.at(x, y, c)), ++n;
    return sum / n;
}

// The largest mean |difference| of one 16x16 block between two frames.
double worstBlock(const Image& a, const Image& b) {
    double worst = 0;
    for (int by = 0; by < a.height; by += 16)
        for (int bx = 0; bx < a.width; bx += 16) worst = std::max(worst, blockDiff(a, b, bx, by));
    return worst;
}

// Frames of a flight: under the sanitizers fewer (the renderer's code is the same; llvmpipe's
// work is most of these tests' time, and CI's sanitizer step runs every test).
constexpr int kFlightFrames = test::kSanitized ? 10 : 16;

class FarReuseGLTest : public test::EglTest {};

}  // namespace

// What a flight of `frames` frames gives with the default period against every pixel fresh.
struct FlightResult {
    double worstDb = 1e9;
    double worstStepReused = 0,
           worstStepFresh = 0;                 // the largest mean |change| of a 16x16 block from one frame to the next
    double changeReused = 0, changeFresh = 0;  // mean |change| from one frame to the next, over the flight
    long long kept = 0;                        // reduced pixels kept, over the flight
};

template <class CameraAt>
FlightResult fly(const Scene& scene, int frames, CameraAt&& viewAt, const char* name) {
    SkyFlight reused(reuseSettings(), scene), fresh(reuseSettings(1), scene);
    FlightResult r;
    Image lastReused, lastFresh;
    for (int k = 0; k < frames; ++k) {
        const View view = viewAt(k);
        const double t = k / 30.0;
        const Image a = reused.frame(scene, view, t), b = fresh.frame(scene, view, t);
        EXPECT_EQ(reused.last.reusedFrame, k > 0) << "frame " << k;
        EXPECT_FALSE(fresh.last.reusedFrame);
        r.kept += std::max(reused.last.reusedPixels, 0LL);
        const double db = psnr(test::clamped(a), test::clamped(b));
        if (db < r.worstDb) {
            r.worstDb = db;
            if (db < 40) test::save(std::string(name) + "_reused", a), test::save(std::string(name) + "_fresh", b);
        }
        if (k > 0) {
            r.changeReused += test::meanChange(a, lastReused) / (frames - 1);
            r.changeFresh += test::meanChange(b, lastFresh) / (frames - 1);
            r.worstStepReused = std::max(r.worstStepReused, worstBlock(a, lastReused));
            r.worstStepFresh = std::max(r.worstStepFresh, worstBlock(b, lastFresh));
        }
        lastReused = a, lastFresh = b;
    }
    return r;
}

// The bounds of a flight: 40 dB in every frame is the issue's; the frame-to-frame change may
// exceed fresh's by the flicker allowance, 0.002; and no 16x16 block (one reduced 8x8
// block, drawn afresh in its turn) steps from one frame to the next by more than 3/255 over the
// largest step of fresh's flight: at this size the layer's texture is aliased, and a kept block
// is its last sample moved where a fresh one samples anew (measured at the defaults, period 8
// and 2 px: 43.0 dB off-axis, 45.1 symmetric; steps +2.3/255 at most; the change -0.00002; 85%
// of the texels kept). At least `keptShare` of the reduced pixels of frames 2.. were kept.
void expectWithinBounds(const FlightResult& r, int frames, double keptShare) {
    EXPECT_GE(r.worstDb, 40);
    EXPECT_LE(r.changeReused, r.changeFresh + 0.002);
    EXPECT_LE(r.worstStepReused, r.worstStepFresh + 3.0 / 255) << "worst " << r.worstDb << " dB";
    EXPECT_GE(double(r.kept), keptShare * (frames - 2) * 160 * 90) << "worst " << r.worstDb << " dB";
    std::printf("[ figure ] %.1f dB worst, steps %.2f / %.2f of 255, change %.5f / %.5f, kept %.2f\n", r.worstDb,
                255 * r.worstStepReused, 255 * r.worstStepFresh, r.changeReused, r.changeFresh,
                double(r.kept) / ((frames - 2) * 160 * 90));
}

// At a simulator's pace (30 frames a second: 2.3 m and 0.3 degrees of yaw a frame, the wind
// blowing) under a deck 1.1 km up, in a symmetric view and in an off-axis channel.
TEST_F(FarReuseGLTest, AFlightStaysWithinTheBoundOfFreshFrames) {
    const Scene scene = deckScene();
    for (const bool offAxis : {false, true}) {
        SCOPED_TRACE(offAxis ? "an off-axis channel" : "a symmetric view");
        const FlightResult r = fly(
            scene, kFlightFrames,
            [&](int k) {
                Camera c = scene.camera;
                const double yaw = glm::radians(0.3 * k);
                c.position += Vec3(std::sin(yaw), std::cos(yaw), 0.0) * (2.3 * k);
                c.direction = glm::normalize(Vec3(std::sin(yaw), std::cos(yaw), std::tan(glm::radians(8.0))));
                return offAxis ? makeView(c, Frustum{-0.2, 1.0, -0.25, 0.4}) : makeView(c);
            },
            offAxis ? "far_reuse_off_axis" : "far_reuse_deck");
        // 7 of 8 turns, less the parallax bound's: most pixels kept
        expectWithinBounds(r, kFlightFrames, 0.6);
    }
}

// A thin layer 100 m above the eye, looked at 45 degrees up and flown sideways at 5 m a frame,
// towards the sun: the view of its matter turns by about 3 reduced px a frame, and the sun's
// forward-scattered glow on it stays where the sun is, which no reprojection of the matter
// follows: the parallax bound has it drawn afresh (kept: the sky beside it, where the layer
// is thin).
TEST_F(FarReuseGLTest, ALayerCloseByIsDrawnAfreshWhereItsViewTurns) {
    Scene scene = deckScene();
    scene.layers[0].base = 1000, scene.layers[0].thickness = 40;
    const FlightResult r = fly(
        scene, kFlightFrames - 4,
        [&](int k) {
            Camera c = scene.camera;
            c.position += Vec3(5.0 * k, 0, 0);
            c.direction = glm::normalize(Vec3(0, 1, 1));
            return makeView(c);
        },
        "far_reuse_thin");
    expectWithinBounds(r, kFlightFrames - 4, 0.0);
}

// The same view and time again and again: every kept pixel is the last frame's own (the
// reprojection lands on the texel's centre); an off-axis channel checks the ray of each pixel.
TEST_F(FarReuseGLTest, AStillViewKeepsItsPixels) {
    const Scene scene = deckScene();
    const View view = makeView(scene.camera, Frustum{-0.3, 0.9, -0.1, 0.5});
    SkyFlight reused(reuseSettings(), scene), fresh(reuseSettings(1), scene);
    const Image b = fresh.frame(scene, view, 0);
    long long kept = 0;
    for (int k = 0; k < 6; ++k) {
        const Image a = reused.frame(scene, view, 0);
        kept += std::max(reused.last.reusedPixels, 0LL);
        // float round-off of the texel coordinates through two matrices moves a bilinear fetch off the centre;
        // llvmpipe filters with 8-bit weights: one step of 1/256 of the largest contrast (1)
        EXPECT_LT(compareImages(a, b, 1e-3).maxAbs, 1.0 / 255) << "frame " << k;
    }
    EXPECT_GT(kept, 4 * 160 * 90 * 3 / 4);  // 7 of 8 turns of the 4 frames reported
}

// A step of the weather (more than a ramp makes in a frame) draws every pixel afresh in the
// frame it comes; a ramp's step keeps reusing.
TEST_F(FarReuseGLTest, AWeatherStepIsDrawnAfreshAtOnce) {
    Scene scene = deckScene();
    const View view = makeView(scene.camera);
    SkyFlight reused(reuseSettings(), scene), fresh(reuseSettings(1), scene);
    for (int k = 0; k < 3; ++k) reused.frame(scene, view, k / 30.0);
    scene.layers[0].coverage += 0.004;  // a ramp's step
    reused.frame(scene, view, 3 / 30.0);
    EXPECT_TRUE(reused.last.reusedFrame);
    scene.layers[0].coverage = 0.8;  // a step
    const Image a = reused.frame(scene, view, 4 / 30.0), b = fresh.frame(scene, view, 4 / 30.0);
    EXPECT_FALSE(reused.last.reusedFrame);
    EXPECT_EQ(compareImages(a, b, 0).maxAbs, 0.0);
    scene.sun.direction = glm::normalize(scene.sun.direction + Vec3(0.1, 0, 0));  // the sun jumps
    reused.frame(scene, view, 5 / 30.0);
    EXPECT_FALSE(reused.last.reusedFrame);
}

// A layer's lighting volume replaced by another (here its own light for 900 m, as a thickness
// ramp's target volume arrives) is rolled in over two frames: the frame it arrives keeps the
// pixels whose turn has not come (the old light, as the layer was drawn with it until then) and
// draws about half afresh, the next frame the rest, so that it equals the frame drawn afresh.
TEST_F(FarReuseGLTest, AReplacedLightingVolumeRollsInOverTwoFrames) {
    Scene scene = deckScene();
    scene.layers[0].wind = Vec2(0);  // a still pattern and a still view: only the light changes
    const View view = makeView(scene.camera);
    SkyFlight reused(reuseSettings(), scene), fresh(reuseSettings(1), scene);
    Image before;
    for (int k = 0; k < 4; ++k) before = reused.frame(scene, view, k / 30.0);
    scene.layers[0].lightingThickness = 900;
    const Image a = reused.frame(scene, view, 4 / 30.0), freshA = fresh.frame(scene, view, 4 / 30.0);
    EXPECT_TRUE(reused.last.reusedFrame) << "the new light drew every pixel afresh at once";
    ASSERT_GT(worstBlock(freshA, before), 4.0 / 255) << "the new light must show for the test to mean anything";
    // Blocks of the arrival frame: those drawn afresh (equal to fresh) and those kept (equal to before).
    int drawn = 0, kept = 0, blocks = 0;
    for (int by = 0; by < a.height; by += 16)
        for (int bx = 0; bx < a.width; bx += 16, ++blocks) {
            const double toFresh = blockDiff(a, freshA, bx, by), toBefore = blockDiff(a, before, bx, by);
            drawn += toFresh < toBefore, kept += toBefore < toFresh;
        }
    std::printf("[ figure ] arrival frame: %d blocks drawn with the new light, %d kept, of %d\n", drawn, kept, blocks);
    EXPECT_GT(drawn, blocks / 4);
    EXPECT_GT(kept, blocks / 4);
    const Image b = reused.frame(scene, view, 5 / 30.0), freshB = fresh.frame(scene, view, 5 / 30.0);
    EXPECT_TRUE(reused.last.reusedFrame);
    // Every pixel has the new light now: equal to fresh but for the resampling of a kept texel
    // (AStillViewKeepsItsPixels: llvmpipe's filter step, 1/255).
    EXPECT_LE(worstBlock(b, freshB), 1.0 / 255);
}

// A transition's new layer arrives at fade 0 (density 0), so it changes nothing yet: the far
// field keeps its pixels, as at each step of the fade after it (0.01 a frame); a dense layer
// turned on at once is drawn afresh.
TEST_F(FarReuseGLTest, ALayerTurnedOnAtFadeZeroKeepsThePixels) {
    Scene scene = deckScene();
    scene.layers[0].wind = Vec2(0);  // a still view: kept pixels are the last frame's exactly
    const View view = makeView(scene.camera);
    SkyFlight reused(reuseSettings(), scene), fresh(reuseSettings(1), scene);
    for (int k = 0; k < 3; ++k) reused.frame(scene, view, k / 30.0);
    Layer above = scene.layers[0];
    above.base = 3200, above.seed = 5, above.density = 0;
    scene.layers.push_back(above);
    const Image a = reused.frame(scene, view, 3 / 30.0), b = fresh.frame(scene, view, 3 / 30.0);
    EXPECT_TRUE(reused.last.reusedFrame) << "a layer at fade 0 drew every pixel afresh";
    EXPECT_GT(reused.last.reusedPixels, reused.last.reducedPixels / 2);
    EXPECT_LT(compareImages(a, b, 1e-3).maxAbs, 1.0 / 255);  // as AStillViewKeepsItsPixels
    scene.layers[1].density = 0.01;                          // the fade's first step
    reused.frame(scene, view, 4 / 30.0);
    EXPECT_TRUE(reused.last.reusedFrame);
    Layer dense = scene.layers[0];
    dense.base = 4500, dense.seed = 6;
    scene.layers.push_back(dense);
    reused.frame(scene, view, 5 / 30.0);
    EXPECT_FALSE(reused.last.reusedFrame) << "a dense layer turned on at once was kept out";
}

// Under a ramp (the coverage 0.0167 a frame, a 2 s ramp's share at 30 fps) the far field keeps
// reusing, and no block lags the weather by more than a frame's step: each step adds to every
// kept texel's bound (one reduced px per 0.01, 1.67 px here against a bound of 2), so a texel
// is kept one frame at most.
TEST_F(FarReuseGLTest, UnderARampNoBlockLagsMoreThanAFramesStep) {
    Scene scene = deckScene();
    const View view = makeView(scene.camera);
    SkyFlight reused(reuseSettings(), scene), fresh(reuseSettings(1), scene);
    Image lastFresh;
    double worstLag = 0, worstStep = 0;
    long long kept = 0, total = 0;
    for (int k = 0; k < 12; ++k) {
        if (k >= 2) scene.layers[0].coverage += 0.3 / 18;
        const Image a = reused.frame(scene, view, k / 30.0), b = fresh.frame(scene, view, k / 30.0);
        if (k >= 3) {
            EXPECT_TRUE(reused.last.reusedFrame) << "frame " << k;
            worstLag = std::max(worstLag, worstBlock(test::clamped(a), test::clamped(b)));
            worstStep = std::max(worstStep, worstBlock(test::clamped(b), test::clamped(lastFresh)));
            kept += reused.last.reusedPixels, total += reused.last.reducedPixels;
        }
        lastFresh = b;
    }
    const double keptShare = double(kept) / double(std::max(total, 1LL));
    std::printf("[ figure ] under a ramp: worst 16x16 block from fresh %.4f, fresh's worst step %.4f, %.0f%% kept\n",
                worstLag, worstStep, 100 * keptShare);
    EXPECT_GT(worstStep, 2.0 / 255);  // the ramp shows
    // A frame's step (measured 0.018 against 0.026), and 1/255 for the resampling of a kept
    // texel (AStillViewKeepsItsPixels).
    EXPECT_LE(worstLag, worstStep + 1.0 / 255);
    EXPECT_GT(keptShare, 0.25);  // reused, not drawn afresh every frame (measured 50%)
}

// A box in front of the deck moves: where it was, the last image holds no cloud (the box hid
// it), so those pixels are drawn afresh; the rest are kept exactly (the view is still).
TEST_F(FarReuseGLTest, WhereASurfaceWasTheLayerIsDrawnAfresh) {
    Scene scene = deckScene();
    const View view = makeView(scene.camera);
    Object box;
    box.type = Object::Type::Box;
    box.center = Vec3(-30, 400, 900 + 400 * std::tan(glm::radians(10.0)));
    box.size = Vec3(40, 10, 40);
    scene.objects.push_back(box);
    SkyFlight reused(reuseSettings(), scene), fresh(reuseSettings(1), scene);
    for (int k = 0; k < 3; ++k) reused.frame(scene, view, 0);
    scene.objects[0].center.x += 60;
    const Image a = reused.frame(scene, view, 0), b = fresh.frame(scene, view, 0);
    EXPECT_TRUE(reused.last.reusedFrame);
    const ImageDifference d = compareImages(a, b, 1e-3);  // 1/255: as AStillViewKeepsItsPixels
    if (d.maxAbs >= 1.0 / 255) test::save("far_reuse_box_reused", a), test::save("far_reuse_box_fresh", b);
    EXPECT_LT(d.maxAbs, 1.0 / 255);
}
