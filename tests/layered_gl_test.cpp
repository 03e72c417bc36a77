// The layered sky on a headless context: draw counts, coverage, the eye below / in / above
// the layer, wind, lightning, grazing-view gaps, and the host's GL state.
#include "gl_test_util.hpp"
#include "layered_test_util.hpp"
#include "temp_dir.hpp"
#include "test_build.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/layered.hpp"
#include "nephele/layer_volume.hpp"
#include "nephele/opaque.hpp"
#include "nephele/pathtrace.hpp"
#include "parallel.hpp"
#include "nephele/resources.hpp"

#include <cmath>
#include <cstdio>

using namespace nephele;
using namespace nephele::gl;

namespace {

constexpr double kBase = 2000, kThickness = 600, kExtent = 20000;

// Small textures keep the precomputation in milliseconds; the geometry is the real one.
LayeredSettings testSettings() { return test::smallLayered(); }

// One layer, the eye at height z looking along +y tilted up by pitchDeg, 160x90.
Scene layerScene(double eyeZ, double pitchDeg, double coverage = 0.6, double density = 1.0) {
    Scene s;
    s.camera.position = Vec3(0, 0, eyeZ);
    const double p = glm::radians(pitchDeg);
    s.camera.direction = Vec3(0, std::cos(p), std::sin(p));
    s.camera.up = std::abs(pitchDeg) > 89 ? Vec3(0, 1, 0) : Vec3(0, 0, 1);
    s.camera.width = 160, s.camera.height = 90;
    s.camera.farClip = 100000;
    Layer l;
    l.base = kBase, l.thickness = kThickness, l.extent = kExtent;
    l.coverage = coverage, l.density = density;
    s.layers.push_back(l);
    return s;
}

struct Result {
    Image rgba;
    LayeredStats stats;
    LightingVolume light;
    ModulationTexture modulation;
};

Result render(const Scene& scene, const LayeredSettings& given, double t = 0) {
    // One lighting cache for the renders (unless the test names its own): the layer's photons
    // are traced once per medium and thickness, not once per render (most of these tests' CPU);
    // under ctest once per run.
    static const test::TempDir cache("nephele_layered_gl_");
    LayeredSettings settings = given;
    if (settings.cacheDir.empty()) settings.cacheDir = test::runCacheDirOr(cache.dir().string());
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    LayeredRenderer sky(settings);
    Result r;
    r.stats = sky.render(scene, view, target.framebuffer(), t);
    r.rgba = target.readColor();
    r.light = *sky.lighting(0);
    r.modulation = *sky.modulation(0);
    return r;
}

// Mean opacity over the pixels whose ray elevation is within [lo, hi] degrees.
double meanAlphaAtElevations(const Scene& scene, const Image& rgba, double lo, double hi) {
    const View view = makeView(scene.camera);
    double sum = 0;
    int n = 0;
    for (int y = 0; y < rgba.height; ++y)
        for (int x = 0; x < rgba.width; ++x) {
            const double e = glm::degrees(std::asin(view.rayDirection(x + 0.5, y + 0.5).z));
            if (e >= lo && e <= hi) sum += rgba.at(x, y, 3), ++n;
        }
    EXPECT_GT(n, 0);
    return n ? sum / n : 0;
}

Image opaqueOnly(const Scene& scene) {
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    return target.readColor();
}

bool allFinite(const Image& im) {
    for (float v : im.pixels)
        if (!std::isfinite(v)) return false;
    return true;
}

// Does the ray of pixel (x, y) cross the slab [base, base + thickness] somewhere within
// horizontal distance [from, to] of the eye? (The layer's angular band.)
bool inBand(const View& view, int x, int y, double from, double to) {
    const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
    const double h = std::sqrt(d.x * d.x + d.y * d.y);
    double t0 = 0, t1 = 1e12;
    if (std::abs(d.z) < 1e-12) {
        if (view.eye.z < kBase || view.eye.z > kBase + kThickness) return false;
    } else {
        double a = (kBase - view.eye.z) / d.z, b = (kBase + kThickness - view.eye.z) / d.z;
        if (a > b) std::swap(a, b);
        t0 = std::max(a, 0.0), t1 = b;
    }
    if (h < 1e-12) return t1 > t0 && from <= 0;
    t0 = std::max(t0, from / h), t1 = std::min(t1, to / h);
    return t1 > t0;
}

// The opacity of the volume the layers stand for along each pixel's ray, 1 - exp(-tau),
// tau = extinction * the integral of layerDensity (the shader's eq. 16 on the CPU) up to
// the start of the rim fade, by the midpoint rule (20 m steps, at most 2000: the 3D texture's
// texels are 250 m wide at the test's 32^2, the slab's 8 slices 75 m high).
// The volume's opacity per pixel: 1 - exp(-tau) along rays through a k x k grid of points of
// the pixel, averaged (k = 1: the pixel's centre).
Image volumeOpacity(const Scene& scene, const Result& r, const LayeredSettings& s, int k = 1) {
    const View view = makeView(scene.camera);
    const Layer& layer = scene.layers[0];
    Image out(scene.camera.width, scene.camera.height, 1);
    const double reach = layer.extent * (1 - s.extentFade);
    parallelFor(out.height, [&](int y) {
        for (int x = 0; x < out.width; ++x) {
            double sum = 0;
            for (int j = 0; j < k; ++j)
                for (int i = 0; i < k; ++i) {
                    const Vec3 d = view.rayDirection(x + (i + 0.5) / k, y + (j + 0.5) / k);
                    const double tau =
                        scene.medium.extinction * layerDensityIntegral(layer, r.modulation, s.modulation, r.light,
                                                                       view.eye, d, reach, 0, 20, 2000);
                    sum += 1 - std::exp(-tau);
                }
            out.at(x, y, 0) = float(sum / (k * k));
        }
    });
    return out;
}

struct Gaps {
    int band = 0, holes = 0, gaps = 0;
    double fraction() const { return band ? double(gaps) / band : 0; }
    double holeFraction() const { return band ? double(holes) / band : 0; }
};

// Pixels of the layer's band (before the rim fade): holes = the layers' opacity is below
// 0.5; gaps = holes where the volume itself is opaque (>= 0.9), i.e. holes that more layers
// (or billboards) should have filled, not holes of the cloud field.
Gaps measureGaps(const Scene& scene, const Result& r, const Image& volume, const LayeredSettings& s) {
    const View view = makeView(scene.camera);
    Gaps g;
    for (int y = 0; y < r.rgba.height; ++y)
        for (int x = 0; x < r.rgba.width; ++x)
            if (inBand(view, x, y, 0, kExtent * (1 - s.extentFade))) {
                ++g.band;
                const bool hole = r.rgba.at(x, y, 3) < 0.5f;
                g.holes += hole;
                g.gaps += hole && volume.at(x, y, 0) >= 0.9f;
            }
    return g;
}

class LayeredGLTest : public test::EglTest {};

}  // namespace

