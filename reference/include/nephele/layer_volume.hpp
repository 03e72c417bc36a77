// The scene's far-field layers as volumes of cloud matter, for the path tracer
// (PathTraceSettings::layers): the layered sky's density exactly as its shader reads it, so
// that the layered sky and auto's hand-off can be measured against physics.
//
// Layer i is the slab [base, base + thickness] within the horizontal distance `extent` of the
// eye (the layered sky is centred on the eye), of extinction
//   sigma_t(x) = medium.extinction * layerDensity(x, t) * (1 - smoothstep(extent (1 - f), extent, h))
// layerDensity() being eq. (16) with the lighting volume's A and the modulation texture's r,
// wind applied at time t (nephele/layered.hpp), h the horizontal distance from the eye and f
// LayeredSettings::extentFade (the shader's fade at the rim). Albedo and phase are the medium's,
// as for the ellipsoid clouds. The textures are the renderer's own: the lighting volume from
// lightingCached(settings.lighting, ...) and the modulation from makeModulation(settings.modulation,
// layer.seed). Both are sampled at their full resolution (the GPU's mipmaps are the renderer's
// approximation, not the layer's density).
//
// For delta and ratio tracking, a majorant per layer over a coarse grid of the modulation
// texture: in each cell of 8 x 8 texels, extinction * D * max(A_max - (r_min + 1 - C), 0), with
// A_max the lighting volume's largest density and r_min the smallest threshold the bilinear
// lookups in the cell can read; cells where the layer is empty cost no steps.
#pragma once

#include "nephele/api.hpp"
#include "nephele/layered.hpp"
#include "nephele/scene.hpp"

#include <string>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

class LayerVolumes {
public:
    // The layers of `scene` at time `timeSeconds` (wind), with the textures LayeredRenderer
    // would make from `settings` (its lighting and modulation settings, extentFade, and
    // cacheDir for the lighting volumes). Throws std::invalid_argument for bad settings.
    LayerVolumes(const Scene& scene, const LayeredSettings& settings, double timeSeconds);
    // With given textures, one of each per scene layer (e.g. a uniform test layer: A = 1 and r = 0
    // everywhere gives the density D C). Throws std::invalid_argument when the counts differ.
    LayerVolumes(const Scene& scene, std::vector<LightingVolume> lighting, std::vector<ModulationTexture> modulation,
                 const ModulationSettings& modulationSettings, double extentFade, double timeSeconds);

    bool empty() const { return layers_.empty(); }
    double time() const { return time_; }

    // Extinction (1/m) of all layers at world point p, their extents centred on the eye `eye`.
    double extinction(const Vec3& p, const Vec3& eye) const;

    // Bounds of the extinction along o + t d (unit d) over [t0, t1]: stretches [a, b] with
    // extinction <= bound there (summed where layers overlap); appended to `out`.
    struct Bound {
        double t0, t1;  // m
        double bound;   // 1/m
    };
    void majorant(const Vec3& o, const Vec3& d, double t0, double t1, const Vec3& eye, std::vector<Bound>& out) const;

    // Every input the extinction depends on (the layers, the channels of their textures that the
    // density reads, time, settings), as bytes for a cache key.
    std::string key() const;

    // The modulation texture and lighting volume of layer `index` (as LayeredRenderer has them).
    const ModulationTexture& modulation(int index) const { return layers_.at(std::size_t(index)).modulation; }
    const LightingVolume& lighting(int index) const { return layers_.at(std::size_t(index)).light; }
    const ModulationSettings& modulationSettings() const { return modulationSettings_; }

private:
    struct Entry {
        Layer layer;
        LightingVolume light;
        ModulationTexture modulation;
        double peakA = 0;         // the largest density A of the lighting volume
        std::vector<float> rMin;  // per coarse cell (cells x cells), the smallest r a lookup in it reads
    };
    void cellBounds(const Entry& e, const Vec3& o, const Vec3& d, double t0, double t1, std::vector<Bound>& out) const;

    ModulationSettings modulationSettings_;
    double extinction_ = 0;  // 1/m at density 1
    double extentFade_ = 0;
    double time_ = 0;
    int cells_ = 1;  // coarse cells per side of the modulation texture
    std::vector<Entry> layers_;
};

}  // namespace nephele
NEPHELE_API_END
