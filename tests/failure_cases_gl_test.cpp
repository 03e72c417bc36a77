// Where fast cloud methods classically break, one test per failure case, named after it:
// a tile jumping to the next power of two on approach, a flat cloud seen edge-on, an
// ellipsoid cut by the near plane, the ray-marcher's growing step on approach. Each is
// checked against the exact evaluation of the same model (`gardner-exact`, or the closed
// form of the density field for the ray-marcher), so a pop or a hole is a failure here.
// gardner-exact shares the compositor's model source: these tests catch pops, holes and
// order flips of the pipeline, not a wrong light (the path-tracer tests hold the light).
#include "gl_test_util.hpp"

#include "nephele/camera.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/gardner.hpp"
#include "nephele/metrics.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"
#include "nephele/raymarch.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>

using namespace nephele;

namespace {

using test::clamped;
using test::save;

// One ellipsoid 3 km ahead of a small camera, noise off (the model's exact field).
Scene oneEllipsoid(Vec3 radii) {
    Scene s;
    s.file = "failure case";
    s.camera.position = {0, -3000, 1500};
    s.camera.direction = {0, 1, 0};
    s.camera.width = 96;
    s.camera.height = 72;
    s.medium.noise = 0;
    Cloud c;
    c.name = "c";
    Ellipsoid e;
    e.center = {0, 0, 1500};
    e.radii = radii;
    c.ellipsoids.push_back(e);
    s.clouds.push_back(c);
    return s;
}

class FailureCaseGLTest : public test::EglTest {};

}  // namespace

// Approaching an ellipsoid, its tile size doubles whenever its screen size passes a power of
// two: the tile is then resampled from a texture twice as large. If that showed, the
// frame-to-frame change would spike at the jump where the exact model's does not.
TEST_F(FailureCaseGLTest, TileSizeJumpOnApproachDoesNotPop) {
    Scene s = oneEllipsoid({300, 300, 220});
    EllipsoidRenderer clouds;
    FrameTarget target(s.camera.width, s.camera.height);
    OpaquePass opaque;
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns);
    std::set<int> tiles;
    Image prevGpu, prevExact;
    double worst = 0, meanExactChange = 0;
    const int steps = 24;
    for (int k = 0; k <= steps; ++k) {
        s.camera.position.y = -6000 + 5000.0 * k / steps;  // 6 km to 1 km
        const View view = makeView(s.camera);
        opaque.draw(s, view, target.framebuffer());
        const EllipsoidStats st = clouds.render(s, view, target.framebuffer(), false);
        tiles.insert(int(st.tilePixels));  // one ellipsoid: its tile's area
        const Image gpu = target.readColor(), exact = renderGardnerExact(s, view, noise, ns);
        if (k > 0) {
            const double cg = meanClampedDifference(gpu, prevGpu), ce = meanClampedDifference(exact, prevExact);
            // Relative to what may change: 10% of the exact change plus 1e-4 for the bilinear
            // resampling of a small tile moving by a fraction of a pixel.
            worst = std::max(worst, std::fabs(cg - ce) / (0.1 * ce + 1e-4));
            meanExactChange += ce / steps;
            if (std::getenv("NEPHELE_TEST_VERBOSE"))
                std::printf("step %d tile area %lld change gpu %.5f exact %.5f\n", k, (long long)st.tilePixels, cg, ce);
        }
        prevGpu = gpu;
        prevExact = exact;
    }
    std::printf(
        "[ figure ] tile sizes used: %zu, worst |GPU change - exact change| / (0.1 exact change + 1e-4) = %.2f "
        "(mean exact change %.5f)\n",
        tiles.size(), worst, meanExactChange);
    ASSERT_GE(tiles.size(), 3u) << "the approach must cross at least two tile-size jumps to test them";
    // At every step, tile jumps included, the GPU's change stays within 10% (+1e-4) of the
    // exact model's: measured at most 0.58 of that margin on llvmpipe (the 1024 -> 4096 px^2
    // jump, 6% of the change). A pop would add about the ellipsoid's whole change at once.
    EXPECT_LT(worst, 1.0);
}

// A flat layer-like ellipsoid seen exactly edge-on from its own altitude: its screen
// rectangle is a few pixels tall, its chords are long and grazing. The tile must still hold
// the whole silhouette and the opacity must follow the density field.
TEST_F(FailureCaseGLTest, FlatCloudSeenEdgeOnFollowsTheDensityField) {
    Scene s = oneEllipsoid({1500, 1500, 60});
    s.camera.position = {0, -2500, 1500};  // at the ellipsoid's mid-plane: a band ~3 px tall
    const View view = makeView(s.camera);
    FrameTarget target(s.camera.width, s.camera.height);
    OpaquePass().draw(s, view, target.framebuffer());
    EllipsoidRenderer().render(s, view, target.framebuffer(), false);
    const Image gpu = target.readColor();
    const Image physics = exactDensityOpacity(s, view);
    const Image alpha = channels(gpu, 3, 1);
    const RenderComparison c = compareRenders(channels(gpu, 0, 3), channels(gpu, 0, 3), &alpha, &physics);
    double physicsSum = 0;
    for (float v : physics.pixels) physicsSum += v;
    std::printf("[ figure ] edge-on flat cloud: alpha MAE %.4f, IoU %.3f, physics alpha sum %.1f\n", c.alphaMae,
                c.alphaIou, physicsSum);
    ASSERT_GT(physicsSum, 10.0) << "the edge-on cloud must cover some pixels for the test to mean anything";
    if (c.alphaMae > 0.01) save("failure_edge_on_gpu", gpu);
    // The compositor's opacity is exact at noise 0 up to half-float storage and the bilinear
    // resampling of a 3 px tall silhouette: measured MAE 0.0003. 0.01 fails on a missing row.
    EXPECT_LT(c.alphaMae, 0.01);
}

