// The layered far field's reuse across frames: what it counts as a change from one frame to the
// next (compareFrames, layered/internal/frame_change.hpp). A layer a transition adds or drops at
// fade 0 changes nothing, wherever it sits among the others; one dense layer come or given
// textures not made before draws everything afresh (an infinite or large step); a dense layer's
// textures replaced by others are rolled in; a dim one's are a step of its density.
#include "frame_change.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace nephele;

namespace {

constexpr double kMaxStep = 0.02;  // LayeredSettings' default reuseError (2 px) / kWeatherErrorPerUnit

// Distinct addresses standing for textures.
const int kLight[3] = {}, kPattern[3] = {};

Layer layer(double coverage, double density, unsigned seed = 1) {
    Layer l;
    l.base = 2000, l.thickness = 600;
    l.coverage = coverage, l.density = density, l.seed = seed;
    return l;
}

// A frame of these layers, each drawing with its own light and pattern (index i: kLight[i]).
FrameRecord frame(const std::vector<Layer>& layers, std::vector<LayerTextures> textures = {}) {
    Scene scene;
    scene.layers = layers;
    for (std::size_t i = textures.size(); i < layers.size(); ++i) textures.push_back({&kLight[i], &kPattern[i]});
    return frameRecord(scene, textures);
}

}  // namespace

TEST(FrameChangeTest, TheSameFrameIsNoChangeAndTheFirstIsAll) {
    const FrameRecord a = frame({layer(0.6, 0.9)});
    EXPECT_EQ(compareFrames(a, a, kMaxStep).step, 0.0);
    EXPECT_FALSE(compareFrames(a, a, kMaxStep).texturesReplaced);
    EXPECT_TRUE(std::isinf(compareFrames(a, FrameRecord{}, kMaxStep).step));
}

TEST(FrameChangeTest, ALayerComeOrGoneIsAStepOfItsDensityWhereverItSits) {
    const Layer low = layer(0.3, 0.9), high = layer(0.7, 0.5);
    const FrameRecord before = frame({low, high});
    // A transition's new layer (ids between the others') at fade 0, then 0.01.
    for (double fade : {0.0, 0.01, 0.6}) {
        const FrameRecord now =
            frame({low, layer(0.5, fade, 9), high},
                  {{&kLight[0], &kPattern[0]}, {&kLight[2], &kPattern[2]}, {&kLight[1], &kPattern[1]}});
        EXPECT_DOUBLE_EQ(compareFrames(now, before, kMaxStep).step, fade) << "fade " << fade;
        EXPECT_DOUBLE_EQ(compareFrames(before, now, kMaxStep).step, fade) << "gone at fade " << fade;
    }
    // Two layers at once: matched no more.
    const FrameRecord two = frame({low, layer(0.5, 0, 9), high, layer(0.5, 0, 8)});
    EXPECT_TRUE(std::isinf(compareFrames(two, before, kMaxStep).step));
}

TEST(FrameChangeTest, ADenseLayersNewTexturesAreRolledInADimOnesAreAStep) {
    const Layer dense = layer(0.6, 0.9), dim = layer(0.6, 0.015, 2);
    const FrameRecord before = frame({dense, dim});
    // The dense layer's own pattern replacing a stand-in, and its own light replacing another's.
    for (const LayerTextures t : {LayerTextures{&kLight[0], &kPattern[2]}, LayerTextures{&kLight[2], &kPattern[0]}}) {
        const FrameChange c = compareFrames(frame({dense, dim}, {t, {&kLight[1], &kPattern[1]}}), before, kMaxStep);
        EXPECT_TRUE(c.texturesReplaced);
        EXPECT_EQ(c.step, 0.0);
    }
    // The dim layer's own pattern: a step of its density, nothing rolled in.
    const FrameChange c =
        compareFrames(frame({dense, dim}, {{&kLight[0], &kPattern[0]}, {&kLight[1], &kPattern[2]}}), before, kMaxStep);
    EXPECT_FALSE(c.texturesReplaced);
    EXPECT_DOUBLE_EQ(c.step, 0.015);
    // A dense layer drawn for the first time (its first lighting volume): everything afresh.
    const FrameRecord unlit = frame({dense, dim}, {{nullptr, &kPattern[0]}, {&kLight[1], &kPattern[1]}});
    EXPECT_TRUE(std::isinf(compareFrames(before, unlit, kMaxStep).step));
}

// Each entry's unit: 0.01 is a ramp's change in a frame (the coverage 0.01; the base, thickness,
// extent and sun 1% of themselves; the base 1 m near the ground); the step is the largest entry's.
TEST(FrameChangeTest, TheWeatherStepIsTheLargestChangeOfAnEntry) {
    Scene scene;
    scene.layers = {layer(0.6, 0.9)};
    scene.sun.intensity = 3;
    const FrameRecord before = frameRecord(scene, {{&kLight[0], &kPattern[0]}});
    auto step = [&](auto change) {
        Scene s = scene;
        change(s);
        return compareFrames(frameRecord(s, {{&kLight[0], &kPattern[0]}}), before, kMaxStep).step;
    };
    EXPECT_NEAR(step([](Scene& s) { s.layers[0].coverage += 0.004; }), 0.004, 1e-9);
    EXPECT_NEAR(step([](Scene& s) { s.layers[0].base *= 1.01; }), 0.01, 1e-4);
    EXPECT_NEAR(step([](Scene& s) { s.layers[0].thickness *= 1.01; }), 0.01, 1e-4);
    EXPECT_NEAR(step([](Scene& s) { s.layers[0].extent *= 0.99; }), 0.01, 1e-4);
    EXPECT_NEAR(step([](Scene& s) { s.sun.intensity *= 1.01; }), 0.01, 1e-4);
    EXPECT_NEAR(step([](Scene& s) {
                    s.layers[0].coverage += 0.004;
                    s.layers[0].base *= 1.015;
                }),
                std::log(1.015), 1e-4);  // the base's, 0.0149
    EXPECT_NEAR(step([](Scene& s) { s.layers[0].base = 0; }) - step([](Scene& s) { s.layers[0].base = 1; }), 0.01,
                1e-4);
    EXPECT_FALSE(step([](Scene& s) { s.layers[0].coverage = std::nan(""); }) <= kMaxStep);
}
