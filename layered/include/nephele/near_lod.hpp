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
//   of the eye, horizontally, is made. It holds the layer's own matter (issue #10: the near
//   clouds must cover the sky as the layer does): the cell is cut into columns x columns
//   columns, each integrated through the layer's density as the shader has it (layerDensity():
//   eq. 16 with the lighting volume's A, at samples x samples points and `levels` heights); a
//   column whose mean optical depth reaches minColumnDepth becomes `stack` ellipsoids, each
//   carrying its band of the layer's height's matter (the integral of its extinction), of
//   horizontal radius overlap x the column's side, so that neighbours merge. With stack 1 the
//   ellipsoid takes the height of the column's matter: centred on its mean height, vertical
//   radius verticalSpread x its standard deviation (at most half the thickness, and kept inside
//   the layer). With stack > 1 one is centred in each band, vertical radius thickness / 2 (they
//   reach a quarter of the thickness beyond the slab). The layer's optical depth along any ray is thus
//   carried at the columns' resolution. cover = the fraction of the sample points whose column
//   has optical depth >= columnDepth (0: no cloud); `center` is the cloudy point nearest to
//   their centroid (there layerModulation() > 0). The cloud depends on the layer and (i, j)
//   alone, never on the eye: the same cell always gives the same cloud, whatever path the eye
//   took to it.
// - Wind: a cloud is made once in pattern coordinates and drawn moved by t * wind, so it
//   drifts with the layer's pattern.
// - Cache: spawned cells are kept by (layer, i, j) while they stay within reach and
//   dropped (retired) when they leave it; a cell is generated once while it stays near. When
//   the layer changes (seed, base, coverage, density, or its lighting volume: the medium or the
//   thickness), its cells are made again; given a budget (update's maxCells), at most that
//   many cells are made per update, nearest first (those made the most changes ago before them),
//   and the others keep their old cloud until their turn
//   (a cell that is new is drawn from its turn on: it enters at the reach, where its weight is 0).
// - Weights: a cloud's Cloud::weight (the fraction of its optical depth the eye sees) is
//   1 - nearFade(d), d the horizontal distance of its spawn point from the eye, while the
//   layer's own optical depth is multiplied by nearFade of each fragment's distance: the sum
//   has no seam, and a cell spawns and retires at the reach, where its weight is 0 (nothing
//   pops). Within nearRadius the clouds have weight 1 and the layer is not drawn.
// - Lighting: the compositor lights the clouds (sun through each cloud's light volume, the
//   sky's ambient), as it lights the scene's explicit clouds.
#pragma once

#include "nephele/api.hpp"
#include "nephele/layered.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <map>
#include <memory>
#include <tuple>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// Auto's defaults (`--method auto`): a helicopter sees the cumulus it can reach within a
// few km as ellipsoids and hands over to the layer across the next 1.5 km.
inline constexpr double kAutoNearRadius = 2000;  // m
inline constexpr double kAutoBlendBand = 1500;   // m
// Auto's billboard disc (LayeredSettings::lod0Radius) reaches this far beyond the blend band:
// the near radius removes the layer's billboards within it, and without billboards beyond
// it the layer seen edge-on (from inside it, or grazing) shows only the annuli's thin streaks
// instead of a wall of cloud at the horizon.
inline constexpr double kAutoLod0Margin = 1000;  // m

struct NearLodSettings {
    double cellSize = 1000;    // m, side of a cell (about a cumulus's width), > 0
    double jitter = 0.2;       // cells, largest offset of a spawn point from its cell's centre per axis, [0, 0.5)
    int columns = 4;           // ellipsoid columns per cell side, 1..16 (each carries its column of the layer)
    int stack = 1;             // ellipsoids per column, one per band of the layer's height, 1..4
    int samples = 2;           // points per column side sampled through the layer, 1..16
    int levels = 8;            // heights per point, 1..64
    double columnDepth = 0.5;  // optical depth of a point's column that counts as cloud (the cell's cover), > 0
    // A column with less optical depth on average gets no ellipsoid, >= 0. Spread over a whole
    // ellipsoid, such faint matter hazes over more of the sky than the layer's patchy matter
    // does: mean opacity along the view rays inside a layer of coverage 0.3, near clouds against
    // the layer's own, 0.411 against 0.284 at 0.02, 0.344 at 0.2, 0.300 at 0.3 (NearLodGLTest).
    double minColumnDepth = 0.3;
    // Horizontal radius of a column's ellipsoid, in columns, [0.5, 2], and (stack 1) its vertical
    // radius in standard deviations of the height of the column's matter, [1, 8] (the kernel's
    // matter has 1/3 of its radius: 3 matches that, 3.5 leaves it a little flatter). At 0.75
    // and half the thickness the near clouds' opacity missed the layer's both ways: inside
    // near_and_far.json's layer 0.805 against the volume's 0.869 (gaps between the columns, the
    // matter heaped at mid-height), inside a layer of coverage 0.4 0.718 against 0.664 (a
    // column's matter spread over the whole thickness); with these, 0.853 and 0.704 (NearLodGLTest,
    // `bench --layer-accuracy`).
    double overlap = 1.25;
    double verticalSpread = 3.5;
    double columnJitter = 0.15;  // largest random offset of a column's ellipsoid per axis, in columns, [0, 0.5]
    // Light each cell's cloud as one tile of an endless layer of copies of itself (Cloud::tileMin:
    // the neighbours' shadow and the light they send back), not as a cloud alone in clear air.
    bool tiledLight = true;
    int maxCellsPerAxis = 256;  // bound on 2 (nearRadius + blendBand) / cellSize (a setting error beyond)
};
// Throws std::invalid_argument naming the setting (NearLodSettings and the reach of `layered`).
void validate(const NearLodSettings& settings, const LayeredSettings& layered);

