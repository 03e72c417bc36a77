// A level of detail per cloud (EllipsoidSettings::cloudLod): a far cloud drawn as one impostor
// of its tiles. A fresh impostor is its tiles' image (so the switch cannot pop), a still camera
// makes nothing again, a moving one stays close to every tile fresh, the switch while the eye
// closes in does not pop, a cloud turned into view is made again, and a new sun makes every
// impostor again.
#include "flight_test_util.hpp"
#include "prepared_clouds.hpp"

#include <cmath>
#include <limits>

using namespace nephele;
using nephele::test::db;
using nephele::test::Flight;
using nephele::test::meanChange;
using nephele::test::save;
using nephele::test::sharedScene;

namespace {

EllipsoidSettings lod(bool on = true) {
    EllipsoidSettings s;
    s.reuse = true;
    s.cloudLod = on;
    return s;
}

// Three cumulus27 clouds shrunk to a third (bounding radius about 310 m), 1000 m apart, seen
// from 2.5 km (8 radii) at 320x180: each about 50 px, all in view.
Scene threeClouds() {
    Scene scene = sharedScene("cumulus27.json", 320);
    scene.camera.height = 180;
    const Cloud base = scene.clouds[0];
    Vec3 centre(0.0);
    for (const Ellipsoid& e : base.ellipsoids) centre += e.center / double(base.ellipsoids.size());
    scene.clouds.clear();
    for (int k = -1; k <= 1; ++k) {
        Cloud c = base;
        for (Ellipsoid& e : c.ellipsoids) {
            e.center = centre + (e.center - centre) / 3.0 + Vec3(1000.0 * k, 0, 0);
            e.radii /= 3.0;
        }
        scene.clouds.push_back(c);
    }
    scene.camera.position = centre + Vec3(0, -2500, 0);
    scene.camera.direction = Vec3(0, 1, 0);
    return scene;
}

class CloudLodGLTest : public test::EglTest {};

// "Over" is associative: a cloud's tiles composited into its impostor, then the impostor over
// the frame, is its tiles over the frame. Measured on llvmpipe: 91.6 dB (the RGBA16F image's
// rounding); its image stretched by one pixel of its ~50 (a texel-for-pixel mapping gone
// wrong) measured 51.6 dB: 70 dB fails on that.
TEST_F(CloudLodGLTest, AFreshImpostorIsItsTiles) {
    const Scene scene = threeClouds();
    Flight on(lod(true), scene), off(lod(false), scene);
    const Image a = on.frame(scene, scene.camera), b = off.frame(scene, scene.camera);
    EXPECT_EQ(on.last.impostors, 3);
    EXPECT_EQ(on.last.impostorsRendered, 3);
    EXPECT_EQ(off.last.impostors, 0);
    const double d = db(a, b);
    if (d < 70) save("lod_fresh_on", a), save("lod_fresh_off", b);
    EXPECT_GE(d, 70);
}

// The second frame of a still camera makes no impostor and renders no tile, and looks as the
// first (60 dB, as for tiles: the reprojection of an image to the view it was made from).
TEST_F(CloudLodGLTest, AStillCameraMakesNothingAfterTheFirstFrame) {
    const Scene scene = threeClouds();
    Flight f(lod(), scene);
    const Image first = f.frame(scene, scene.camera);
    const Image second = f.frame(scene, scene.camera);
    EXPECT_EQ(f.last.impostors, 3);
    EXPECT_EQ(f.last.impostorsRendered, 0);
    EXPECT_EQ(f.last.tilesRendered, 0);
    const double d = db(second, first);
    if (d < 60) save("lod_still_second", second), save("lod_still_first", first);
    EXPECT_GE(d, 60);
}

// Flying past at 20 m a frame: every frame within 40 dB of every tile fresh (the issue's
// target), with most impostors reused. Measured on llvmpipe: worst 55.6 dB, 7 of 48 made again.
TEST_F(CloudLodGLTest, AMovingCameraStaysCloseToFreshTiles) {
    const Scene scene = threeClouds();
    Flight on(lod(), scene), off(EllipsoidSettings{}, scene);
    const Vec3 side(1, 0, 0);
    int made = 0, drawn = 0;
    double worst = 1e9;
    for (int k = 0; k < 17; ++k) {
        Camera c = scene.camera;
        c.position += side * (20.0 * k) + Vec3(0, 0, 3.0 * k);
        const Image a = on.frame(scene, c), b = off.frame(scene, c);
        const double d = db(a, b);
        if (d < worst && d < 40) save("lod_moving_on", a), save("lod_moving_fresh", b);
        worst = std::min(worst, d);
        if (k > 0) made += on.last.impostorsRendered, drawn += on.last.impostors;
    }
    EXPECT_GE(worst, 40);
    EXPECT_EQ(drawn, 48);
    EXPECT_GT(made, 0);  // the parallax of 320 m at 2.5 km passes the threshold
    EXPECT_LT(made, drawn / 2) << made << " of " << drawn << " impostors made again";
}

// Closing in on the middle cloud from 8 to 2.5 radii (it switches to tiles at 0.9 x 4 radii,
// the others stay impostors): no frame changes more than the same flight with every cloud
// drawn as tiles by more than 0.0005 of the mean |change| (a fifth of a frame's change here;
// measured on llvmpipe: at most 0.00007): a switch that popped would show as one frame's jump.
TEST_F(CloudLodGLTest, TheSwitchToTilesDoesNotPop) {
    const Scene scene = threeClouds();
    Flight on(lod(), scene), off(lod(false), scene);
    Image lastOn, lastOff;
    bool switched = false;
    for (int k = 0; k <= 30; ++k) {
        Camera c = scene.camera;
        c.position += Vec3(0, 60.0 * k, 0);  // 2500 -> 700 m from the middle cloud's centre
        const Image a = on.frame(scene, c), b = off.frame(scene, c);
        if (k > 0) {
            const double excess = meanChange(a, lastOn) - meanChange(b, lastOff);
            if (excess > 0.0005) save("lod_switch_on", a), save("lod_switch_before", lastOn);
            EXPECT_LE(excess, 0.0005) << "frame " << k;
        }
        switched = switched || on.last.impostors < 3;
        lastOn = a, lastOff = b;
    }
    EXPECT_TRUE(switched);
}

// A new sun: every impostor's light is stale; they are made again (worst first within the
// budget) and the image is then the fresh one.
TEST_F(CloudLodGLTest, ASunChangeMakesEveryImpostorAgain) {
    Scene scene = threeClouds();
    Flight f(lod(), scene);
    f.frame(scene, scene.camera);
    scene.sun.direction = glm::normalize(Vec3(-0.6, 0.3, 0.5));
    int made = 0, frames = 0;
    Image last;
    for (; frames < 10; ++frames) {
        last = f.frame(scene, scene.camera);
        if (f.last.impostorsRendered == 0) break;
        made += f.last.impostorsRendered;
    }
    EXPECT_EQ(made, 3);
    EXPECT_LE(frames, 3);
    Flight fresh(lod(false), scene);
    EXPECT_GE(db(last, fresh.frame(scene, scene.camera)), 70);  // as AFreshImpostorIsItsTiles
}

// A cloud cut by the view's edge is an impostor of what is in view; turning the rest of it into
// view makes it again (its image does not hold it), and the frame is then its tiles'. One
// ellipsoid, so that no ellipsoid comes newly into view: what is in view of it outgrowing the
// image's quad is what makes it again. Without that check it was not made again: 39.7 dB.
TEST_F(CloudLodGLTest, ACloudTurnedIntoViewIsMadeAgain) {
    Scene scene = threeClouds();
    scene.clouds.resize(1);
    scene.clouds[0].ellipsoids.resize(1);
    Ellipsoid& e = scene.clouds[0].ellipsoids[0];
    e.center = scene.camera.position + Vec3(0, 2500, 0);
    e.radii = Vec3(300, 300, 200);
    e.density = 1;
    Camera c = scene.camera;
    c.direction = glm::normalize(Vec3(-0.75, 1, 0));  // the cloud half out of view on the right
    Flight on(lod(), scene), off(lod(false), scene);
    on.frame(scene, c);
    EXPECT_EQ(on.last.impostors, 1);
    const Image a = on.frame(scene, scene.camera), b = off.frame(scene, scene.camera);
    EXPECT_EQ(on.last.impostors, 1);
    EXPECT_EQ(on.last.impostorsRendered, 1);
    const double d = db(a, b);
    if (d < 70) save("lod_turned_on", a), save("lod_turned_fresh", b);
    EXPECT_GE(d, 70);  // as AFreshImpostorIsItsTiles: made again, not a reprojection of the half
}

// Not a cloud LOD: a cloud cut by the near plane or nearer than the distance stays tiles; so do
// all with the weighted composite.
TEST_F(CloudLodGLTest, OnlyFarCloudsBeyondTheNearPlaneBecomeImpostors) {
    Scene scene = threeClouds();
    Camera c = scene.camera;
    c.position += Vec3(1000, 1700, 0);  // 800 m from the right cloud (2.6 radii), the others off to the side
    Flight f(lod(), scene);
    f.frame(scene, c);
    EXPECT_EQ(f.last.impostors, 0);
    EllipsoidSettings w = lod();
    w.order = CompositeOrder::Weighted;
    Flight g(w, scene);
    g.frame(scene, scene.camera);
    EXPECT_EQ(g.last.impostors, 0);
    EllipsoidSettings bad = lod();
    bad.cloudLodDistance = 0.5;
    EXPECT_THROW(EllipsoidRenderer{bad}, std::invalid_argument);
    bad = lod(), bad.cloudLodErrorPixels = 0;
    EXPECT_THROW(EllipsoidRenderer{bad}, std::invalid_argument);
}

// The close LOD: a tile is never finer than its ellipsoid's image (closeTileTexels): 128 texels
// for the smooth part, two per texel of the noise volume across its diameter when that is more.
TEST_F(CloudLodGLTest, ACloseTileHoldsItsSmoothPartOrItsNoise) {
    const double inf = std::numeric_limits<double>::infinity();
    EXPECT_EQ(closeTileTexels(100, inf), kSmoothTileTexels);  // no noise: the smooth part
    EXPECT_EQ(closeTileTexels(100, 7.5), kSmoothTileTexels);  // 107 texels of noise across 200 m
    EXPECT_NEAR(closeTileTexels(2000, 7.5), 1066.7, 0.1);     // a large ellipsoid keeps its noise
    PreparedEllipsoid e;
    e.projection.pixelWidth = 1280, e.projection.pixelHeight = 700;
    EXPECT_EQ(tileExtent(e), 1280);  // the paper: its size on screen
    e.contentTexels = 128;
    EXPECT_EQ(tileExtent(e), 128);
    e.projection.pixelWidth = 60, e.projection.pixelHeight = 90;
    EXPECT_EQ(tileExtent(e), 90);  // smaller on screen than its image: as on screen
}

// Inside cumulus27 at 640x360, its noise 240 m across (its texels 30 m: its ellipsoids, 100-170 m
// in radius, hold 128 texels), the ellipsoids around the eye span the view: with the cloud LOD
// their tiles are 128 px, not the 256 the paper renders (the largest this view's atlas holds),
// and the frame looks the same. Measured on llvmpipe: 262144 tile pixels against 851968, 79.9 dB
// apart. 50 dB leaves room for the rounding of other drivers and still fails on a blur one could
// see (a frame one 8-bit step off everywhere is 48 dB).
TEST_F(CloudLodGLTest, CloseTilesAreRenderedAtWhatTheirImageHolds) {
    Scene scene = sharedScene("cumulus27.json", 640);
    scene.camera.height = 360;
    scene.medium.noiseScale = 240;
    const Ellipsoid& big = scene.clouds[0].ellipsoids[0];
    Camera c = scene.camera;
    c.position = big.center + Vec3(0, -0.3 * big.radii.y, 0);
    c.direction = Vec3(0, 1, 0);
    EllipsoidSettings fresh = lod(false);
    fresh.reuse = false;
    EllipsoidSettings close = fresh;
    close.cloudLod = true;  // (no impostor: the eye is in the cloud)
    Flight on(close, scene), off(fresh, scene);
    const Image a = on.frame(scene, c), b = off.frame(scene, c);
    EXPECT_EQ(on.last.impostors, 0);
    EXPECT_GT(off.last.tilePixelsRendered, 2 * on.last.tilePixelsRendered)
        << off.last.tilePixelsRendered << " against " << on.last.tilePixelsRendered;
    const double d = db(a, b);
    if (d < 50) save("close_lod_on", a), save("close_lod_off", b);
    EXPECT_GE(d, 50);
}

// With the detail, a tile holds no finer texels than the detail's finest octave drawn needs
// (detailTileTexels: one across its cut, 0.004 rad at this range): detailed_cumulus.json from
// its own camera 1.6 km away at 640 x 480 (1,050 px a radian; the cut's texels 250 a radian,
// the smooth part's 128 a tile the floor) renders fewer tile pixels with the cloud LOD and looks
// the same. Measured on llvmpipe: 626,688 tile pixels against 1,216,512 (every tile at screen
// resolution, as before), 53.9 dB apart (at 960 x 720: 27% of the pixels, 50.4 dB). 45 dB: the
// cloud LOD's bound for far impostors (a frame one 8-bit step off everywhere is 48 dB).
TEST_F(CloudLodGLTest, DetailedTilesAreRenderedAtTheirFinestOctave) {
    Scene scene = sharedScene("detailed_cumulus.json", 640);
    scene.camera.height = 480;
    EllipsoidSettings fresh = lod(false);
    fresh.reuse = false;
    EllipsoidSettings close = fresh;
    close.cloudLod = true;
    close.cloudLodDistance = 1e6;  // tiles, not one impostor for the cloud: the close LOD alone
    Flight on(close, scene), off(fresh, scene);
    const Image a = on.frame(scene, scene.camera), b = off.frame(scene, scene.camera);
    EXPECT_EQ(on.last.impostors, 0);
    std::printf("[ figure ] detailed tiles: %lld tile pixels against %lld, %.1f dB\n",
                (long long)on.last.tilePixelsRendered, (long long)off.last.tilePixelsRendered, db(a, b));
    EXPECT_LT(on.last.tilePixelsRendered, off.last.tilePixelsRendered * 3 / 4);
    const double d = db(a, b);
    if (d < 45) save("detail_lod_on", a), save("detail_lod_off", b);
    EXPECT_GE(d, 45);
}

}  // namespace