TEST_F(LayeredGLTest, DrawCallsDoNotGrowWithTheLayerCount) {
    const Scene scene = layerScene(500, 10);
    int draws = -1;
    for (int n : {2, 8, 32, 128}) {
        LayeredSettings s = testSettings();
        s.layers = n;
        const Result r = render(scene, s);
        if (draws < 0) draws = r.stats.drawCalls;
        EXPECT_EQ(r.stats.drawCalls, draws) << "N = " << n;
        EXPECT_GE(r.stats.instances, n);
    }
    EXPECT_EQ(draws, 2);  // one instanced draw of annuli, one of billboards
    Scene two = scene;
    two.layers.push_back(two.layers[0]);
    two.layers[1].base = 5000;
    EXPECT_EQ(render(two, testSettings()).stats.drawCalls, 4);  // per scene layer, not per annulus
}

// Layers of the same thickness share one lighting volume and layers of the same seed one
// modulation texture, on the CPU and in GL (each layer cost about 30 MB: 100 layers of a 9 KB
// file took 3.1 GB); the distinct ones are bounded by resourceMegabytes before anything is made.
TEST_F(LayeredGLTest, LayersOfTheSameParametersShareTheirTexturesWithinABudget) {
    Scene scene = layerScene(500, 10);
    for (int i = 1; i < 100; ++i) {  // 100 layers, one thickness and one seed: stacked every 10 m
        scene.layers.push_back(scene.layers[0]);
        scene.layers.back().base = kBase + 10 * i;
    }
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    {
        LayeredRenderer sky(testSettings());
        EXPECT_EQ(sky.render(scene, view, target.framebuffer(), 0).uploads, 2);  // one volume, one modulation
        EXPECT_EQ(sky.lighting(0), sky.lighting(99));
        EXPECT_EQ(sky.modulation(0), sky.modulation(99));
        scene.layers[7].thickness = 900, scene.layers[8].seed = 42;
        EXPECT_EQ(sky.render(scene, view, target.framebuffer(), 0).uploads, 2);  // the new volume and modulation only
        EXPECT_NE(sky.lighting(7), sky.lighting(0));
        EXPECT_EQ(sky.lighting(8), sky.lighting(0));
    }
    // 2 distinct thicknesses at 32x32x8 (about 18 KB each) and 2 seeds at 256^2 (1.9 MB each
    // with the GL copy's four channels and mipmaps): over a 1 MB budget; the message says what
    // and how much.
    LayeredSettings small = testSettings();
    small.modulation.size = 256;
    small.resourceMegabytes = 1;
    LayeredRenderer bounded(small);
    try {
        bounded.render(scene, view, target.framebuffer(), 0);
        ADD_FAILURE() << "over the budget, not refused";
    } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("2 modulation textures (one per seed)"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("resourceMegabytes"), std::string::npos) << e.what();
    }
    EXPECT_EQ(bounded.lighting(0), nullptr);  // refused before anything was made
}

