// The volumetric ray-marcher (Jiménez de Parga & Gómez Palomo 2018) on a headless context:
// its opacity against the closed form of the density field, convergence with the step,
// the camera inside a cloud, objects inside clouds, its light model against a CPU integral,
// the noisy field against its CPU twin, the light cache, the host's GL state, determinism.
#include "gl_test_util.hpp"

#include "nephele/camera.hpp"
#include "nephele/gardner.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"
#include "nephele/projection.hpp"
#include "nephele/raymarch.hpp"
#include "nephele/gardner_model.hpp"
#include "light_cache.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <vector>

using namespace nephele;
using namespace nephele::gl;
using nephele::test::sharedScene;

namespace {

struct Frame {
    Image rgba;
    RaymarchStats stats;
};

// Sky and objects first, then the clouds over them, as the CLI and a host do.
Frame render(RaymarchRenderer& clouds, const Scene& scene, bool opaqueDepth = true) {
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    Frame f;
    f.stats = clouds.render(scene, view, target.framebuffer(), opaqueDepth && !scene.objects.empty());
    f.rgba = target.readColor();
    return f;
}

// The march's own accuracy is tested with a ray per pixel; the reduced resolution (the default,
// RaymarchSettings::downsample 2) has tests of its own against it.
RaymarchSettings perPixel() {
    RaymarchSettings s;
    s.downsample = 1;
    return s;
}

Frame render(const Scene& scene, const RaymarchSettings& settings = perPixel()) {
    RaymarchRenderer clouds(settings);
    return render(clouds, scene);
}

Image alphaOf(const Image& rgba) { return channels(rgba, 3, 1); }

double meanAbs(const Image& a, const Image& b) { return compareImages(a, b, 0.01).meanAbs; }
double maxAbs(const Image& a, const Image& b) { return compareImages(a, b, 0.01).maxAbs; }

double mean(const Image& a) {
    double sum = 0;
    for (float v : a.pixels) sum += v;
    return sum / double(a.pixels.size());
}

using test::clamped;
using test::save;

// box_in_thin_cloud.json (noise 0) marched with `settings`: its opacity, and that opacity's mean
// error on the box pixels inside the cloud (where the object cuts the ray: there the closed form
// clipped at the object and the whole chord's differ) against each of the two.
struct BoxInCloud {
    Frame frame;
    Image alpha, exact;
    double errObject = 0, errWhole = 0;
    int n = 0;
};
BoxInCloud boxInCloud(const RaymarchSettings& settings) {
    Scene scene = sharedScene("box_in_thin_cloud.json");
    scene.medium.noise = 0;
    const View view = makeView(scene.camera);
    BoxInCloud b;
    b.exact = exactDensityOpacity(scene, view);  // clipped at the first object
    Scene cloudsOnly = scene;
    cloudsOnly.objects.clear();
    const Image wholeChord = exactDensityOpacity(cloudsOnly, view);
    b.frame = render(scene, settings);
    b.alpha = alphaOf(b.frame.rgba);
    for (std::size_t i = 0; i < b.exact.pixels.size(); ++i)
        if (wholeChord.pixels[i] - b.exact.pixels[i] > 0.02) {
            b.errObject += std::fabs(b.alpha.pixels[i] - b.exact.pixels[i]);
            b.errWhole += std::fabs(b.alpha.pixels[i] - wholeChord.pixels[i]);
            ++b.n;
        }
    b.errObject /= std::max(b.n, 1);
    b.errWhole /= std::max(b.n, 1);
    return b;
}

class RaymarchGLTest : public test::EglTest {};

// With medium.noise = 0 the marcher integrates exactly the format's density field, so its
// opacity must follow 1 - exp(-tau) of the closed form, and get closer as the step shrinks
// (midpoint quadrature: the error falls with the step).
TEST_F(RaymarchGLTest, OpacityFollowsTheDensityFieldAndConvergesWithTheStep) {
    for (const char* name : {"single.json", "cumulus27.json"}) {
        Scene scene = sharedScene(name);
        scene.medium.noise = 0;
        const Image exact = exactDensityOpacity(scene, makeView(scene.camera));
        double mae[3], worst[3];
        const double steps[3] = {50, 25, 10};
        for (int i = 0; i < 3; ++i) {
            RaymarchSettings s = perPixel();
            s.step = steps[i];
            const Image alpha = alphaOf(render(scene, s).rgba);
            mae[i] = meanAbs(alpha, exact);
            worst[i] = maxAbs(alpha, exact);
            if (i == 1 && (mae[i] > 5e-4 || worst[i] > 0.01)) {
                save(std::string("raymarch_alpha_") + name, alpha);
                save(std::string("raymarch_exact_alpha_") + name, exact);
            }
        }
        std::printf(
            "[ figure ] %-14s raymarch alpha vs density field: MAE %.2e / max %.2e (step 50), %.2e / %.2e (25), "
            "%.2e / %.2e (10)\n",
            name, mae[0], worst[0], mae[1], worst[1], mae[2], worst[2]);
        // The default step (25 m, growing to ~37 m at these 2 km by the LOD) against chords of
        // 200-600 m: the midpoint rule on the smooth (1 - q)^2 profile, float rounding and the
        // 1e-4 transmittance cut. Measured on llvmpipe: MAE 1.5e-5 (single) and 6.9e-5
        // (cumulus27), max 4.4e-4 and 2.9e-3; at step 50 MAE 1.15e-4 and 4.96e-4. Each step's
        // extinction taken at its start, the left-point rule
        // (tests/sabotage/39-raymarch-extinction-at-step-start.sabotage): MAE 3.5e-5 and 1.74e-4,
        // max 1.06e-3 and 1.05e-2; at step 50 2.85e-4 and 1.33e-3. The bounds sit about 1.5x
        // over what is measured, per scene; marching overlaps twice (cumulus27: MAE 4.2e-4, max
        // 0.22) or losing one ellipsoid (MAE 8e-3) are far past them.
        const bool single = std::string(name) == "single.json";
        EXPECT_LT(mae[1], single ? 2.2e-5 : 1.0e-4) << name;
        EXPECT_LT(worst[1], single ? 6.5e-4 : 4.3e-3) << name;
        EXPECT_LT(mae[0], single ? 1.7e-4 : 7.4e-4) << name;
        // Convergence: from 50 m to 10 m the error must fall clearly. The midpoint rule's falls
        // as h^2 (25x); measured 55x (cumulus27) and 115x (single). Ask for 4x.
        EXPECT_LT(mae[2], 0.25 * mae[0]) << name;
    }
}

// Objects inside clouds: with the frame's depth the march ends at the object, so the box half
// way into the thin cloud is covered only by the matter in front of it.
TEST_F(RaymarchGLTest, ObjectInsideACloudIsHiddenOnlyByTheMatterInFront) {
    const BoxInCloud box = boxInCloud(perPixel());
    ASSERT_GT(box.n, 100) << "the probe scene no longer puts the box inside the cloud";
    const Image& alpha = box.alpha;
    const Image& exact = box.exact;
    const double errObject = box.errObject, errWhole = box.errWhole;
    const int n = box.n;
    const double mae = meanAbs(alpha, exact);
    std::printf(
        "[ figure ] box in thin cloud: alpha MAE %.5f over the image; on the %d box pixels inside the cloud "
        "%.5f against the matter in front, %.5f against the whole chord\n",
        mae, n, errObject, errWhole);
    // The 24-bit depth (the object's distance to ~1 mm here) and the quadrature as above:
    // measured MAE 8e-5 over the image and 4.3e-4 on the box pixels. Covering the box with the
    // whole chord costs 0.038 there; 0.005 sits between with room on both sides.
    EXPECT_LT(mae, 0.002);
    EXPECT_LT(errObject, 0.005);
    EXPECT_GT(errWhole, 4 * errObject);

    // The same for the helicopter inside the cumulus of flythrough.json, seen from inside the cloud.
    Scene fly = sharedScene("flythrough.json");
    fly.medium.noise = 0;
    fly.camera = cameraAt(fly, 5.0);
    fly.camera.width = 160;
    fly.camera.height = 120;
    const double flyMae = meanAbs(alphaOf(render(fly).rgba), exactDensityOpacity(fly, makeView(fly.camera)));
    std::printf("[ figure ] flythrough t=5 (inside the cloud): alpha MAE %.5f vs the density field\n", flyMae);
    // Measured 1.0e-4; marching overlaps twice gives 4.7e-3, losing one ellipsoid 2e-3.
    EXPECT_LT(flyMae, 1e-3);
}

// The default march: a ray per 2x2 pixels into a target of half the size, upsampled over the
// frame with its depth. Against a ray per pixel, what a pilot sees must not change: the light
// and the opacity of a cloud vary slowly across the screen, so the means of 4x4 pixel blocks
// (what the accuracy bench measures against the path tracer) stay within a fraction of the
// bench's errors, and single pixels within the cloud's edges' one-pixel blur.
TEST_F(RaymarchGLTest, ARayPerBlockKeepsTheImageOfARayPerPixel) {
    // Relative RMS of the 4x4 block means of the colour, over the blocks with cloud.
    auto blockError = [](const Image& a, const Image& b) {
        double se = 0, sum = 0;
        int n = 0;
        for (int y = 0; y + 4 <= a.height; y += 4)
            for (int x = 0; x + 4 <= a.width; x += 4) {
                double ma[4] = {0, 0, 0, 0}, mb[4] = {0, 0, 0, 0};
                for (int j = 0; j < 4; ++j)
                    for (int i = 0; i < 4; ++i)
                        for (int c = 0; c < 4; ++c)
                            ma[c] += a.at(x + i, y + j, c) / 16.0, mb[c] += b.at(x + i, y + j, c) / 16.0;
                if (std::max(ma[3], mb[3]) < 0.02) continue;
                for (int c = 0; c < 3; ++c) se += (ma[c] - mb[c]) * (ma[c] - mb[c]), sum += mb[c];
                n += 3;
            }
        return n ? std::sqrt(se / n) / (sum / n) : 0.0;
    };
    RaymarchSettings reduced;  // the default
    ASSERT_EQ(reduced.downsample, 2);
    for (const char* name : {"cumulus27.json", "single.json"})
        for (double noise : {0.0, -1.0}) {
            Scene scene = sharedScene(name);
            if (noise >= 0) scene.medium.noise = noise;
            scene.camera.width = 160, scene.camera.height = 120;
            const Frame halfFrame = render(scene, reduced);
            ASSERT_EQ(halfFrame.stats.downsample, 2) << name << ": the view must be away from the sun's peak";
            const Image full = render(scene).rgba, &half = halfFrame.rgba;
            const double blocks = blockError(half, full);
            const double alphaMae = meanAbs(alphaOf(half), alphaOf(full));
            std::printf(
                "[ figure ] %-14s noise %.1f: a ray per 2x2 pixels against a ray per pixel: 4x4 blocks %.2f%% "
                "(relative RMS), alpha MAE %.5f\n",
                name, scene.medium.noise, 100 * blocks, alphaMae);
            // Measured on llvmpipe: blocks 0.37% (single) and 0.47% (cumulus27), alpha MAE 0.0010
            // and 0.0044 (the clouds' edges: a pixel's blur), with and without noise. The
            // accuracy bench's errors against the path tracer are 3-17%. A ray per 4x4 pixels
            // measures 1.2-1.3% and an alpha MAE of 0.0036 and 0.013: the bounds, 2x the
            // measured, fail it on cumulus27 (and on both for the blocks).
            EXPECT_LT(blocks, 0.01) << name;
            EXPECT_LT(alphaMae, 0.008) << name;
            if (blocks >= 0.01 || alphaMae >= 0.008) {
                save(std::string("raymarch_half_") + name, clamped(half));
                save(std::string("raymarch_full_") + name, clamped(full));
            }
        }
}

// An object inside a cloud, a ray per 2x2 pixels: the rays end at the farthest depth of their
// block, and the upsampling takes, per pixel, the neighbours of its own depth, so the box half
// way into the thin cloud is still covered only by the matter in front of it, and its
// silhouette stays sharp.
TEST_F(RaymarchGLTest, ARayPerBlockKeepsToTheFramesDepth) {
    const BoxInCloud box = boxInCloud(RaymarchSettings{});
    ASSERT_EQ(box.frame.stats.downsample, 2) << "the view must be away from the sun's peak";
    ASSERT_GT(box.n, 100) << "the probe scene no longer puts the box inside the cloud";
    const Image& alpha = box.alpha;
    const Image& exact = box.exact;
    const double errObject = box.errObject, errWhole = box.errWhole;
    const int n = box.n;
    const ImageDifference d = compareImages(alpha, exact, 0.05);
    std::printf(
        "[ figure ] box in thin cloud, a ray per 2x2 pixels: alpha MAE %.5f, max %.4f, pixels off by > 0.05: "
        "%.4f; on the %d box pixels inside the cloud %.5f against the matter in front, %.5f against the whole chord\n",
        d.meanAbs, d.maxAbs, d.fractionOver, n, errObject, errWhole);
    // Measured on llvmpipe: MAE 1.2e-4, max 0.0033, 5.6e-4 on the box pixels (a ray per pixel:
    // 8e-5, 4.4e-4 and 4.3e-4, ObjectInsideACloudIsHiddenOnlyByTheMatterInFront); covering the
    // box with the whole chord costs 0.038 there. Upsampled bilinearly, without the depth: max
    // 0.033 at the silhouette and 3.3e-3 on the box pixels: both bounds below fail it.
    EXPECT_LT(d.maxAbs, 0.015);
    EXPECT_LT(errObject, 0.002);
    EXPECT_GT(errWhole, 10 * errObject);
    if (d.maxAbs >= 0.015 || errObject >= 0.002) save("raymarch_half_box_alpha", alpha);
}

// Looking within the sun's phase peak (HG at least 4x isotropic: about 24 degrees at g = 0.85),
// a back-lit cloud's bright rim is thinner than a 2x2 block: the frame is marched a ray per
// pixel. In view, or just beyond the view's edge, the peak counts; far from the view it does not.
TEST_F(RaymarchGLTest, ARayPerPixelWithinTheSunsPhasePeak) {
    Scene scene = sharedScene("single.json");
    scene.camera.width = 160, scene.camera.height = 120;
    const View view = makeView(scene.camera);
    const double halfX = std::atan(view.tanHalfX);
    const Vec3 f = view.forward, r = view.right;
    auto toward = [&](double yaw) {
        return glm::normalize(std::cos(yaw) * f + std::sin(yaw) * r);
    };  // yaw right of the axis
    struct Case {
        const char* what;
        Vec3 sun;
        int downsample;
    };
    const double deg = std::numbers::pi / 180;
    for (const Case& c :
         {Case{"the sun ahead", f, 1}, Case{"the sun behind", -f, 2},
          Case{"10 degrees beyond the right edge", toward(halfX + 10 * deg), 1},
          Case{"10 degrees beyond the left edge", toward(-halfX - 10 * deg), 1},
          Case{"40 degrees beyond the right edge", toward(halfX + 40 * deg), 2}, Case{"straight up", view.up, 2}}) {
        scene.sun.direction = c.sun;
        RaymarchRenderer clouds;  // the default: a ray per 2x2 pixels
        EXPECT_EQ(render(clouds, scene).stats.downsample, c.downsample) << c.what;
    }
}

// A display channel placed anywhere in the host's frame (View::origin): a ray per 2x2 pixels
// draws there, with the frame's depth of that place, the image it draws alone, and nothing
// outside the channel's viewport.
TEST_F(RaymarchGLTest, ARayPerBlockDrawsIntoAChannelsViewport) {
    Scene scene = sharedScene("box_in_thin_cloud.json");
    scene.camera.width = 96, scene.camera.height = 64;
    RaymarchRenderer clouds;
    const Frame alone = render(clouds, scene);
    ASSERT_EQ(alone.stats.downsample, 2);
    View placed = makeView(scene.camera);
    placed.origin = glm::ivec2(40, 30);  // from the lower left: rows 18..81, columns 40..135 from the top left
    FrameTarget big(160, 112);
    const float marker[4] = {0.25f, 0.5f, 0.75f, 1.0f};
    glClearNamedFramebufferfv(big.framebuffer(), GL_COLOR, 0, marker);
    OpaquePass().draw(scene, placed, big.framebuffer());
    clouds.render(scene, placed, big.framebuffer(), true);
    const Image image = big.readColor();
    double worst = 0;
    int outside = 0;
    for (int y = 0; y < 112; ++y)
        for (int x = 0; x < 160; ++x)
            for (int k = 0; k < 4; ++k) {
                if (x >= 40 && x < 136 && y >= 18 && y < 82)
                    worst = std::max(worst, double(std::fabs(image.at(x, y, k) - alone.rgba.at(x - 40, y - 18, k))));
                else outside += image.at(x, y, k) != marker[k];
            }
    // Rasterised at other window positions, interpolants round in the last bits of a float; a
    // depth or ray read at the wrong place moves the box's silhouette by pixels (differences of
    // 0.1 and more).
    EXPECT_LT(worst, 1e-4);
    EXPECT_EQ(outside, 0);
}

TEST_F(RaymarchGLTest, CameraInsideACloudSeesFog) {
    Scene s = sharedScene("flythrough.json");  // with the scene's own noise
    s.camera = cameraAt(s, 5.0);               // the path passes through the cloud
    s.camera.width = 160;
    s.camera.height = 120;
    const Frame f = render(s);
    const double a = mean(alphaOf(f.rgba));
    std::printf("[ figure ] flythrough t=5, noise %.2f: mean alpha %.4f\n", s.medium.noise, a);
    EXPECT_GT(a, 0.9) << "inside the cloud the view must be filled with cloud";
    // Lit, not black: the radiance of a cloud seen from inside is of the order of the ambient.
    const Image rgb = channels(f.rgba, 0, 3);
    EXPECT_GT(mean(rgb), 0.1);
    save("raymarch_inside", clamped(f.rgba));
}

// The light model (Algorithm 3 with the shared source S of cloud_light.glsl), checked against a
// brute-force CPU integral of the same equation: exact density at every point (all
// ellipsoids), the radiance grid read on the CPU in float, a fine fixed step. What separates
// them: the grid in half floats on the GPU, and the marcher's growing step.
namespace {

void radianceMatchesTheLightModel(const char* name) {
    Scene scene = sharedScene(name, 80);
    scene.medium.noise = 0;
    scene.sun.direction = glm::normalize(Vec3(0.5, 0.6, 0.4));  // low and behind: lit and shadowed sides, a bright rim
    const View view = makeView(scene.camera);
    const Image gpu = channels(render(scene).rgba, 0, 3);
    const Image background = channels(renderOpaqueCpu(scene, view), 0, 3);

    const Cloud& cloud = scene.clouds[0];
    std::vector<glm::dmat3> units;
    for (const Ellipsoid& e : cloud.ellipsoids) units.push_back(ellipsoidToUnit(e));
    Vec3 lo, hi;
    raymarchCloudBox(cloud, lo, hi);
    const Medium& m = scene.medium;
    const glm::vec3 sun(scene.sun.color * scene.sun.intensity);
    // The same grid the renderer computes (deterministic for the same inputs and settings).
    const CloudRadiance grid = computeCloudRadiance(scene, cloud, RaymarchSettings{}.light);
    Image cpu(gpu.width, gpu.height, 3);
    const double dl = 2.0;  // m
    for (int y = 0; y < cpu.height; ++y)
        for (int x = 0; x < cpu.width; ++x) {
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            // The ray's span inside the cloud's box.
            double t0 = view.camera.nearClip / glm::dot(d, view.forward), t1 = 1e9;
            for (int k = 0; k < 3; ++k) {
                const double a = (lo[k] - view.eye[k]) / d[k], b = (hi[k] - view.eye[k]) / d[k];
                t0 = std::max(t0, std::min(a, b));
                t1 = std::min(t1, std::max(a, b));
            }
            Vec3 radiance(0.0);
            double T = 1;
            for (double t = t0; t < t1 && T > 1e-6; t += dl) {
                const Vec3 p = view.eye + (t + 0.5 * dl) * d;
                double sigma = 0;
                for (std::size_t i = 0; i < units.size(); ++i) {
                    const Vec3 u = units[i] * (p - cloud.ellipsoids[i].center);
                    const double q = glm::dot(u, u);
                    if (q < 1) sigma += m.extinction * cloud.ellipsoids[i].density * (1 - q) * (1 - q);
                }
                if (sigma <= 0) continue;
                const double dT = std::exp(-sigma * dl);
                // The shared light model with the grid read on the CPU.
                const RadianceSample r = sampleRadiance(grid, p);
                const glm::vec3 scalars = model::lightScalars(r.sunFew, r.sunMany, r.skyTau, r.skyFlux, glm::vec3(d),
                                                              glm::vec3(scene.sun.direction), float(m.hgG));
                radiance += T * (1 - dT) *
                            Vec3(model::sourceFromScalars(scalars, sun, model::skyChroma(glm::vec3(r.skyTau)),
                                                          float(m.albedo)));
                T *= dT;
            }
            const Vec3 bg(background.at(x, y, 0), background.at(x, y, 1), background.at(x, y, 2));
            for (int k = 0; k < 3; ++k) cpu.at(x, y, k) = float(radiance[k] + T * bg[k]);
        }
    const double db = psnr(clamped(gpu), clamped(cpu));
    std::printf("[ figure ] %s radiance, GPU vs CPU integral of the light model: PSNR %.1f dB\n", name, db);
    // Measured on llvmpipe: cumulus27 70.9 dB, dense_cumulus 59.4 dB: the grid in half floats and the GPU's 8-bit
    // filtering weights against the CPU's float trilinear reads, the marcher's growing step against 2 m steps. 50 dB
    // leaves room for other drivers' filtering; a light term missing or read from the wrong grid costs far more.
    EXPECT_GT(db, 50.0);
    if (db <= 50.0) {
        save(std::string("raymarch_light_gpu_") + name, clamped(gpu));
        save(std::string("raymarch_light_cpu_") + name, clamped(cpu));
    }
}

}  // namespace

// dense_cumulus.json (real cumulus matter) too: its grid holds the sun's transmittance as T^p with
// p well below 1 (CloudRadiance::sunPower), which the GPU must read back as the CPU does.
TEST_F(RaymarchGLTest, RadianceMatchesTheLightModelIntegratedOnTheCpu) {
    for (const char* name : {"cumulus27.json", "dense_cumulus.json"}) {
        SCOPED_TRACE(name);
        radianceMatchesTheLightModel(name);
    }
}

// With noise the GPU integrates the noisy density field (raymarch.hpp): its opacity must match the
// CPU twin (raymarchExtinction / marchDensityNdt with the same noise volume) along every ray.
TEST_F(RaymarchGLTest, NoisyFieldMatchesItsCpuTwin) {
    Scene scene = sharedScene("cumulus27.json", 80);
    scene.medium.noise = 0.3;
    scene.medium.noiseScale = 60;
    RaymarchSettings s = perPixel();
    s.step = 10;
    s.lodDistance = 0;
    const View view = makeView(scene.camera);
    const Frame f = render(scene, s);
    const Image alpha = alphaOf(f.rgba);
    const NoiseSettings ns = raymarchNoiseSettings(s);
    const NoiseVolume nv = makeNoiseVolume(ns);
    const double period = raymarchNoisePeriod(scene.medium, ns);
    Image cpu(alpha.width, alpha.height, 1);
    Scene smooth = scene;
    smooth.medium.noise = 0;
    const Image smoothAlpha = exactDensityOpacity(smooth, view);
    for (int y = 0; y < cpu.height; ++y)
        for (int x = 0; x < cpu.width; ++x) {
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            const double depth = marchDensityNdt(scene.medium, scene.clouds[0], view.eye, d, 2.0, &nv, period);
            cpu.at(x, y, 0) = float(1 - std::exp(-scene.medium.extinction * depth));
        }
    const double mae = meanAbs(alpha, cpu), changed = meanAbs(smoothAlpha, cpu);
    std::printf(
        "[ figure ] cumulus27 noise 0.3: GPU vs CPU twin alpha MAE %.5f (the noise itself changes alpha by %.4f)\n",
        mae, changed);
    // A step of 10 m against the CPU's 2 m across fBm detail down to 60 m / 2^4, and the
    // texture's float filtering against NoiseVolume::sample's: measured 9e-5. The noise must
    // matter (changed >> mae), or this test proves nothing: without noise on the GPU, with the
    // noise not anchored to the world or with its sign flipped, mae is 6.0e-3 to 9.1e-3.
    EXPECT_LT(mae, 1e-3);
    EXPECT_GT(changed, 5 * mae);
    save("raymarch_noise", clamped(f.rgba));
}

// More ellipsoids along a ray than the shader's candidate list holds (32), and more clouds
// than one batch of box hits (8): the list is gathered again past the first one left out,
// the clouds taken batch after batch, and the opacity is still the closed form's.
TEST_F(RaymarchGLTest, ManyCandidatesAndCloudsPerRayStayExact) {
    Scene s;
    s.camera.position = {0, -300, 0};
    s.camera.direction = {0, 1, 0};
    s.camera.fovYDeg = 20;
    s.camera.width = 160;
    s.camera.height = 120;
    s.medium.noise = 0;
    Cloud chain{"chain", {}};  // 80 spheres one behind the other, each overlapping its neighbours
    for (int i = 0; i < 80; ++i) {
        Ellipsoid e;
        e.center = {10.0 * std::sin(i * 0.7), 25.0 * i, 10.0 * std::cos(i * 0.3)};
        e.radii = {60, 60, 60};
        e.density = 0.005;
        chain.ellipsoids.push_back(e);
    }
    s.clouds.push_back(chain);
    for (int c = 0; c < 12; ++c) {  // 12 one-ellipsoid clouds beyond it, on the same rays
        Ellipsoid e;
        e.center = {0, 2300.0 + 150.0 * c, 0};
        e.radii = {70, 50, 70};
        e.density = 0.03;
        std::string name = "c";
        name += std::to_string(c);  // not "c" + ...: a GCC 12 -Wrestrict false positive
        s.clouds.push_back({name, {e}});
    }
    const Image exact = exactDensityOpacity(s, makeView(s.camera));
    RaymarchSettings fine = perPixel();  // a fine fixed step: what is left is the bookkeeping, not the quadrature
    fine.step = 5;
    fine.lodDistance = 0;
    const Image alpha = alphaOf(render(s, fine).rgba);
    const double mae = meanAbs(alpha, exact), worst = maxAbs(alpha, exact);
    std::printf("[ figure ] 80 ellipsoids and 12 clouds on a ray: alpha MAE %.6f, max %.5f (exact centre alpha %.3f)\n",
                mae, worst, exact.at(80, 60, 0));
    ASSERT_GT(exact.at(80, 60, 0), 0.5);  // the probe must have matter to measure
    ASSERT_LT(exact.at(80, 60, 0), 0.99);
    // Measured MAE 3e-6, max 3e-5 (float rounding). Marching only the first gather of
    // candidates gives max 0.20, only the first batch of clouds max 0.066.
    EXPECT_LT(mae, 1e-4);
    EXPECT_LT(worst, 2e-3);
}

// Algorithm 2 on the CPU, with noise 0, against the closed form: the no-duplicate march over
// overlapping ellipsoids integrates each point once.
TEST_F(RaymarchGLTest, NoDuplicateTracingIntegratesOverlapsOnce) {
    const Scene scene = sharedScene("cumulus27.json");
    Medium smooth = scene.medium;
    smooth.noise = 0;
    const Cloud& cloud = scene.clouds[0];
    double worst = 0;
    for (int i = 0; i < 50; ++i) {
        const Vec3 o(-1500 + 60 * i, -1800, 1500 + 4 * i);
        const Vec3 d = glm::normalize(Vec3(0.4 - 0.016 * i, 1.0, 0.1));
        double exact = 0;
        for (const Ellipsoid& e : cloud.ellipsoids) {
            const glm::dmat3 m = ellipsoidToUnit(e);
            exact += e.density * model::segmentDepth(glm::vec3(m * (o - e.center)), glm::vec3(m * d), 0.0f, 1e30f);
        }
        const double marched = marchDensityNdt(smooth, cloud, o, d, 1.0, nullptr, 1.0);
        worst = std::max(worst, std::fabs(marched - exact) / std::max(exact, 1.0));
    }
    std::printf("[ figure ] NDT density march (step 1 m) vs closed form: worst relative error %.2e\n", worst);
    // Measured 1.8e-6 (the midpoint rule at 1 m over chords of hundreds of metres); an overlap
    // marched twice adds its whole depth again (tens of percent).
    EXPECT_LT(worst, 1e-4);
}

TEST_F(RaymarchGLTest, LightIsComputedOnlyWhenCloudsSunSkyOrMediumChange) {
    Scene scene = sharedScene("cumulus27.json");
    scene.medium.noise = 0;
    RaymarchRenderer clouds;
    const int first = render(clouds, scene).stats.lightGridsComputed;
    const int again = render(clouds, scene).stats.lightGridsComputed;
    scene.camera.position.x += 100;  // the camera moves: nothing to recompute
    const int moved = render(clouds, scene).stats.lightGridsComputed;
    for (Ellipsoid& e : scene.clouds[0].ellipsoids) e.center += Vec3(250, -40, 0);  // the wind moves the cloud
    const int drifted = render(clouds, scene).stats.lightGridsComputed;
    scene.sun.direction = glm::normalize(Vec3(-0.3, 0.2, 0.9));
    const int sun = render(clouds, scene).stats.lightGridsComputed;
    scene.sky.ground = Vec3(0.3, 0.2, 0.1);
    const int sky = render(clouds, scene).stats.lightGridsComputed;
    scene.medium.albedo = 0.9;
    const int medium = render(clouds, scene).stats.lightGridsComputed;
    EXPECT_EQ(first, 1);
    EXPECT_EQ(again, 0);
    EXPECT_EQ(moved, 0);
    EXPECT_EQ(drifted, 0);
    EXPECT_EQ(sun, 1);
    EXPECT_EQ(sky, 1);
    EXPECT_EQ(medium, 1);
}

TEST_F(RaymarchGLTest, RendersAreDeterministic) {
    const Scene scene = sharedScene("flythrough.json");  // noise on, an object, several passes of candidates
    RaymarchRenderer clouds;
    const Image a = render(clouds, scene).rgba;
    const Image b = render(clouds, scene).rgba;
    const Image c = render(scene, RaymarchSettings{}).rgba;  // a fresh renderer: same again
    EXPECT_EQ(a.pixels, b.pixels);
    EXPECT_EQ(a.pixels, c.pixels);
}

TEST_F(RaymarchGLTest, LeavesHostStateUnchanged) {
    const Scene scene = sharedScene("flythrough.json");
    const View view = makeView(scene.camera);
    FrameTarget target(scene.camera.width, scene.camera.height);
    OpaquePass().draw(scene, view, target.framebuffer());
    RaymarchRenderer clouds;
    const test::HostileGlState hostile;
    // With the frame's depth (draw 0) and without (draw 1).
    test::expectStateUnchanged([&](int k) { clouds.render(scene, view, target.framebuffer(), k == 0); }, 2);
}

TEST_F(RaymarchGLTest, CloudsBehindTheEyeLeaveTheFrameUntouched) {
    Scene s = sharedScene("single.json");
    s.camera.direction = -s.camera.direction;  // looking away
    const View view = makeView(s.camera);
    const Image rgba = render(s).rgba;
    EXPECT_EQ(alphaOf(rgba).pixels, Image(160, 120, 1, 0.0f).pixels);
    const Image bg = renderOpaqueCpu(s, view);
    EXPECT_LT(compareImages(channels(rgba, 0, 3), channels(bg, 0, 3), 1e-3).maxAbs, 1e-3);
}

TEST_F(RaymarchGLTest, RejectsBadSettings) {
    for (auto change :
         {+[](RaymarchSettings& s) { s.step = 0; }, +[](RaymarchSettings& s) { s.lodDistance = -1; },
          +[](RaymarchSettings& s) { s.light.size = 1; }, +[](RaymarchSettings& s) { s.octaves = 0; },
          +[](RaymarchSettings& s) { s.maxSteps = 0; }, +[](RaymarchSettings& s) { s.maxSteps = 1 << 20; },
          +[](RaymarchSettings& s) { s.step = NAN; }, +[](RaymarchSettings& s) { s.downsample = 0; },
          +[](RaymarchSettings& s) { s.downsample = 5; }}) {
        RaymarchSettings s;
        change(s);
        EXPECT_THROW(RaymarchRenderer{s}, std::invalid_argument);
    }
}

// Runaway marches are bounded: a cloud of radius 1e9 m with noise (its light march took 10^7
// steps a voxel: hung) and a step so small that adding it leaves the distance unchanged (it
// marked time forever on the CPU, until maxSteps on the GPU) end in bounded time with an
// opaque cloud, and the CPU march of such a step still integrates the closed form. The eye is
// halfway into the huge cloud (density 0.56 there): near its surface the (1 - q)^2 profile of
// a 1e9 m sphere is too thin to cover anything within the far plane.
TEST_F(RaymarchGLTest, HugeCloudsAndTinyStepsEndInBoundedTime) {
    Scene scene = sharedScene("single.json");
    scene.camera.width = 32, scene.camera.height = 24;
    scene.medium.noise = 0.3;
    Ellipsoid& e = scene.clouds[0].ellipsoids[0];
    Scene huge = scene;
    huge.clouds[0].ellipsoids = {e};
    huge.clouds[0].ellipsoids[0].radii = Vec3(1e9);
    huge.clouds[0].ellipsoids[0].center = scene.camera.position + 5e8 * glm::normalize(scene.camera.direction);
    struct Case {
        const char* what;
        const Scene& scene;
        double step;
    };
    for (const Case& c : {Case{"radius 1e9", huge, 25.0}, Case{"step 1e-30", scene, 1e-30}}) {
        RaymarchSettings s;
        s.step = c.step;
        s.light.size = 8;  // the light march's cost is per voxel: a small grid keeps the test short
        const auto start = std::chrono::steady_clock::now();
        const Image alpha = alphaOf(render(c.scene, s).rgba);
        const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::printf("[ figure ] %s: %.2f s\n", c.what, took);
        EXPECT_LT(took, 60.0) << c.what;                  // a bound on a loaded 2-core machine, not a speed claim
        EXPECT_GT(alpha.at(16, 12, 0), 0.99f) << c.what;  // the centre of the frame is cloud
    }
    // The CPU march along a radius of the 1e9 m sphere (noise 0: the closed form is r 8/15)
    // at a step of 1e-300: 1024 steps at most, and midpoint quadrature is within 1e-5 there.
    Medium m;
    m.noise = 0;
    Cloud sphere{"s", {Ellipsoid{Vec3(0.0), Vec3(1e9), Vec3(0.0), 1.0}}};
    const double depth = marchDensityNdt(m, sphere, Vec3(0.0), Vec3(0, 0, 1), 1e-300, nullptr, 1.0);
    EXPECT_NEAR(depth, 1e9 * 8.0 / 15.0, 1e-5 * 1e9);
}

// A host's window: the default framebuffer and its own depth buffer (GLFW under Xvfb).
TEST(RaymarchWindowGLTest, DrawsIntoAWindowsDefaultFramebuffer) {
    if (!std::getenv("DISPLAY")) GTEST_SKIP() << "no DISPLAY (run under xvfb-run)";
    Scene scene = sharedScene("box_in_thin_cloud.json");
    scene.medium.noise = 0;
    Image offscreen;
    {
        auto egl = test::makeContext(GlBackend::Egl);
        offscreen = render(scene).rgba;
    }
    const Image window = test::renderInWindow(
        scene, [&](const View& view, GLuint fb) { RaymarchRenderer().render(scene, view, fb, true); });
    // The window's buffer is 8-bit: the sky and the clouds over it each round to 1/255
    // (measured 1.6/255 at most). Without the depth (the box covered by the whole chord) the
    // box's pixels change by up to 6.5/255.
    Image reference = offscreen;
    for (float& v : reference.pixels) v = std::clamp(v, 0.0f, 1.0f);
    const double worst = compareImages(channels(window, 0, 3), channels(reference, 0, 3), 0).maxAbs;
    std::printf("[ figure ] window vs off-screen frame: max difference %.1f/255\n", worst * 255);
    EXPECT_LT(worst, 3.0 / 255);
}

}  // namespace