namespace {

// Inside cumulus27's largest ellipsoid at 640x360 (the view of the test above), with a 30 m
// cube 40 m ahead when `box`.
struct InsideView {
    Scene scene;
    Camera camera;
    explicit InsideView(bool box) : scene(sharedScene("cumulus27.json", 640)) {
        scene.camera.height = 360;
        scene.medium.noiseScale = 240;
        const Ellipsoid& big = scene.clouds[0].ellipsoids[0];
        camera = scene.camera;
        camera.position = big.center + Vec3(0, -0.3 * big.radii.y, 0);
        camera.direction = Vec3(0, 1, 0);
        if (!box) return;
        Object cube;
        cube.center = camera.position + Vec3(0, 40, 0);
        cube.size = Vec3(30.0);
        scene.objects = {cube};
    }
    // The frame with the clouds over the objects and their depth; `objects` (if given) gets
    // 1 where an object is (the frame without clouds differs from the one without objects).
    Image frame(EllipsoidRenderer& r, EllipsoidStats& stats, std::vector<char>* objects = nullptr) const {
        FrameTarget target(scene.camera.width, scene.camera.height);
        const View view = makeView(camera);
        if (objects) {
            Scene bare = scene;
            bare.objects.clear();
            OpaquePass().draw(bare, view, target.framebuffer());
            const Image empty = target.readColor();
            OpaquePass().draw(scene, view, target.framebuffer());
            const Image full = target.readColor();
            objects->assign(std::size_t(empty.width) * empty.height, 0);
            for (std::size_t p = 0; p < objects->size(); ++p)
                for (int c = 0; c < 3; ++c) (*objects)[p] |= empty.pixels[4 * p + c] != full.pixels[4 * p + c];
        }
        OpaquePass().draw(scene, view, target.framebuffer());
        stats = r.render(scene, view, target.framebuffer(), !scene.objects.empty());
        return channels(target.readColor(), 0, 3);
    }
};

EllipsoidSettings closeLod(int downsample) {
    EllipsoidSettings s = lod(true);
    s.reuse = false;
    s.closeDownsample = downsample;
    return s;
}

}  // namespace

