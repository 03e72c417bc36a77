// The near LOD: cells of a layer's pattern spawned as Gaussian cumulus near the eye
// (nephele/near_lod.hpp).
#include "nephele/near_lod.hpp"

#include "layer_assets.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace nephele {

namespace {

std::uint64_t mix(std::uint64_t x) {  // SplitMix64's finaliser
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

// A hash of (layer seed, i, j, salt): the only inputs of a cell.
std::uint64_t cellHash(unsigned seed, std::int64_t i, std::int64_t j, std::uint64_t salt) {
    std::uint64_t h = mix(std::uint64_t(seed) ^ (salt << 40));
    h = mix(h ^ std::uint64_t(i));
    return mix(h ^ std::uint64_t(j) * 0xD6E8FEB86659FD93ull);
}

double unit(std::uint64_t h) { return double(h >> 11) * 0x1.0p-53; }  // [0, 1)

Vec2 spawnPoint(unsigned seed, std::int64_t i, std::int64_t j, const NearLodSettings& s) {
    const double jx = (2 * unit(cellHash(seed, i, j, 1)) - 1) * s.jitter;
    const double jy = (2 * unit(cellHash(seed, i, j, 2)) - 1) * s.jitter;
    return Vec2((double(i) + 0.5 + jx) * s.cellSize, (double(j) + 0.5 + jy) * s.cellSize);
}

double reach(const LayeredSettings& l) { return l.nearRadius + l.blendBand; }

}  // namespace

void validate(const NearLodSettings& s, const LayeredSettings& l) {
    auto bad = [](const std::string& what) { throw std::invalid_argument("near LOD settings: " + what); };
    if (!(s.cellSize > 0) || !std::isfinite(s.cellSize)) bad("cellSize must be > 0 m");
    if (!(s.jitter >= 0 && s.jitter < 0.5)) bad("jitter must be in [0, 0.5) cells");
    if (s.columns < 1 || s.columns > 16) bad("columns must be 1..16, got " + std::to_string(s.columns));
    if (s.stack < 1 || s.stack > 4) bad("stack must be 1..4, got " + std::to_string(s.stack));
    if (s.samples < 1 || s.samples > 16) bad("samples must be 1..16, got " + std::to_string(s.samples));
    if (s.levels < 1 || s.levels > 64 || s.levels % s.stack != 0)
        bad("levels must be 1..64 and a multiple of stack, got " + std::to_string(s.levels));
    if (!(s.columnDepth > 0) || !std::isfinite(s.columnDepth)) bad("columnDepth must be > 0");
    if (!(s.minColumnDepth >= 0) || !std::isfinite(s.minColumnDepth)) bad("minColumnDepth must be >= 0");
    if (!(s.overlap >= 0.5 && s.overlap <= 2)) bad("overlap must be in [0.5, 2] columns");
    if (!(s.verticalSpread >= 1 && s.verticalSpread <= 8)) bad("verticalSpread must be in [1, 8] standard deviations");
    if (!(s.columnJitter >= 0 && s.columnJitter <= 0.5)) bad("columnJitter must be in [0, 0.5] columns");
    if (s.maxCellsPerAxis < 1 || s.maxCellsPerAxis > 4096) bad("maxCellsPerAxis must be 1..4096");
    validate(l);
    if (!std::isfinite(reach(l))) bad("nearRadius + blendBand must be finite");
    if (2 * reach(l) / s.cellSize > s.maxCellsPerAxis)
        bad("2 (nearRadius + blendBand) / cellSize = " + std::to_string(2 * reach(l) / s.cellSize) +
            " cells per axis exceeds " + std::to_string(s.maxCellsPerAxis) +
            "; raise cellSize or lower the near radius / blend band");
}

namespace {
// The matter of the kernel (1 - r^2)^2 over the unit ball, the ellipsoids' density profile
// (gardner_model.glsl): 4 pi (1/3 - 2/5 + 1/7) = 32 pi / 105.
constexpr double kKernelVolume = 32 * 3.14159265358979323846 / 105;

// Per level of the stack an ellipsoid of horizontal radius `overlap` w carrying the band's
// matter: d kKernelVolume R^2 Rz = mean w^2 thickness / stack. With stack 1 it takes the height of
// the column's matter (the kernel's matter over height, (1 - z^2)^3, has a deviation of Rz / 3):
// centred on its mean, Rz = verticalSpread deviations, kept inside the layer; with more, centred
// in its band, Rz half the thickness (neighbours in the stack overlap as in the row). m0, m1, m2:
// the moments of the column's matter over height above the base.
struct ColumnAt {
    std::int64_t i, j;  // the cell
    int a, b;           // the column in it
};
void addColumnEllipsoids(Cloud& cloud, const Layer& layer, const NearLodSettings& s, ColumnAt at,
                         const std::vector<double>& mean, double m0, double m1, double m2) {
    const int stack = s.stack;
    const double w = s.cellSize / s.columns, dz = layer.thickness / s.levels;
    const double radius = s.overlap * w;
    const bool fitted = stack == 1 && m0 > 0;
    double rz = 0.5 * layer.thickness, cz = 0;
    if (fitted) {
        const double mu = m1 / m0, deviation = std::sqrt(std::max(m2 / m0 - mu * mu, 0.0));
        rz = std::clamp(s.verticalSpread * deviation, 0.5 * dz, 0.5 * layer.thickness);
        cz = std::clamp(mu, rz, layer.thickness - rz);
    }
    for (int k = 0; k < stack; ++k) {
        if (!(mean[std::size_t(k)] > 0)) continue;
        Ellipsoid e;
        // Each column's centre moved at random by up to `columnJitter` w per axis: rows of
        // ellipsoids in line leave straight lanes of thinner matter between them, which show as
        // lines converging on the vanishing point when the eye looks along them.
        const std::uint64_t h = cellHash(layer.seed, at.i, at.j, 16 + std::uint64_t(at.b * s.columns + at.a));
        const Vec2 shake = s.columnJitter * w * (2.0 * Vec2(unit(h), unit(mix(h))) - 1.0);
        e.center = Vec3(double(at.i) * s.cellSize + (at.a + 0.5) * w + shake.x,
                        double(at.j) * s.cellSize + (at.b + 0.5) * w + shake.y,
                        layer.base + (fitted ? cz : (k + 0.5) / stack * layer.thickness));
        e.radii = Vec3(radius, radius, rz);
        e.density = mean[std::size_t(k)] * w * w * layer.thickness / (stack * kKernelVolume * radius * radius * rz);
        cloud.ellipsoids.push_back(e);
    }
}
}  // namespace

NearCell makeNearCell(const Scene& scene, int li, std::int64_t i, std::int64_t j, const NearLodSettings& s,
                      const ModulationTexture& modulation, const ModulationSettings& ms, const LightingVolume& light) {
    const Layer& layer = scene.layers.at(std::size_t(li));
    NearCell cell;
    cell.layer = li, cell.i = i, cell.j = j;
    cell.spawn = spawnPoint(layer.seed, i, j, s);
    cell.cloud.name = "near" + std::to_string(li) + "(" + std::to_string(i) + "," + std::to_string(j) + ")";
    cell.cloud.noiseId = cellHash(layer.seed, i, j, 3) | 1;  // never 0 ("the cloud's index")
    if (s.tiledLight) {
        cell.cloud.tileMin = Vec2(double(i), double(j)) * s.cellSize;
        cell.cloud.tileMax = cell.cloud.tileMin + s.cellSize;
    }
    // The layer's matter over the cell, column by column (pattern coordinates are the world at
    // t = 0): columns x columns columns of side w, each sampled at samples x samples points
    // and `levels` heights: its mean density (eq. 16) and its optical depth.
    const int n = s.columns, m = s.samples, stack = s.stack;
    const double w = s.cellSize / n, dz = layer.thickness / s.levels;
    std::vector<Vec2> cloudy;
    std::vector<double> mean(static_cast<std::size_t>(stack));  // per level of the stack: the mean density there
    for (int b = 0; b < n; ++b)
        for (int a = 0; a < n; ++a) {
            std::fill(mean.begin(), mean.end(), 0.0);
            double m0 = 0, m1 = 0, m2 = 0;  // the column's matter over height above the base: its moments
            for (int y = 0; y < m; ++y)
                for (int x = 0; x < m; ++x) {
                    const Vec2 xy(double(i) * s.cellSize + (a + (x + 0.5) / m) * w,
                                  double(j) * s.cellSize + (b + (y + 0.5) / m) * w);
                    double tau = 0;
                    for (int k = 0; k < s.levels; ++k) {
                        const double rho =
                            layerDensity(layer, modulation, ms, light, Vec3(xy, layer.base + (k + 0.5) * dz), 0);
                        tau += rho;
                        const double z = (k + 0.5) * dz;
                        m0 += rho, m1 += rho * z, m2 += rho * z * z;
                        mean[std::size_t(k * stack / s.levels)] += rho * stack / (double(s.levels) * m * m);
                    }
                    if (scene.medium.extinction * tau * dz >= s.columnDepth) cloudy.push_back(xy);
                }
            double columnMean = 0;
            for (double v : mean) columnMean += v / stack;
            if (!(scene.medium.extinction * columnMean * layer.thickness >= s.minColumnDepth)) continue;
            addColumnEllipsoids(cell.cloud, layer, s, {i, j, a, b}, mean, m0, m1, m2);
        }
    cell.cover = double(cloudy.size()) / (double(n) * n * m * m);
    if (cloudy.empty()) {
        cell.cloud.ellipsoids.clear();  // only faint matter: nothing that counts as cloud
        return cell;
    }
    Vec2 centroid(0.0);
    for (const Vec2& c : cloudy) centroid += c / double(cloudy.size());
    cell.center = *std::min_element(cloudy.begin(), cloudy.end(), [&](const Vec2& a, const Vec2& b) {
        return glm::length(a - centroid) < glm::length(b - centroid);
    });
    cell.modulation = layerModulation(layer, modulation, ms, cell.center.x, cell.center.y, 0);
    return cell;
}

// One layer's cells and the state of the layer they were made for.
struct NearLod::LayerCache {
    struct Made {  // what a cell's cloud depends on besides (i, j)
        unsigned seed = 0;
        double base = 0, coverage = 0, density = 0;
        LightingParameters lightKey;
        bool operator==(const Made&) const = default;
    };
    Made made;        // the layer as its current data is for
    int version = 0;  // bumped when `made`, the modulation or the light change: older cells are stale
    std::shared_ptr<const ModulationTexture> modulation;
    std::shared_ptr<const LightingVolume> light;
    struct Cell {
        NearCell cell;
        int version = 0;
    };
    std::map<std::pair<std::int64_t, std::int64_t>, Cell> cells;
};

struct NearLod::Job {
    double distance = 0;  // of the spawn point from the eye (m): nearest first
    int layer = 0;
    std::int64_t i = 0, j = 0;
    int behind = 1;  // changes of the layer since the cell was made: most first
};

NearLod::NearLod(NearLodSettings settings, LayeredSettings layered)
    : settings_(settings), layered_(std::move(layered)), assets_(std::make_shared<LayerAssets>(layered_)) {
    validate(settings_, layered_);
}

NearLod::~NearLod() = default;

void NearLod::shareAssets(std::shared_ptr<LayerAssets> assets) { assets_ = std::move(assets); }

void NearLod::refreshLayer(const Scene& scene, int li, const Vec3& eye, double t, std::vector<Job>& jobs,
                           NearLodStats& st) {
    const Layer& layer = scene.layers[li];
    LayerCache& c = *layers_[li];
    const double r = reach(layered_), size = settings_.cellSize, jit = settings_.jitter;
    const LayerCache::Made made{layer.seed, layer.base, layer.coverage, layer.density,
                                lightingParameters(scene.medium, layer)};
    // While the layer's own data is made, the nearest made (as the layered sky draws it).
    std::shared_ptr<const ModulationTexture> modulation = assets_->nearestModulation(layer.seed);
    std::shared_ptr<const LightingVolume> light = assets_->nearestLighting(made.lightKey);
    const bool ready = modulation && light;  // else: the cells stay as they are, none is made
    if (ready && (!(made == c.made) || modulation != c.modulation || light != c.light)) {
        c.made = made, c.modulation = std::move(modulation), c.light = std::move(light);
        ++c.version;
    }
    const Vec2 e = Vec2(eye.x, eye.y) - layerDrift(layer, t);  // the eye in pattern coordinates
    // Spawn points lie within jitter cells of their cell's centre.
    const auto i0 = std::int64_t(std::floor((e.x - r) / size - 0.5 - jit)),
               i1 = std::int64_t(std::ceil((e.x + r) / size - 0.5 + jit));
    const auto j0 = std::int64_t(std::floor((e.y - r) / size - 0.5 - jit)),
               j1 = std::int64_t(std::ceil((e.y + r) / size - 0.5 + jit));
    std::map<std::pair<std::int64_t, std::int64_t>, LayerCache::Cell> next;
    for (std::int64_t j = j0; j <= j1; ++j)
        for (std::int64_t i = i0; i <= i1; ++i) {
            const double distance = glm::length(spawnPoint(layer.seed, i, j, settings_) - e);
            if (distance >= r) continue;
            auto old = c.cells.find({i, j});
            const bool have = old != c.cells.end();
            if (have) {
                next.emplace(old->first, std::move(old->second));
                c.cells.erase(old);
            }
            // A new cell counts as one change behind: after one change the cells due are made
            // nearest first; while a layer keeps changing (a weather transition) the cells made
            // longest ago go first, so that each is made again in turn.
            const int behind = have ? c.version - next[{i, j}].version : 1;
            if (c.light && behind != 0) jobs.push_back({distance, li, i, j, behind});
        }
    st.retired += int(c.cells.size());
    c.cells = std::move(next);
}

std::vector<Cloud> NearLod::update(const Scene& scene, const Vec3& eye, double t, NearLodStats* stats, int maxCells,
                                   const std::vector<double>& fades) {
    if (!fades.empty() && fades.size() != scene.layers.size())
        throw std::invalid_argument("NearLod::update: one fade per layer, or none");
    NearLodStats st;
    const std::size_t before = layers_.size();
    for (std::size_t li = scene.layers.size(); li < before; ++li) st.retired += int(layers_[li]->cells.size());
    layers_.resize(scene.layers.size());
    std::vector<Job> jobs;
    for (std::size_t li = 0; li < scene.layers.size(); ++li) {
        if (!layers_[li]) layers_[li] = std::make_unique<LayerCache>();
        if (!scene.layers[li].nearLod || !(reach(layered_) > 0)) {
            st.retired += int(layers_[li]->cells.size());
            layers_[li]->cells.clear();
            continue;
        }
        refreshLayer(scene, int(li), eye, t, jobs, st);
    }
    // The cells due, nearest first, as many as the budget allows.
    std::stable_sort(jobs.begin(), jobs.end(), [](const Job& a, const Job& b) {
        return a.behind != b.behind ? a.behind > b.behind : a.distance < b.distance;
    });
    const std::size_t budget = maxCells > 0 ? std::size_t(maxCells) : jobs.size();
    for (std::size_t k = 0; k < std::min(budget, jobs.size()); ++k) {
        const Job& job = jobs[k];
        LayerCache& c = *layers_[job.layer];
        c.cells[{job.i, job.j}] = {
            makeNearCell(scene, job.layer, job.i, job.j, settings_, *c.modulation, layered_.modulation, *c.light),
            c.version};
        ++st.generated;
    }
    st.pending = int(jobs.size() - std::min(budget, jobs.size()));
    // The clouds: made cells in (layer, i, j) order, moved with the wind, weighted by distance.
    std::vector<Cloud> out;
    for (std::size_t li = 0; li < layers_.size(); ++li) {
        const Layer& layer = scene.layers[li];
        const Vec2 drift = layerDrift(layer, t);
        const Vec2 e = Vec2(eye.x, eye.y) - drift;
        const double fade = fades.empty() ? 1.0 : fades[li];
        for (const auto& [ij, made] : layers_[li]->cells) {
            const NearCell& cell = made.cell;
            ++st.cells;
            if (cell.cloud.ellipsoids.empty()) continue;
            Cloud cloud = cell.cloud;
            cloud.weight = (1 - nearFade(layered_, glm::length(cell.spawn - e))) * fade;
            for (Ellipsoid& el : cloud.ellipsoids) el.center += Vec3(drift, 0.0);
            if (cloud.tiled()) cloud.tileMin += drift, cloud.tileMax += drift;
            ++st.clouds;
            st.ellipsoids += int(cloud.ellipsoids.size());
            st.fading += cloud.weight > 0 && cloud.weight < 1;
            out.push_back(std::move(cloud));
        }
    }
    if (stats) *stats = st;
    return out;
}

std::vector<const NearCell*> NearLod::cells() const {
    std::vector<const NearCell*> out;
    for (const auto& c : layers_)
        if (c)
            for (const auto& [ij, made] : c->cells) out.push_back(&made.cell);
    return out;
}

Scene withNearClouds(const Scene& scene, const std::vector<Cloud>& near) {
    Scene s = scene;
    s.clouds.insert(s.clouds.end(), near.begin(), near.end());
    return s;
}

}  // namespace nephele
