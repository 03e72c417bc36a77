// `--method auto` as one library call: what an image generator links to draw all of a scene's
// clouds. The layered far field (layers with near_lod: true leave out a disc around the eye,
// faded across a blend band), then, in one compositor call, the scene's explicit ellipsoid
// clouds and the near LOD's cumulus that stand in for the layer near the eye (faded by the
// complement). A scene without layers is drawn exactly as EllipsoidRenderer draws it.
#pragma once

#include "nephele/ellipsoid.hpp"
#include "nephele/layered.hpp"
#include "nephele/near_lod.hpp"

#include <memory>

namespace nephele {

// `base` with auto's hand-off: nearRadius kAutoNearRadius and blendBand kAutoBlendBand where
// they are 0, and the billboard disc reaching kAutoLod0Margin beyond the band.
LayeredSettings autoLayeredSettings(LayeredSettings base = {});

// The compositor's settings for auto: the weighted, order-independent composite, since the
// eye flies through overlapping near cumulus, where back to front pops as the order flips
// (see the README, "Composite order").
EllipsoidSettings autoEllipsoidSettings(EllipsoidSettings base = {});

struct SkySettings {
    LayeredSettings layered = autoLayeredSettings();
    NearLodSettings nearLod;
    EllipsoidSettings ellipsoid = autoEllipsoidSettings();
    bool timings = false;  // SkyStats' ms by part (gl::PartTimer: glFinish between the parts, slower)
};

struct SkyStats {
    LayeredStats layered;      // the far field (sceneLayers 0 when the scene has no layers)
    NearLodStats nearLod;      // what the near LOD spawned
    EllipsoidStats ellipsoids; // the compositor, explicit and near clouds together (tilesMs, compositeMs)
    // With SkySettings::timings, the wall time of each part (ms); else 0.
    double farFieldMs = 0;     // the layered sky
    double nearLodMs = 0;      // the near LOD's update (spawning and retiring cells)
};

// Needs a current OpenGL 4.5 context; leaves the GL state as it found it.
class SkyRenderer {
public:
    // Throws std::invalid_argument for bad settings (naming the setting).
    explicit SkyRenderer(SkySettings settings = {});
    ~SkyRenderer();
    SkyRenderer(const SkyRenderer&) = delete;
    SkyRenderer& operator=(const SkyRenderer&) = delete;
    const SkySettings& settings() const { return settings_; }

    // Draws every cloud of `scene` over `framebuffer` (as EllipsoidRenderer::render and
    // LayeredRenderer::render: colour attachment 0 rgb = radiance, a = cloud opacity; the
    // opaque objects' depth in its depth attachment when `opaqueDepth`). timeSeconds drives
    // wind, lightning and the near LOD's drift.
    SkyStats render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds, bool opaqueDepth);

    // For a host's debug views: the compositor (its last tiles and atlas), and the near LOD
    // (its cells; nullptr before the first scene with layers).
    const EllipsoidRenderer& compositor() const { return clouds_; }
    const NearLod* nearLod() const { return nearLod_.get(); }

private:
    SkySettings settings_;
    EllipsoidRenderer clouds_;
    std::unique_ptr<LayeredRenderer> layered_;  // made at the first scene with layers
    std::unique_ptr<NearLod> nearLod_;
};

}  // namespace nephele