// The eye inside the cloud: the tiles round it cover the view at 128 texels, so runs of them
// are composited at half the resolution and upsampled; the frame looks the same. Measured on
// llvmpipe: 6 of 16 tiles downsampled, 78.8 dB from every tile at full resolution; the
// upsampling shifted by one pixel (half a reduced texel) 72.8 dB: 75 dB fails on that (the
// images are smooth, so a blur or a shift shows only as a few dB).
TEST_F(CloudLodGLTest, CloseTilesMagnifiedOnScreenAreCompositedAtAReducedResolution) {
    const InsideView v(false);
    EllipsoidRenderer half(closeLod(2)), full(closeLod(1));
    EllipsoidStats hs, fs;
    const Image a = v.frame(half, hs), b = v.frame(full, fs);
    EXPECT_GE(hs.tilesDownsampled, 2);
    EXPECT_EQ(fs.tilesDownsampled, 0);
    const double d = db(a, b);
    if (d < 75) save("close_half", a), save("close_full", b);
    EXPECT_GE(d, 75) << hs.tilesDownsampled << " of " << hs.visible << " tiles downsampled";
}

// With an object in the cloud the reduced composite takes the frame's depth (reduced per block to
// its farthest, upsampled from the neighbours at the pixel's own depth). Measured on llvmpipe
// against every tile at full resolution: 0.14 of an 8-bit step at most on the cube and round it,
// 0.15 at its silhouette (2 px either side), 78.9 dB. The reduced tiles' fraction read without
// the reduced depth: 154 steps off on the cube; the upsampling without the depth (bilinear):
// 19.4 steps at the silhouette, 51.4 dB. 2 steps away from the silhouette, 8 at it and 60 dB
// fail on both. (An object thinner than a block, a rotor blade, can still take the fog behind
// it: README.)
TEST_F(CloudLodGLTest, TheReducedCompositeKeepsToTheFramesDepth) {
    const InsideView v(true);
    EllipsoidRenderer half(closeLod(2)), full(closeLod(1));
    EllipsoidStats hs, fs;
    std::vector<char> objects;
    const Image a = v.frame(half, hs, &objects), b = v.frame(full, fs);
    ASSERT_GE(hs.tilesDownsampled, 2);
    const int W = a.width, H = a.height;
    double worstInside = 0, worstAway = 0, worstEdge = 0;
    int inside = 0;
    for (int y = 2; y < H - 2; ++y)
        for (int x = 2; x < W - 2; ++x) {
            // Object pixels 2 px from any other, other pixels 2 px from any object: apart from the silhouette.
            const char o = objects[std::size_t(y) * W + x];
            bool edge = false;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) edge |= objects[std::size_t(y + dy) * W + x + dx] != o;
            double diff = 0;
            for (int c = 0; c < 3; ++c) {
                const std::size_t i = 3 * (std::size_t(y) * W + x) + c;
                diff = std::max(
                    diff, double(std::abs(std::clamp(a.pixels[i], 0.0f, 1.0f) - std::clamp(b.pixels[i], 0.0f, 1.0f))));
            }
            double& worst = edge ? worstEdge : o ? worstInside : worstAway;
            worst = std::max(worst, diff);
            inside += o && !edge;
        }
    ASSERT_GT(inside, 1000);  // the cube is in view
    if (worstInside > 2.0 / 255 || worstAway > 2.0 / 255 || worstEdge > 8.0 / 255)
        save("depth_half", a), save("depth_full", b);
    EXPECT_LE(worstInside * 255, 2.0);
    EXPECT_LE(worstAway * 255, 2.0);
    EXPECT_LE(worstEdge * 255, 8.0);
    EXPECT_GE(db(a, b), 60);
}