// Issue #10: far away a fetch averages A and the threshold r over the pixel's footprint, and
// eq. (16)'s max() of the means loses the thin peaks that the mean of the max() keeps. The
// layer far away stays as opaque as its volume: the mean over each pixel of 1 - exp(-tau)
// along 4 x 4 rays through it, over the pixels whose ray meets the layer 4-18 km away.
TEST_F(LayeredGLTest, ADistantLayerIsAsOpaqueAsItsVolume) {
    LayeredSettings s = testSettings();
    s.modulation.size = 512;  // the default's detail: far away the fetches are mip levels up
    s.extentFade = 0;
    struct ViewCase {
        const char* name;
        double z, pitch;
    };
    for (const ViewCase& v :
         {ViewCase{"below, looking up 6 degrees", 500, 6}, ViewCase{"above, looking down 6 degrees", 4100, -6}}) {
        Scene scene = layerScene(v.z, v.pitch);
        scene.camera.width = 96, scene.camera.height = 54;
        const Result r = render(scene, s);
        const Image volume = volumeOpacity(scene, r, s, 4);
        const View view = makeView(scene.camera);
        double layered = 0, exact = 0;
        int n = 0;
        for (int y = 0; y < volume.height; ++y)
            for (int x = 0; x < volume.width; ++x)
                if (inBand(view, x, y, 4000, 18000)) layered += r.rgba.at(x, y, 3), exact += volume.at(x, y, 0), ++n;
        ASSERT_GT(n, 200) << v.name;
        std::printf("[ figure ] %s: mean opacity 4-18 km away, layered %.3f, volume %.3f (%d pixels)\n", v.name,
                    layered / n, exact / n, n);
        // 0.03: measured +0.007 and +0.014 (the N slabs' clear parts are drawn independently of
        // each other, where the threshold's clear columns go through all of them); eq. (16) on
        // the fetched means alone measured -0.073 and -0.056.
        EXPECT_NEAR(layered / n, exact / n, 0.03) << v.name;
    }
}

TEST_F(LayeredGLTest, CoverageZeroLeavesTheFrameUnchanged) {
    for (double z : {500.0, 2300.0, 4000.0}) {
        const Scene scene = layerScene(z, z > 3000 ? -10 : 10, 0.0);
        const Result r = render(scene, testSettings());
        EXPECT_EQ(r.rgba.pixels, opaqueOnly(scene).pixels) << "eye at " << z;  // alpha 0 everywhere, colour untouched
    }
}