// The eye just outside an ellipsoid, closer to it than the near plane: the near plane cuts
// it. Only the matter beyond the near plane may be drawn, and it must fill the right pixels.
TEST_F(FailureCaseGLTest, EllipsoidCutByTheNearPlaneMatchesTheExactModel) {
    Scene s = oneEllipsoid({300, 300, 220});
    s.camera.nearClip = 5;
    s.camera.position = {0, -303, 1500};  // 3 m outside the surface, 5 m near plane
    const View view = makeView(s.camera);
    FrameTarget target(s.camera.width, s.camera.height);
    OpaquePass().draw(s, view, target.framebuffer());
    EllipsoidRenderer().render(s, view, target.framebuffer(), false);
    const Image gpu = clamped(target.readColor());
    const NoiseSettings ns;
    const Image exact = clamped(renderGardnerExact(s, view, makeNoiseVolume(ns), ns));
    const double db = psnr(channels(gpu, 0, 3), channels(exact, 0, 3));
    std::printf("[ figure ] near-plane cut: GPU vs exact %.1f dB\n", db);
    if (db <= 33) save("failure_near_cut_gpu", gpu), save("failure_near_cut_exact", exact);
    // The same bound as the shared scenes' (see EllipsoidGLTest.MatchesGardnerExactOnSharedScenes).
    EXPECT_GT(db, 33.0);
}

// The ray-marcher's step grows with distance (the paper's LOD): on approach each pixel's
// samples move along the ray every frame. With noise (at noise 0 it integrates the closed
// form, nothing to test) its opacity must change like a fine fixed-step march's, without the
// jumps a step switch would make.
TEST_F(FailureCaseGLTest, RaymarchGrowingStepOnApproachDoesNotPop) {
    Scene s = oneEllipsoid({300, 300, 220});
    s.medium.noise = 0.3;
    RaymarchSettings fine;
    fine.step = 2;
    fine.lodDistance = 0;
    fine.downsample = 1;
    RaymarchRenderer marcher, reference(fine);
    FrameTarget target(s.camera.width, s.camera.height);
    OpaquePass opaque;
    auto alphaOf = [&](RaymarchRenderer& r, const View& view) {
        opaque.draw(s, view, target.framebuffer());
        r.render(s, view, target.framebuffer(), false);
        return channels(target.readColor(), 3, 1);
    };
    Image prevGpu, prevRef;
    double worst = 0, meanRefChange = 0;
    const int steps = 16;
    for (int k = 0; k <= steps; ++k) {
        s.camera.position.y = -8000 + 7000.0 * k / steps;
        const View view = makeView(s.camera);
        const Image alpha = alphaOf(marcher, view), ref = alphaOf(reference, view);
        if (k > 0) {
            worst =
                std::max(worst, std::fabs(meanClampedDifference(alpha, prevGpu) - meanClampedDifference(ref, prevRef)));
            meanRefChange += meanClampedDifference(ref, prevRef) / steps;
        }
        prevGpu = alpha;
        prevRef = ref;
    }
    std::printf("[ figure ] ray-marcher approach: worst |change - fine march's change| %.5f (mean change %.5f)\n",
                worst, meanRefChange);
    ASSERT_GT(meanRefChange, 0.002) << "the cloud must grow on screen for the test to mean anything";
    // A step switch that popped would change a visible part of the cloud's opacity at once:
    // of the order of the mean change itself. Measured on llvmpipe: see the figure line.
    EXPECT_LT(worst, 0.25 * meanRefChange);
}

