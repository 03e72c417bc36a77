// The clouds of one update() as a field the host can query (SkyRenderer::densityAt,
// transmittance, insideCloud; sky.hpp): what the frame draws, as matter. Immutable once made,
// so that any thread may read it while update() makes the next one.
//
// The extinction at a world point x is the sum of
// - the explicit clouds' matter (nephele/cloud_matter.hpp; made once at prepare());
// - the near LOD's clouds', each times its Cloud::weight (1 - nearFade of its spawn point's
//   distance from the eye: what the eye sees of it);
// - each layer's, as the layered sky draws it: medium.extinction * layerDensity(x, t) (eq. 16,
//   wind at the update's time), times nearFade(h) for a layer with near_lod (the near clouds
//   stand in for it near the eye), times rimFade(h) (LayeredSettings::extentFade), h the
//   horizontal distance of x from the eye (as LayerVolumes and the path tracer have it).
#pragma once

#include "nephele/cloud_matter.hpp"
#include "nephele/layered.hpp"
#include "nephele/sky.hpp"

#include <memory>
#include <vector>

namespace nephele {

class CloudField {
public:
    struct LayerEntry {
        Layer layer;  // windOffset such that layerDrift(layer, time) is where its pattern is
        bool nearLod = false;
        std::shared_ptr<const LightingVolume> light;
        std::shared_ptr<const ModulationTexture> modulation;
    };

    // `explicitClouds` (shared between fields: made once) and `nearClouds` (may be null), the
    // detail seen from `eye` with `medium.detail`'s drift, the layers at time `time`.
    CloudField(std::shared_ptr<const CloudMatter> explicitClouds, std::shared_ptr<const CloudMatter> nearClouds,
               const Medium& medium, const LayeredSettings& layered, std::vector<LayerEntry> layers, const Vec3& eye,
               double time);

    double extinction(const Vec3& p) const;
    double transmittance(const Vec3& origin, const Vec3& direction, double length) const;
    CloudPresence presence(const Vec3& p) const;

private:
    double layerExtinction(const LayerEntry& e, const Vec3& p) const;
    double cloudDepth(const CloudMatter& matter, const Vec3& o, const Vec3& d, double length) const;
    double layerDepth(const LayerEntry& e, const Vec3& o, const Vec3& d, double length) const;

    std::shared_ptr<const CloudMatter> explicit_, near_;
    CloudMatter::DetailFrame detail_;
    double noiseScale_ = 0;
    double extinctionPerDensity_ = 0;
    LayeredSettings layered_;
    std::vector<LayerEntry> layers_;
    Vec3 eye_{0.0};
    double time_ = 0;
};

}  // namespace nephele
