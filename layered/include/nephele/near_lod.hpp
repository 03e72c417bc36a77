// The near LOD of the layered sky (issue #5): near the eye, a layer with `near_lod: true` is
// drawn as ellipsoid cumulus clouds (the compositor, nephele/ellipsoid.hpp) instead of its
// annuli and billboards, with a blend band between the two.
//
// - Cells: the layer's pattern (its modulation texture, which the wind moves: texture
//   coordinates are (x, y) - t * wind) is cut into square cells of `cellSize` metres. Cell
//   (i, j) covers pattern coordinates [i, i + 1) x [j, j + 1) * cellSize. Its spawn point is
//   the cell's centre moved by a jitter of at most `jitter` cells per axis, so that the grid
//   does not show.
// - Spawning: a cell whose spawn point lies within nearRadius + blendBand (LayeredSettings)
//   of the eye, horizontally, holds a cloud if layerModulation() is > 0 there. The cloud is a
//   Gaussian cumulus (generateCumulus, Jimenez de Parga eqs. 14-17) whose seed comes from the
//   layer's seed and (i, j) alone, never from the eye: the same cell always gives the same
//   cloud, whatever path the eye took to it. Its size follows the local modulation m:
//   strength q = m / (D * C) in (0, 1] (D, C the layer's density and coverage; D * C is
//   the largest m), the cloud's width 2 * halfWidth(q) (see NearLodSettings), its height
//   thickness * (minHeight + (1 - minHeight) q), its base on the layer's base and its top
//   within the layer; ellipsoid density = the layer's D.
// - Wind: a cloud is made once in pattern coordinates and drawn moved by t * wind, so it
//   drifts with the layer's pattern.
// - Cache: spawned cells are kept by (layer, i, j) while they stay within reach and
//   dropped (retired) when they leave it; a cell is generated once while it stays near.
// - Weights: a cloud's Cloud::weight (the fraction of its optical depth the eye sees) is
//   1 - nearFade(d), d the horizontal distance of its spawn point from the eye, while the
//   layer's own optical depth is multiplied by nearFade of each fragment's distance: the sum
//   has no seam, and a cell spawns and retires at the reach, where its weight is 0 (nothing
//   pops). Within nearRadius the clouds have weight 1 and the layer is not drawn.
// - Lighting: the compositor lights the clouds (sun through each cloud's light volume, the
//   sky's ambient), as it lights the scene's explicit clouds.
#pragma once

#include "nephele/layered.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <map>
#include <memory>
#include <tuple>
#include <vector>

namespace nephele {

// Auto's defaults (`--method auto`): a helicopter sees the cumulus it can reach within a
// few km as ellipsoids and hands over to the layer across the next 1.5 km.
inline constexpr double kAutoNearRadius = 2000;  // m
inline constexpr double kAutoBlendBand = 1500;   // m

struct NearLodSettings {
    double cellSize = 1000;     // m, side of a cell (about a cumulus's width), > 0
    double jitter = 0.2;        // cells, largest offset of a spawn point from its cell's centre per axis, [0, 0.5)
    int ellipsoids = 40;        // cumulus `count` at full strength (q = 1), 1..1000; at least 4 at any q
    double minWidth = 0.6;      // cloud width at q -> 0, as a fraction of cellSize, (0, maxWidth]
    double maxWidth = 1.4;      // cloud width at q = 1, as a fraction of cellSize, <= 1.5 (> 1: neighbours merge)
    double minHeight = 0.4;     // cloud height at q -> 0, as a fraction of the layer's thickness, (0, 1]
    int maxCellsPerAxis = 256;  // bound on 2 (nearRadius + blendBand) / cellSize (a setting error beyond)
};
// Throws std::invalid_argument naming the setting (NearLodSettings and the reach of `layered`).
void validate(const NearLodSettings& settings, const LayeredSettings& layered);

// One cell of one layer, as spawned.
struct NearCell {
    int layer = 0;               // index in scene.layers
    std::int64_t i = 0, j = 0;   // cell coordinates in the layer's pattern
    Vec2 spawn{0.0};             // m, spawn point in pattern coordinates (world = spawn + t * wind)
    double modulation = 0;       // layerModulation at the spawn point (0: the cell holds no cloud)
    Cloud cloud;                 // in pattern coordinates (empty when modulation is 0)
};

struct NearLodStats {
    int cells = 0;         // cells within reach this frame (with or without a cloud)
    int clouds = 0;        // of which hold a cloud (what was spawned)
    int ellipsoids = 0;    // the ellipsoids of those clouds
    int generated = 0;     // cells generated in this call (entered reach, or after a change of the layer)
    int retired = 0;       // cells dropped in this call (left reach)
    int fading = 0;        // clouds in the blend band (0 < weight < 1)
};

// The layer's own cell: same arguments, same cloud (pure; what NearLod caches).
NearCell makeNearCell(const Scene& scene, int layer, std::int64_t i, std::int64_t j, const NearLodSettings& settings,
                      const ModulationTexture& modulation, const ModulationSettings& ms);

class NearLod {
public:
    // Throws std::invalid_argument for bad settings (validate()).
    NearLod(NearLodSettings settings, LayeredSettings layered);
    ~NearLod();
    NearLod(const NearLod&) = delete;
    NearLod& operator=(const NearLod&) = delete;
    const NearLodSettings& settings() const { return settings_; }
    const LayeredSettings& layered() const { return layered_; }

    // The near clouds of the scene's near_lod layers for the eye at time t (world, wind
    // applied), weights set (Cloud::weight) and noise ids stable per cell; spawns the cells
    // that came within reach and retires those that left it. Clouds are ordered by (layer, i, j).
    std::vector<Cloud> update(const Scene& scene, const Vec3& eye, double t, NearLodStats* stats = nullptr);
    // The cells cached now (after the last update), ordered by (layer, i, j).
    std::vector<const NearCell*> cells() const;

private:
    struct LayerCache;
    NearLodSettings settings_;
    LayeredSettings layered_;
    std::vector<std::unique_ptr<LayerCache>> layers_;
};

// The scene with `near` appended to its clouds (explicit clouds first, so they keep their
// indices and noise).
Scene withNearClouds(const Scene& scene, const std::vector<Cloud>& near);

}  // namespace nephele
