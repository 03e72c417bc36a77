// Tiles that last (EllipsoidSettings::reuse): a still camera renders nothing again, a moving
// one stays close to every tile fresh, a new sun is caught up within the budget, the wind
// carries reused tiles with their clouds.
#include "flight_test_util.hpp"

#include <cmath>
#include <cstdio>
#include <functional>

using namespace nephele;
using nephele::test::db;
using nephele::test::Flight;
using nephele::test::save;
using nephele::test::sharedScene;

namespace {

EllipsoidSettings reuseOn(CompositeOrder order = CompositeOrder::PerEllipsoid) {
    EllipsoidSettings s;
    s.reuse = true;
    s.order = order;
    return s;
}

// The mean of the first cloud's ellipsoid centres.
Vec3 cloudCentre(const Scene& scene) {
    Vec3 centre(0.0);
    for (const Ellipsoid& e : scene.clouds[0].ellipsoids)
        centre += e.center / double(scene.clouds[0].ellipsoids.size());
    return centre;
}

// cumulus27 from 600 m, 320 px: tiles of 8 to 128 px.
Scene nearCumulus() {
    Scene scene = sharedScene("cumulus27.json", 320);
    scene.camera.position = cloudCentre(scene) - scene.camera.direction * 900.0;
    return scene;
}

class TileReuseGLTest : public test::EglTest {};

// The second frame of a still camera draws no tile, and looks as the first: the reprojection
// of a tile to the view it was rendered from is its screen rectangle. Measured on llvmpipe:
// 140 dB (float rounding of the reprojected quad's coordinates); 60 dB leaves room for a
// driver that interpolates the perspective-correct coordinates with other rounding, and fails
// on a tile misplaced by a pixel.
TEST_F(TileReuseGLTest, AStillCameraRendersNothingAfterTheFirstFrame) {
    const Scene scene = nearCumulus();
    for (CompositeOrder order : {CompositeOrder::PerEllipsoid, CompositeOrder::Weighted}) {
        Flight f(reuseOn(order), scene);
        const Image first = f.frame(scene, scene.camera);
        EXPECT_EQ(f.last.tilesRendered, f.last.visible);
        ASSERT_GT(f.last.visible, 10);
        const Image second = f.frame(scene, scene.camera);
        EXPECT_EQ(f.last.tilesRendered, 0);
        EXPECT_EQ(f.last.tilesReused, f.last.visible);
        const double d = db(second, first);
        if (d < 60) save("reuse_still_second", second), save("reuse_still_first", first);
        EXPECT_GE(d, 60) << "order " << int(order);
    }
}

// A camera flying past the cloud: every frame within 40 dB of the same frame with every tile
// fresh (the target), while most tiles are reused. Measured on llvmpipe: the worst
// frame 57.2 dB, 152 of 393 tiles rendered (each about every second frame at 4 m a frame,
// 900 m away: the parallax of a 60 px tile reaches the 0.5 px threshold in two).
TEST_F(TileReuseGLTest, AMovingCameraStaysCloseToFreshTiles) {
    const Scene scene = nearCumulus();
    Flight on(reuseOn(), scene), off(EllipsoidSettings{}, scene);
    const Vec3 side = glm::normalize(glm::cross(scene.camera.direction, Vec3(0, 0, 1)));
    int rendered = 0, visible = 0;
    double worst = 1e9;
    for (int k = 0; k < 16; ++k) {
        Camera c = scene.camera;
        c.position += side * (4.0 * k) + Vec3(0, 0, 1.5 * k);  // 4 m sideways a frame (40 m/s at 10 fps)
        const Image a = on.frame(scene, c), b = off.frame(scene, c);
        const double d = db(a, b);
        if (d < worst && d < 40) save("reuse_moving_on", a), save("reuse_moving_fresh", b);
        worst = std::min(worst, d);
        if (k > 0) rendered += on.last.tilesRendered, visible += on.last.visible;
    }
    EXPECT_GE(worst, 40);
    EXPECT_LT(rendered, visible / 2) << "reuse rendered " << rendered << " of " << visible << " tiles";
}

// A camera circling the cloud at a constant distance, always looking at it: the parallax is all
// turn (the eye's direction from each ellipsoid changes; its distance does not), so a tile is
// kept only while the turn moves its image under the threshold. 1.5 degrees a frame, 16 frames.
TEST_F(TileReuseGLTest, ACameraCirclingTheCloudStaysCloseToFreshTiles) {
    Scene scene = nearCumulus();
    // The sun overhead: circling at one height, the eye sees each ellipsoid at the same angle to
    // the sun (the sun's phase towards the eye, a reason of its own to render a tile again, stays).
    scene.sun.direction = Vec3(0, 0, 1);
    // Spheres: their outline, seen from anywhere at one distance, is the same circle, so no tile
    // is rendered again because the cloud's outline left its quad; what changes is the noise on
    // each sphere, seen from a direction that turned.
    for (Ellipsoid& e : scene.clouds[0].ellipsoids) e.radii = Vec3((e.radii.x + e.radii.y + e.radii.z) / 3);
    Flight on(reuseOn(), scene), off(EllipsoidSettings{}, scene);
    const Vec3 centre = cloudCentre(scene);
    const Vec3 arm = scene.camera.position - centre;
    int rendered = 0, visible = 0;
    double worst = 1e9, sum = 0;
    for (int k = 0; k < 16; ++k) {
        const double a = glm::radians(1.5 * k);
        Camera c = scene.camera;
        c.position =
            centre + Vec3(arm.x * std::cos(a) - arm.y * std::sin(a), arm.x * std::sin(a) + arm.y * std::cos(a), arm.z);
        c.direction = glm::normalize(centre - c.position);
        const Image reused = on.frame(scene, c), fresh = off.frame(scene, c);
        if (k == 0) continue;  // (the first frame renders every tile: the same image)
        const double d = db(reused, fresh);
        if (d < worst && d < 45) save("reuse_circling_on", reused), save("reuse_circling_fresh", fresh);
        worst = std::min(worst, d), sum += d;
        rendered += on.last.tilesRendered, visible += on.last.visible;
    }
    std::printf("circling: worst frame %.1f dB against fresh tiles, mean %.1f dB; %d of %d tiles rendered\n", worst,
                sum / 15, rendered, visible);
    // Measured: worst 47.4 dB, mean 54.2 dB, 147 of 385 tiles rendered. Without the turn in
    // the parallax (tests/sabotage/33-reuse-parallax-drops-the-turn.sabotage): 42.2 and 48.5 dB,
    // 106 rendered.
    EXPECT_GE(worst, 45);
    EXPECT_GE(sum / 15, 51);
    EXPECT_LT(rendered, visible / 2) << "reuse rendered " << rendered << " of " << visible << " tiles";
}

// A new sun: every tile's light is stale. They are rendered again worst first within the
// budget (the first of a frame even past it), so that the new light arrives over a few frames
// and no frame renders much more than the budget; then the image is the fresh one.
TEST_F(TileReuseGLTest, ASunChangeRendersEveryTileAgainWithinTheBudget) {
    Scene scene = nearCumulus();
    EllipsoidSettings s = reuseOn();
    s.reuseBudget = 1.0;
    Flight f(s, scene);
    f.frame(scene, scene.camera);
    const int visible = f.last.visible;
    const std::int64_t all = f.last.tilePixels;
    const double budget = s.reuseBudget * scene.camera.width * scene.camera.height;
    ASSERT_GT(double(all), 2 * budget);  // so that the budget spreads the work
    scene.sun.direction = glm::normalize(Vec3(-0.6, 0.3, 0.5));
    int frames = 0, rendered = 0;
    Image last;
    for (; frames < 40; ++frames) {
        last = f.frame(scene, scene.camera);
        if (f.last.tilesRendered == 0) break;
        rendered += f.last.tilesRendered;
        EXPECT_LE(double(f.last.tilePixelsRendered), budget + f.last.maxTile * f.last.maxTile);
    }
    EXPECT_EQ(rendered, visible);
    // All tiles within ceil(all / budget) frames, and one more for the budget's rounding.
    EXPECT_LE(frames, int(std::ceil(double(all) / budget)) + 1) << all << " tile px, budget " << budget;
    EXPECT_GE(frames, 2);  // spread: the budget held
    Flight fresh(EllipsoidSettings{}, scene);
    const Image want = fresh.frame(scene, scene.camera);
    EXPECT_GE(db(last, want), 60);
}

// Tiles with no image (a cloud new in view) are rendered whatever the budget, and they spend
// it: in a frame where they alone fill it, the tiles a new sun made stale get half of it (and
// the worst one always), the rest wait for the next frames. So a frame never adds a whole
// budget's worth of stale tiles on top of the new ones, and the frames stay more even.
TEST_F(TileReuseGLTest, NewTilesSpendTheBudgetBeforeStaleOnes) {
    Scene scene = nearCumulus();
    Cloud second = scene.clouds[0];
    const Vec3 side = glm::normalize(glm::cross(scene.camera.direction, scene.camera.up));
    for (Ellipsoid& e : second.ellipsoids) e.center += side * 250.0 - scene.camera.direction * 200.0;
    Scene both = scene;
    both.clouds.push_back(second);
    both.sun.direction = glm::normalize(Vec3(-0.6, 0.3, 0.5));
    // The budget: a quarter of the new cloud's tile pixels (several stale tiles' worth).
    Flight probe(reuseOn(), scene);
    probe.frame(scene, scene.camera);
    const std::int64_t firstPixels = probe.last.tilePixels;
    probe.frame(both, both.camera);
    const double newPixels = double(probe.last.tilePixels - firstPixels);
    ASSERT_GT(newPixels, 0);
    EllipsoidSettings s = reuseOn();
    s.reuseBudget = 0.25 * newPixels / (scene.camera.width * scene.camera.height);
    Flight f(s, scene);
    f.frame(scene, scene.camera);
    f.frame(both, both.camera);
    ASSERT_GT(f.last.tilesMust, 5);
    ASSERT_GT(f.last.visible - f.last.tilesMust, 5);  // the first cloud's tiles, all stale
    // The new cloud's tiles are the frame's must ones, at the probe's sizes (the same view).
    const double stalePixels = double(f.last.tilePixelsRendered) - newPixels;
    const double budget = s.reuseBudget * scene.camera.width * scene.camera.height;
    std::printf("stale tile pixels %.0f of a budget of %.0f (%d new tiles, %d rendered)\n", stalePixels, budget,
                f.last.tilesMust, f.last.tilesRendered);
    EXPECT_GT(f.last.tilesRendered, f.last.tilesMust);  // the worst stale one at least
    EXPECT_LE(stalePixels, 0.5 * budget + f.last.maxTile * f.last.maxTile);
}

// A cloud that grows and thickens a little every frame, as a near-LOD cloud does through a
// weather ramp (0.4% larger and 2% denser a frame for 16 frames: a 2 s ramp of a 15% change at
// 30 fps is about this), its grid made on the worker as a host's are: a reshaped, thickened
// ellipsoid's image is stale by how far its surface moved (reuse::reshapeMetres) and by its
// extinction's change, not lost, so no frame renders more than the budget, where every tile
// of the cloud was rendered again each frame. When the cloud stops and its grid is made, the
// tiles catch up: the image is the fresh one. Then it fades (Cloud::weight, 8% a frame, as a
// near-LOD cloud at the near field's rim: the light stays, so nothing but the fade makes its
// tiles stale): still within the budget. Measured: 71 tiles rendered in the 16 frames of the
// growth (27 visible) and 39 in the 8 of the fade, none for want of an image; with an
// extinction change forcing tiles past the budget (sabotage 188), 89 of 120 in the fade.
TEST_F(TileReuseGLTest, AReshapedOrFadingCloudIsRenderedAgainWithinTheBudget) {
    Scene scene = nearCumulus();
    EllipsoidSettings s = reuseOn();
    s.reuseBudget = 1.0;
    s.light.background = true;
    Flight on(s, scene);
    on.clouds.waitForLights(scene);
    on.frame(scene, scene.camera);
    const std::int64_t all = on.last.tilePixels;
    const double budget = s.reuseBudget * scene.camera.width * scene.camera.height;
    ASSERT_GT(double(all), 2 * budget);  // every tile again would break the budget
    const std::vector<Ellipsoid> start = scene.clouds[0].ellipsoids;
    auto fly = [&](int frames, const std::function<void(int)>& change) {
        int must = 0, rendered = 0;
        for (int k = 1; k <= frames; ++k) {
            change(k);
            on.frame(scene, scene.camera);
            must += on.last.tilesMust, rendered += on.last.tilesRendered;
            EXPECT_LE(double(on.last.tilePixelsRendered), budget + on.last.maxTile * on.last.maxTile) << "frame " << k;
        }
        std::printf("%d tiles rendered in %d frames (%d visible), %d for want of an image\n", rendered, frames,
                    on.last.visible, must);
        return must;
    };
    EXPECT_EQ(fly(16,
                  [&](int k) {
                      for (std::size_t i = 0; i < start.size(); ++i) {
                          scene.clouds[0].ellipsoids[i].radii = start[i].radii * (1 + 0.004 * k);
                          scene.clouds[0].ellipsoids[i].density = start[i].density * (1 + 0.02 * k);
                      }
                  }),
              0);
    on.clouds.waitForLights(scene);
    int frames = 0;
    Image last;
    for (; frames < 40; ++frames) {
        last = on.frame(scene, scene.camera);
        if (on.last.tilesRendered == 0) break;
    }
    EXPECT_LE(frames, int(std::ceil(double(on.last.tilePixels) / budget)) + 1);
    Flight fresh(EllipsoidSettings{}, scene);
    const Image want = fresh.frame(scene, scene.camera);
    const double d = db(last, want);
    if (d < 60) save("reuse_grown_on", last), save("reuse_grown_fresh", want);
    EXPECT_GE(d, 60);
    EXPECT_EQ(fly(8, [&](int k) { scene.clouds[0].weight = 1 - 0.08 * k; }), 0);
}

// The wind moves a cloud and the eye flies with it: nothing changes in the tiles (medium.noise
// 0, so no noise drifts through them), every tile is reused, moved with its cloud: the frame
// is the first one. Tiles left where they were would sit 60 m off.
TEST_F(TileReuseGLTest, WindCarriesReusedTilesWithTheirClouds) {
    Scene scene = nearCumulus();
    scene.medium.noise = 0;
    Flight on(reuseOn(), scene);
    const Image first = on.frame(scene, scene.camera);
    const Vec3 wind(60, 20, 0);
    for (Ellipsoid& e : scene.clouds[0].ellipsoids) e.center += wind;
    Camera c = scene.camera;
    c.position += wind;
    const Image moved = on.frame(scene, c);
    EXPECT_EQ(on.last.tilesRendered, 0);
    EXPECT_GE(db(moved, first), 60);
}

// The detail drifts with its own wind through a still cloud (Medium::Detail::drift): a reused
// tile would keep the detail it was drawn with, frozen, then jump when drawn again. Its drift
// counts as the noise's does, so a drift of a few metres renders the tiles again (within the
// budget, as any stale tile) and the frames stay close to every tile fresh; a drift of a
// centimetre renders none.
TEST_F(TileReuseGLTest, TheDetailsDriftRendersTilesAgain) {
    Scene scene = nearCumulus();
    scene.medium.noise = 0;
    scene.medium.detail.erosion = 1.5;
    Flight on(reuseOn(), scene), fresh(EllipsoidSettings{}, scene);
    on.frame(scene, scene.camera);
    scene.medium.detail.drift = Vec3(0.01, 0, 0);
    on.frame(scene, scene.camera);
    EXPECT_EQ(on.last.tilesRendered, 0) << "a centimetre's drift rendered tiles again";
    double worst = 1e9;
    int rendered = 0;
    constexpr int kFrames = 8;
    for (int k = 1; k <= kFrames; ++k) {
        scene.medium.detail.drift = Vec3(1.5 * k, 0.5 * k, 0);  // a wind of 16 m/s at 10 frames a second
        const Image a = on.frame(scene, scene.camera), b = fresh.frame(scene, scene.camera);
        rendered += on.last.tilesRendered;
        worst = std::min(worst, db(a, b));
        if (k == kFrames && db(a, b) < 40) save("reuse_detail_drift", a), save("reuse_detail_drift_fresh", b);
    }
    std::printf("[ figure ] detail drifting: %d tiles rendered in %d frames, worst %.1f dB of fresh\n", rendered,
                kFrames, worst);
    EXPECT_GT(rendered, 0);
    // The target for tiles that last (AMovingCameraStaysCloseToFreshTiles). Measured 42.8
    // dB (57 tiles rendered again); with the drift counted once, not four times, 38.8 (28); not
    // counted at all 34.3 (none).
    EXPECT_GE(worst, 40);
}

// A driver may compile a program's machine code at its first draw: llvmpipe takes 0.4-0.5 s for
// a tile program on a cold shader cache, which a flight met in the frame of its first tile cut
// by the near plane and again at its first tile near the sun. Every tile program the settings
// may use is drawn in the first frame, so a later frame that first needs one draws none for the
// first time. Frame 0 from 900 m with the sun behind the eye (no tile cut, none near the sun);
// frame 1 from the cloud's middle looking at the sun (the tiles around the eye cut, those ahead
// lit per pixel). Without the first frame's draws: frame 0 draws 1 program first, frame 1 2
// (mesh); polygon tiles 1 and 1.
TEST_F(TileReuseGLTest, NoLaterFrameDrawsATileProgramForTheFirstTime) {
    Scene scene = nearCumulus();
    scene.sun.direction = -scene.camera.direction;
    Camera inside = scene.camera;
    inside.position = cloudCentre(scene);
    inside.direction = scene.sun.direction;
    for (TileGeometry geometry : {TileGeometry::Mesh, TileGeometry::Polygon}) {
        EllipsoidSettings s = reuseOn();
        s.geometry = geometry;
        Flight f(s, scene);
        f.frame(scene, scene.camera);
        const int programs = geometry == TileGeometry::Mesh ? 3 : 2;  // plain, cut, lit per pixel; plain, cut
        EXPECT_EQ(f.last.programsFirstDrawn, programs) << "geometry " << int(geometry);
        f.frame(scene, inside);
        EXPECT_GT(f.last.tilesRendered, 0);
        EXPECT_EQ(f.last.programsFirstDrawn, 0) << "geometry " << int(geometry);
    }
}

}  // namespace