TEST_F(LayeredGLTest, EyeBelowInAndAboveTheLayer) {
    const LayeredSettings s = testSettings();
    // Below, looking 10 degrees up: the horizon is 10 degrees (about 15 rows) below the
    // centre; the overcast band lies above it, nothing below it.
    {
        const Scene scene = layerScene(500, 10, 1.0, 1.0);
        const Result r = render(scene, s);
        ASSERT_TRUE(allFinite(r.rgba));
        // An opaque band near the horizon (between the layer's far rim at 4.3 degrees and
        // 15 degrees); overhead, eq. (15) at C = 1 still leaves holes where r > A.
        EXPECT_GT(meanAlphaAtElevations(scene, r.rgba, 5, 15), 0.97);
        EXPECT_GT(meanAlphaAtElevations(scene, r.rgba, 25, 40), 0.7);
        EXPECT_EQ(meanAlphaAtElevations(scene, r.rgba, -20, 0), 0.0);  // the ground
        // Lit from above, seen from below: darker than the white a sunlit top would be, but
        // not black (ambient and the transmitted light).
        const float red = r.rgba.at(80, 10, 0);
        EXPECT_GT(red, 0.05f);
        EXPECT_LT(red, 0.9f);
    }
    // Above, looking 10 degrees down: cloud below the horizon, clear sky above.
    {
        const Scene scene = layerScene(4500, -10, 1.0, 1.0);
        const Result r = render(scene, s);
        ASSERT_TRUE(allFinite(r.rgba));
        EXPECT_EQ(meanAlphaAtElevations(scene, r.rgba, 0, 20), 0.0);
        // Looking down at 8-15 degrees crosses less of the slab than looking up at 5-15 from
        // 500 m: the few holes of eq. (15) at C = 1 show (measured 0.958).
        EXPECT_GT(meanAlphaAtElevations(scene, r.rgba, -15, -8), 0.93);
        EXPECT_GT(meanAlphaAtElevations(scene, r.rgba, -40, -25), 0.7);
        // Sunlit tops seen from above are brighter than the bottoms seen from below.
        const Result below = render(layerScene(500, 10, 1.0, 1.0), s);
        EXPECT_GT(r.rgba.at(80, 80, 0), below.rgba.at(80, 10, 0));
    }
    // Inside, looking level: cloud all around, above and below the horizon.
    {
        const Scene scene = layerScene(2300, 0, 1.0, 1.0);
        const Result r = render(scene, s);
        ASSERT_TRUE(allFinite(r.rgba));
        EXPECT_GT(meanAlphaAtElevations(scene, r.rgba, 0.5, 15), 0.97);
        EXPECT_GT(meanAlphaAtElevations(scene, r.rgba, -15, -0.5), 0.97);
    }
}

TEST_F(LayeredGLTest, WindMovesThePatternByTimeTimesWind) {
    LayeredSettings s = testSettings();
    Scene scene = layerScene(500, 30);
    scene.layers[0].wind = Vec2(40, -15);
    const double t = 30;
    const Image later = render(scene, s, t).rgba;
    const Image now = render(scene, s, 0).rgba;
    // At time t the texture coordinates are those of time 0 seen from an eye moved by
    // -t * wind (the geometry stays centred on the eye).
    Scene moved = scene;
    moved.camera.position -= Vec3(scene.layers[0].wind * t, 0.0);
    const Image shifted = render(moved, s, 0).rgba;
    const ImageDifference same = compareImages(later, shifted, 2e-3);
    // float texture coordinates of the two differ in their last bits: a few pixels may differ slightly
    EXPECT_LT(same.fractionOver, 0.01);
    EXPECT_LT(same.meanAbs, 1e-3);
    const ImageDifference changed = compareImages(later, now, 2e-3);
    EXPECT_GT(changed.fractionOver, 0.2);  // the pattern did move
}

TEST_F(LayeredGLTest, LightningBrightensOnlyWhileActive) {
    const LayeredSettings s = testSettings();
    Scene scene = layerScene(500, 20, 1.0, 1.0);
    const Image dark = render(scene, s, 5).rgba;
    Lightning l;
    l.position = Vec3(0, 3000, 2300);
    l.intensity = 3e7;  // I / d^2 at 3 km: about 3, brighter than the sun's irradiance
    l.start = 5, l.duration = 0.2;
    scene.lightning.push_back(l);
    const Image before = render(scene, s, 4.9).rgba, during = render(scene, s, 5.1).rgba,
                after = render(scene, s, 5.2).rgba;
    EXPECT_EQ(before.pixels, dark.pixels);
    EXPECT_EQ(after.pixels, dark.pixels);
    double gain = 0;
    for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 160; ++x) gain += during.at(x, y, 0) - dark.at(x, y, 0);
    EXPECT_GT(gain / (40 * 160), 0.1);
    for (std::size_t i = 0; i < dark.pixels.size(); i += 4) EXPECT_GE(during.pixels[i], dark.pixels[i] - 1e-6f);
}

