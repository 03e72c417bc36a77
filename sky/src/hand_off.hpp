// The near LOD against the layer it stands for (issue #10): the measure that
// `nephele bench --layer-accuracy` reports and the GL tests hold to their targets. Internal.
#pragma once

#include "nephele/ellipsoid.hpp"
#include "nephele/layered.hpp"
#include "nephele/opaque.hpp"
#include "nephele/scene.hpp"

#include <functional>

namespace nephele {

// Within `reach` (m, horizontally) of the eye, the near LOD's clouds alone (every cell at
// weight 1: NearLod with nearRadius = reach, drawn by auto's compositor) and the layered sky
// alone cut at the reach (extent = reach, no rim fade), each over the scene's sky and ground
// (OpaquePass); of scene.layers.front():
// - over the pixels whose ray meets the layer's slab within the reach: the mean opacity of
//   each, and of the layer's volume (1 - exp(-extinction x layerDensityIntegral()));
// - over the pixels whose ray meets the slab between bandFrom and the reach (auto's blend band):
//   the mean luminance of each frame.
struct HandOff {
    int reachPixels = 0, bandPixels = 0;
    double nearOpacity = 0, layerOpacity = 0, volumeOpacity = 0;
    double nearRadiance = 0, layerRadiance = 0;
};
// Needs a current OpenGL 4.5 context; `layered` are the layered sky's settings (its
// nearRadius and blendBand are not used).
HandOff measureHandOff(const Scene& scene, const View& view, const LayeredSettings& layered, double bandFrom,
                       double reach, const EllipsoidSettings& compositor);

// A frame of the view's size: the scene's sky, ground and objects, then draw(framebuffer); read back.
Image drawOver(const Scene& scene, const View& view, const OpaquePass& opaque, const std::function<void(GLuint)>& draw);

// The ray o + s d (s >= 0) meets the slab [base, top] at a horizontal distance from o in [from, to].
bool meetsSlab(const Vec3& o, const Vec3& d, double base, double top, double from, double to);

}  // namespace nephele
