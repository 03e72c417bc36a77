// The layered sky's light, internal (the model: shaders/layer_light.glsl): the photon-traced
// light tables of a lighting volume, and the tables of one frame, for the scene's sun and sky.
#pragma once

#include "nephele/layered.hpp"

#include <vector>

namespace nephele {

// The optical depth (extinction x thickness at A = 1, per unit D) the precomputation gives a
// layer at most. Beyond it the knots are saturated (24.95) but near the layer's top and
// photons do not cross it, so a denser layer is lit as this one; it bounds the photons' null
// collisions (majorant x path: at 2e5, the loader's largest, 70 s for a 16x16x8 volume and 256
// photons; a layer built in code at 10^13 did not finish). Scenes at the default extinction
// (0.04/m) stay under it up to the loader's thickest layer (20 km).
inline constexpr double kMaxLightingOpticalDepth = 1000;
// The extinction (1/m) the column knots and the photons use: the medium's, capped as above.
double lightingExtinction(const LightingParameters& parameters);

// The sun's elevations (sines) the sun tables are made for.
inline constexpr float kLayerSunMu[] = {0.05f, 0.25f, 0.5f, 0.75f, 1.0f};

// Traces the volume's photons (LightingSettings::photons per source and threshold; the sun from
// each elevation of kLayerSunMu along +x, and the three sky bases) through its density at the
// thresholds 0.25, 0.5 and 0.75 with D = 1 and the medium's albedo and phase. Deterministic.
LayerLightTables traceLayerLight(const LightingVolume& volume, const std::atomic<bool>* cancel = nullptr);

// The three tables of one frame (bins x bins, node (i, j) at i + j bins), as the shader reads
// them (layerSource() in shaders/layer_light.glsl): sun = (phi0, phi1 along the sun's horizontal
// direction, phi1 z, the sky's c20) of the sunlight scattered 1 to kFewScatterings times,
// sunMany = (phi0, phi1 along the sun's horizontal direction, phi1 z, 0) of the rest, sky = (the sky's fluence rgb,
// phi1 z of its luminance), both indexed by (above, below). The sun's tables interpolated to its elevation, mirrored
// when it is below the horizon; a skylight's diffuse light added to the sun's fluence in the ratio of their luminances
// (its flux left out: a broad lobe); the sky's from the bases and the scene's colours.
struct LayerFrameTables {
    int bins = 0;
    std::vector<glm::vec4> sun, sunMany, sky;
};
LayerFrameTables layerFrameTables(const LayerLightTables& tables, const Scene& scene);

}  // namespace nephele