// One cell of one layer, as spawned.
struct NearCell {
    int layer = 0;              // index in scene.layers
    std::int64_t i = 0, j = 0;  // cell coordinates in the layer's pattern
    Vec2 spawn{0.0};            // m, spawn point in pattern coordinates (world = spawn + t * wind):
                                // reach and weight are measured from it
    double cover = 0;           // fraction of the cell's columns where the layer has cloud (0: no cloud)
    Vec2 center{0.0};           // m, the cloud's centre in pattern coordinates (a cloudy column)
    double modulation = 0;      // layerModulation at `center` (> 0 when the cell holds a cloud)
    Cloud cloud;                // in pattern coordinates (empty when cover is 0)
};

struct NearLodStats {
    int cells = 0;       // cells within reach this frame (with or without a cloud)
    int clouds = 0;      // of which hold a cloud (what was spawned)
    int ellipsoids = 0;  // the ellipsoids of those clouds
    int generated = 0;   // cells generated in this call (entered reach, or after a change of the layer)
    int retired = 0;     // cells dropped in this call (left reach)
    int fading = 0;      // clouds in the blend band (0 < weight < 1)
    int pending = 0;     // cells due to be made (new, or of a changed layer) left for later updates
};

class LayerAssets;  // internal (layered/internal/layer_assets.hpp): the layers' lighting and modulation data

// The layer's own cell: same arguments, same cloud (pure; what NearLod caches). `light` is
// the layer's lighting volume (its density A), as the layered sky uses it.
NearCell makeNearCell(const Scene& scene, int layer, std::int64_t i, std::int64_t j, const NearLodSettings& settings,
                      const ModulationTexture& modulation, const ModulationSettings& ms, const LightingVolume& light);

class NearLod {
public:
    // Throws std::invalid_argument for bad settings (validate()). The layers' lighting volumes
    // come from lightingCached(layered.lighting, ..., layered.cacheDir), the layered sky's cache.
    NearLod(NearLodSettings settings, LayeredSettings layered);
    ~NearLod();
    NearLod(const NearLod&) = delete;
    NearLod& operator=(const NearLod&) = delete;
    const NearLodSettings& settings() const { return settings_; }
    const LayeredSettings& layered() const { return layered_; }

    // The near clouds of the scene's near_lod layers for the eye at time t (world, wind
    // applied), weights set (Cloud::weight) and noise ids stable per cell; spawns the cells
    // that came within reach and retires those that left it. Clouds are ordered by (layer, i, j).
    // maxCells > 0: at most that many cells are made in this call, those made the most changes of
    // the layer ago first, then nearest first (the rest next time: NearLodStats::pending); 0: all that are due.
    // `fades` (empty, or one per scene layer in [0, 1]) multiplies each layer's clouds' weights:
    // a layer fading in or out of a weather transition, its cells made once at its own density.
    std::vector<Cloud> update(const Scene& scene, const Vec3& eye, double t, NearLodStats* stats = nullptr,
                              int maxCells = 0, const std::vector<double>& fades = {});
    // The cells cached now (after the last update), ordered by (layer, i, j).
    std::vector<const NearCell*> cells() const;
    // Takes the layers' lighting volumes and modulation textures from `assets` (SkyRenderer's,
    // shared with the layered sky and made in the background: a layer whose data is not ready
    // keeps its cells as they are and makes none) instead of its own (made in the call).
    void shareAssets(std::shared_ptr<LayerAssets> assets);

private:
    struct LayerCache;
    struct Job;
    // The layer's cache after a change of the layer or its data; the cells it has to make.
    void refreshLayer(const Scene& scene, int li, const Vec3& eye, double t, std::vector<Job>& jobs, NearLodStats& st);
    NearLodSettings settings_;
    LayeredSettings layered_;
    std::shared_ptr<LayerAssets> assets_;
    std::vector<std::unique_ptr<LayerCache>> layers_;
};

// The scene with `near` appended to its clouds (explicit clouds first, so they keep their
// indices and noise).
Scene withNearClouds(const Scene& scene, const std::vector<Cloud>& near);

}  // namespace nephele
NEPHELE_API_END