namespace {

// Two images as a display shows them (8-bit sRGB): the PSNR (peak 255) and how many steps the
// first is darker than the second at its darkest pixel (a channel's sum over r, g, b).
struct Steps {
    double psnr = 0;
    int darker = 0;
};
Steps stepsOf(const Image& a, const Image& b) {
    Steps s;
    double se = 0;
    const std::size_t n = a.pixels.size() / std::size_t(a.channels);
    for (std::size_t p = 0; p < n; ++p) {
        int down = 0;
        for (int c = 0; c < 3; ++c) {
            const std::size_t i = p * std::size_t(a.channels) + std::size_t(c);
            const int d =
                int(std::lround(255 * linearToSrgb(a.pixels[i]))) - int(std::lround(255 * linearToSrgb(b.pixels[i])));
            se += double(d) * d;
            down += std::max(-d, 0);
        }
        s.darker = std::max(s.darker, down);
    }
    const double mse = se / double(3 * n);
    s.psnr = mse <= 0 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse);
    return s;
}

}  // namespace

// The cloud LOD's bound (docs/compositor.md, "One impostor per far cloud"): with reuse and the
// cloud LOD on, as the defaults draw, every frame close (8-bit sRGB, as the cruise bench
// measures) to the same frame with every tile fresh and the LOD off. The flight closes in on the
// middle of three clouds from 8 radii (all impostors, about 25 px: their parallax stays under
// the threshold as they grow) through the switch to its tiles to inside it, at 160x90, 11
// frames, 250 m a frame. Measured on llvmpipe: worst 58.3 dB, at most 25 steps darker (a pixel's
// sum over r, g, b; where tiles reused by themselves are magnified). Impostors kept while
// magnified on screen (issue 37's dark discs): 46.6 dB and 44 steps, the rims of the clouds
// smeared. The bound is 45 dB at 1280x720; here a cloud's rims are a larger share of
// the frame, so 52 dB and 36 steps: 6 dB and 11 steps from now, failing on the magnified
// impostors by 5 dB and 8 steps.
TEST_F(CloudLodGLTest, DefaultsStayWithinTheBoundOfFreshTilesWithoutTheLod) {
    Scene scene = threeClouds();
    scene.camera.width = 160, scene.camera.height = 90;
    EllipsoidSettings fresh = lod(false);
    fresh.reuse = false;
    Flight on(lod(), scene), off(fresh, scene);
    double worst = 1e9;
    int darkest = 0, impostors = 0, cheaper = 0;
    for (int k = 0; k <= 10; ++k) {
        Camera c = scene.camera;
        c.position += Vec3(0, 250.0 * k, 0);  // 2500 m from the middle cloud's centre to inside it
        const Image a = on.frame(scene, c), b = off.frame(scene, c);
        const Steps s = stepsOf(a, b);
        if (s.psnr < 52 || s.darker > 36) save("lod_bound_on", a), save("lod_bound_fresh", b);
        EXPECT_GE(s.psnr, 52) << "frame " << k;
        worst = std::min(worst, s.psnr), darkest = std::max(darkest, s.darker);
        impostors += on.last.impostors;
        cheaper += on.last.tilePixelsRendered < off.last.tilePixelsRendered ? 1 : 0;
    }
    EXPECT_LE(darkest, 36) << "worst " << worst << " dB";
    EXPECT_GT(impostors, 0);  // the far LOD was drawn
    EXPECT_GT(cheaper, 0);    // and tiles were kept or held smaller than fresh
}
