// What the layered far field's reuse across frames compares from one frame to the next
// (LayeredRenderer, ReducedTarget's reuse): each layer's weather and the textures it draws with,
// the layers matched across frames. Internal to layered/; tests/frame_change_test.cpp checks it.
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// What a layer draws with (its lighting volume and modulation texture, nullptr: none yet).
struct LayerTextures {
    const void* light = nullptr;
    const void* modulation = nullptr;
    bool operator==(const LayerTextures&) const = default;
};

// The weather the far field's image depends on, each entry in units in which 0.01 is a change
// a ramp makes in a frame (coverage and density as they are; the base, the thickness, the
// extent and the sun's intensity 1% of themselves, the base 1 m below 100 m; the sun's direction
// 0.6 degrees). A step of 0.01 adds one reduced pixel to
// every kept texel's bound (kWeatherErrorPerUnit): at the default reuseError of 2 px a texel
// lags the weather by at most 0.02 (a ramp's fade shows no blocks drawn far apart in it, and a
// ramp of 0.01-0.02 a frame draws half its texels or more afresh each frame), and a step larger
// than that draws every pixel afresh, so a fast ramp's frame shows its own weather.
struct LayerRecord {
    std::vector<double> weather;
    LayerTextures textures;
    double density = 0;  // what a layer come, gone or given new textures changes the image by at most
};
struct FrameRecord {
    std::vector<LayerRecord> layers;  // in the scene's order (a transition keeps it: by layer id)
    std::vector<double> weather;      // the sun's and the medium's
};

// `textures`: one per scene layer.
FrameRecord frameRecord(const Scene& scene, const std::vector<LayerTextures>& textures);

constexpr double kWeatherErrorPerUnit = 100;  // reduced px per unit of a FrameRecord's weather

// A layer's lighting volume or pattern replaced by another (a thickness ramp's target volume
// arriving, a layer's own volume or pattern replacing the nearest it was drawn with) is rolled
// in: for this many frames the reuse period is this many frames, so that every pixel is drawn
// afresh with the new textures within them and no frame draws them all. Kept pixels show the
// old ones meanwhile, as the layer was drawn with them until then.
constexpr int kLightRollFrames = 2;

// How the far field's image may have changed from one frame to the next.
struct FrameChange {
    double step = 0;                // the largest change of the weather, in its units (infinite: all of it)
    bool texturesReplaced = false;  // a dense layer's lighting volume or pattern replaced by another
};

// `now` against `last`, the layers matched in order; with one layer more or fewer, the match
// that changes least, the unmatched layer a step of its density (a transition adds a layer at
// fade 0 and drops one at fade 0, keeping the others' order). More layers come or gone:
// infinite. A layer of density d drawing with other textures than before (its first lighting
// volume, or its own pattern instead of another seed's) is a step of d when d <= maxStep (it
// changes the image by at most what d adds, as a fade's frame does); a denser one's textures
// replaced by others (both made) are texturesReplaced; anything else is infinite.
FrameChange compareFrames(const FrameRecord& now, const FrameRecord& last, double maxStep);

}  // namespace nephele
NEPHELE_API_END