// Flying through two overlapping ellipsoids (flythrough.json, 8.0 to 8.75 s): both cover the
// whole view and their centre distances cross, so the paper's back-to-front composite swaps
// which colour lies on top over the whole screen at once. The weighted composite has no
// order to flip. Inside the cloud the light itself changes fast as the eye goes deeper, in
// every order alike; a pop is the change the exact model in per-pixel depth order (which
// cannot flip as a whole) does not have: mean |(a1 - a0) - (r1 - r0)| over a step, clamped to
// [0, 1] as a display shows it. The weighted composite's worst such excess must stay well
// below back to front's (so this fails if the weighted composite is not what runs).
TEST_F(FailureCaseGLTest, OrderFlipThroughOverlappingEllipsoidsDoesNotPop) {
    const Scene s = test::sharedScene("flythrough.json");
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns);
    EllipsoidSettings weightedSettings, backToFrontSettings, momentSettings;
    weightedSettings.order = CompositeOrder::Weighted;
    backToFrontSettings.order = CompositeOrder::PerEllipsoid;
    momentSettings.order = CompositeOrder::Moments;
    EllipsoidRenderer weighted(weightedSettings), backToFront(backToFrontSettings), moments(momentSettings);
    OpaquePass opaque;
    FrameTarget target(96, 72);
    auto gpu = [&](EllipsoidRenderer& r, const View& view) {
        opaque.draw(s, view, target.framebuffer());
        r.render(s, view, target.framebuffer(), true);
        return target.readColor();
    };
    Image prev[4];
    double worst[3] = {0, 0, 0},
           exactWorst = 0;  // excess of weighted, back-to-front, moments (GPU); the exact model's change
    int worstFrame[3] = {0, 0, 0};
    const int steps = 6;  // 8 fps
    const int flip = 4;   // the step across 8.5 s, where the centre distances cross
    double atFlip[3] = {0, 0, 0};
    auto clamp01 = [](float v) { return std::clamp(v, 0.0f, 1.0f); };
    ExactLight light;  // the clouds' grids, made once for the seven frames
    for (int k = 0; k <= steps; ++k) {
        Camera c = cameraAt(s, 8.0 + 0.75 * k / steps);
        c.width = 96;
        c.height = 72;
        const View view = makeView(c);
        const Image frames[4] = {
            gpu(weighted, view), gpu(backToFront, view), gpu(moments, view),
            renderGardnerExact(s, view, noise, ns, CompositeOrder::PerPixel, model::kWeightExponent, {}, &light)};
        if (k > 0) {
            exactWorst = std::max(exactWorst, meanClampedDifference(frames[3], prev[3]));
            for (int m = 0; m < 3; ++m) {
                double sum = 0;
                for (std::size_t i = 0; i < frames[m].pixels.size(); ++i) {
                    if (i % 4 == 3) continue;
                    sum += std::abs((clamp01(frames[m].pixels[i]) - clamp01(prev[m].pixels[i])) -
                                    (clamp01(frames[3].pixels[i]) - clamp01(prev[3].pixels[i])));
                }
                const double excess = sum / (double(c.width) * c.height * 3);
                if (excess > worst[m]) worst[m] = excess, worstFrame[m] = k;
                if (k == flip) atFlip[m] = excess;
            }
        }
        for (int m = 0; m < 4; ++m) prev[m] = frames[m];
        if (k == flip) save("order_flip_weighted", frames[0]), save("order_flip_back_to_front", frames[1]);
    }
    std::printf(
        "[ figure ] order flip, worst excess change over the exact per-pixel order: weighted %.4f (step %d), "
        "back-to-front %.4f (step %d), moments %.4f (step %d); the exact model's own worst change %.4f; "
        "across the flip: weighted %.4f, back-to-front %.4f, moments %.4f\n",
        worst[0], worstFrame[0], worst[1], worstFrame[1], worst[2], worstFrame[2], exactWorst, atFlip[0], atFlip[1],
        atFlip[2]);
    ASSERT_GT(exactWorst, 0.005) << "the camera must move for the test to mean anything";
    // No step may pop: a quarter of the light's own change in a step. Measured on llvmpipe
    // (96 x 72): weighted 0.0054, back to front 0.0061 (worst at the flip, 8.5 s), moments
    // 0.0029; the exact model itself changes by 0.036 a step there. While the compositor's
    // noise thinned the rims (Gardner's threshold) back to front popped by 0.035 here (weighted
    // 0.012, moments 0.018), which this bound caught.
    for (int m = 0; m < 3; ++m)
        EXPECT_LT(worst[m], 0.25 * exactWorst) << (m == 0   ? "weighted"
                                                   : m == 1 ? "back to front"
                                                            : "moments")
                                               << " pops";
    EXPECT_EQ(worstFrame[1], flip)
        << "back to front's worst step is no longer the flip at 8.5 s: the test lost its failure case";
    // Today back to front's pop is small, and a quarter of the light's change would pass it
    // too: so across the flip the order-independent composites must also stay well below back
    // to front, as GardnerExactTest.WeightedOrderKeepsOpacityAndDoesNotPop asks of the exact
    // model (0.75x). Measured weighted 0.0037 (0.62x) and moments 0.0021 (0.35x) against back
    // to front's 0.0060; broken (the weighted composite running back to front, tests/sabotage/
    // 02-weighted-composite-runs-back-to-front.sabotage) 0.0060 (1.0x). A weight taken at each
    // ellipsoid's centre distance instead of the pixel's matter depth reaches 0.0042 (0.70x)
    // and passes: this bound catches the order flipping as a whole, not every weight drift
    // (WeightedCompositeMatchesGardnerExactWeighted holds the weight).
    EXPECT_LT(atFlip[0], 0.75 * atFlip[1]) << "the weighted composite pops across the flip as back to front does";
    EXPECT_LT(atFlip[2], 0.75 * atFlip[1]) << "the moment composite pops across the flip as back to front does";
}