TEST_F(LayeredGLTest, LeavesHostStateUnchanged) {
    const Scene scene = layerScene(2300, 5);
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    LayeredRenderer sky(testSettings());
    const test::HostileGlState hostile;
    // Two frames: the first also uploads the textures.
    test::expectStateUnchanged([&](int frame) { sky.render(scene, view, target.framebuffer(), frame); }, 2);
}

TEST_F(LayeredGLTest, ObjectsInFrontHideTheLayer) {
    Scene scene = layerScene(500, 20, 1.0, 1.0);
    Object box;
    box.type = Object::Type::Box;
    box.center = Vec3(0, 300, 500 + 300 * std::tan(glm::radians(20.0)));
    box.size = Vec3(60, 10, 60);
    scene.objects.push_back(box);
    const Result r = render(scene, testSettings());
    EXPECT_EQ(r.rgba.at(80, 45, 3), 0.0f);  // the box, not cloud
    EXPECT_GT(r.rgba.at(80, 5, 3), 0.5f);   // cloud above it
}

// The paper: too few layers show gaps at low view angles. Gap fraction = pixels of the
// layer's angular band (rays that cross the slab before the rim fade) with opacity < 0.5,
// at coverage 1 and density 1, against N and the view's elevation, for the eye below, in and
// above the layer. Printed as a table; the default N must keep every view below 2%.
TEST_F(LayeredGLTest, GrazingViewsHaveFewGapsAtTheDefaultLayerCount) {
    struct ViewCase {
        double z, pitch;
    };
    const ViewCase views[] = {{0, 2},       {0, 10},   {0, 30},    {1500, 0},  {2300, 0},
                              {2300, 89.5}, {3200, 0}, {5000, -2}, {5000, -30}};
    const int defaultN = LayeredSettings{}.layers;
    // The other counts only print the table beside the default's; under the sanitizers the
    // default alone (the same code checked, a quarter of the renders).
    const std::vector<int> counts = test::kSanitized ? std::vector<int>{defaultN} : std::vector<int>{2, 4, 8, 16};
    std::printf("gaps (%% of the band) at coverage 1, gap/hole: rows = eye z (m) / pitch (deg), columns = N\n%-14s",
                "view");
    for (int n : counts) std::printf("%14d", n);
    std::printf("\n");
    double worstDefault = 0;
    for (const ViewCase& v : views) {
        std::printf("%5.0f / %5.1f  ", v.z, v.pitch);
        const Scene scene = layerScene(v.z, v.pitch, 1.0, 1.0);
        Image volume;
        for (int n : counts) {
            LayeredSettings s = testSettings();
            s.layers = n;
            const Result r = render(scene, s);
            ASSERT_TRUE(allFinite(r.rgba));
            if (volume.empty()) volume = volumeOpacity(scene, r, s);
            const Gaps g = measureGaps(scene, r, volume, s);
            std::printf("%7.2f/%6.2f", 100 * g.fraction(), 100 * g.holeFraction());
            if (n == defaultN) worstDefault = std::max(worstDefault, g.fraction());
        }
        std::printf("\n");
    }
    // The bound: 2% of the band's pixels (the rest are covered at least half).
    EXPECT_LT(worstDefault, 0.02) << "N = " << defaultN;
}

// The billboard disc's rim (LOD0 to LOD1): looking along a deck's base from just under it, a
// ray that climbed into the bottom slab inside the disc and left the disc before the next
// annulus once met no matter in between and saw that annulus, deeper and brighter in the
// layer: a bright line across the view at the rim (auto's disc reaches 4.5 km; seen
// 2026-12-03). Here the rays that reach the base from 0.85 to 1.3 disc radii away must look
// the same whether the disc ends among them or far short of them (annuli alone).
TEST_F(LayeredGLTest, TheBillboardDiscsRimLeavesNoLine) {
    const double below = 100;  // m, the eye under the base
    Scene scene = layerScene(kBase - below, 0, 0.9, 0.8);
    scene.camera.fovYDeg = 30;
    scene.camera.width = 480, scene.camera.height = 270;  // the line is a row or two high: at 240 px it blurs away
    scene.layers[0].extent = 40000;
    const double rim = 4500;
    auto rowLuminance = [&](double lod0Radius) {
        LayeredSettings s;  // the default textures (with the tests' small ones the line measured 1.04, not 1.18)
        s.lod0Radius = lod0Radius;
        const Result r = render(scene, s);
        const View view = makeView(scene.camera);
        double sum = 0;
        int n = 0;
        for (int y = 0; y < r.rgba.height; ++y)
            for (int x = 0; x < r.rgba.width; ++x) {
                const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
                if (d.z <= 0) continue;
                const double reach = below / d.z * std::hypot(d.x, d.y);  // where the ray meets the base
                if (reach < 0.85 * rim || reach > 1.3 * rim) continue;
                sum += 0.2126 * r.rgba.at(x, y, 0) + 0.7152 * r.rgba.at(x, y, 1) + 0.0722 * r.rgba.at(x, y, 2), ++n;
            }
        EXPECT_GT(n, 500);
        return n ? sum / n : 0.0;
    };
    const double disc = rowLuminance(rim), annuli = rowLuminance(1000);
    std::printf(
        "[ figure ] rays reaching the base 0.85-1.3 disc radii away: luminance %.4f with the disc's rim among them, "
        "%.4f with annuli alone (ratio %.3f)\n",
        disc, annuli, disc / annuli);
    ASSERT_GT(annuli, 0.0);
    // 5%: measured 1.011 (the disc's billboards stand for the rays' first stretch in the slab,
    // the annuli's fetches for the rest); with the rim as a hard switch 1.179.
    EXPECT_NEAR(disc / annuli, 1.0, 0.05);
}

// Issue #10: the layered sky's sun light under a deck against the path tracer's, the layer as a
// volume of the same density (reference/, PathTraceSettings::layers). Looking up 20 degrees
// from 100 m under a deck of coverage 0.9, most of what the eye sees is the sun's light
// scattered many times, leaving the base in a broad half-space. The light tables held it as one
// Henyey-Greenstein lobe about its net flux, too narrow for it: 0.71 of the path tracer's sun
// light (the bench's deck view, 192x108), 0.60 at 7 degrees up. The tables now hold the
// few-times and the many-times scattered light apart, as the clouds' grids do.
TEST_F(LayeredGLTest, UnderADeckTheSunsLightMatchesThePathTracer) {
    Scene scene = layerScene(kBase - 100, 20, 0.9, 0.8);
    scene.camera.width = 64, scene.camera.height = 36;
    scene.camera.fovYDeg = 30;
    scene.layers[0].extent = 40000;
    scene.sky = {Vec3(0.0), Vec3(0.0), Vec3(0.0)};  // the sun's light alone
    scene.medium.noise = 0;                         // no explicit clouds: the noise volume would go unused
    const LayeredSettings settings;                 // the default textures and photons, as the renderer ships
    const Result layered = render(scene, settings);
    PathTraceSettings ps{.spp = 32};
    ps.layers = std::make_shared<LayerVolumes>(scene, settings, 0.0);
    const Image reference = renderPathTraced(scene, makeView(scene.camera), ps, nullptr);
    double mine = 0, theirs = 0;
    int n = 0;
    for (int y = 0; y < reference.height; ++y)
        for (int x = 0; x < reference.width; ++x) {
            if (reference.at(x, y, 3) < 0.5f) continue;
            auto luminance = [&](const Image& im) {
                return 0.2126 * im.at(x, y, 0) + 0.7152 * im.at(x, y, 1) + 0.0722 * im.at(x, y, 2);
            };
            mine += luminance(layered.rgba), theirs += luminance(reference), ++n;
        }
    std::printf("[ figure ] under a deck, the sun's light: layered / path tracer %.3f over %d pixels\n", mine / theirs,
                n);
    ASSERT_GT(n, 1000);
    // 15%: the light tables' own approximation (the mean light of the layer's points with the
    // same column depths), their photons' noise and 32 spp over 2300 pixels (under 1% noise).
    // Measured 0.921 in the GCC -O2 build and 0.865 in the clang -O1 sanitizer build: the
    // volume's other float rounding sends the photons other ways, and this view's tables
    // differ by 6% between the two. The same tables read as one lobe (the two parts summed, as
    // before) 0.713.
    EXPECT_NEAR(mine / theirs, 1.0, 0.15);
}
