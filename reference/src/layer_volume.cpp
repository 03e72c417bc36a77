// The layers as volumes for the path tracer (nephele/layer_volume.hpp).
#include "nephele/layer_volume.hpp"

#include "layer_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace nephele {

namespace {

constexpr int kCellTexels = 8;  // modulation texels per coarse majorant cell and side
// Bump when the layers' density or their tracking changes: part of the path tracer's cache key of
// scenes with rendered layers only (pathtrace.cpp's kVersion is left to the cloud-only references).
constexpr std::uint32_t kLayerKeyVersion = 1;

// The smallest r that a bilinear lookup inside each coarse cell can read: the cell's texels
// and a border of one (GL_LINEAR reads floor(x - 0.5) and the next texel), wrapped.
std::vector<float> thresholdMinima(const ModulationTexture& m, int cells) {
    const int n = m.size, per = n / cells;
    std::vector<float> out(std::size_t(cells) * cells);
    auto r = [&](int i, int j) { return m.texels[(std::size_t((j + n) % n) * n + std::size_t((i + n) % n)) * 2]; };
    for (int cj = 0; cj < cells; ++cj)
        for (int ci = 0; ci < cells; ++ci) {
            float lo = 1e30f;
            for (int j = cj * per - 1; j <= (cj + 1) * per; ++j)
                for (int i = ci * per - 1; i <= (ci + 1) * per; ++i) lo = std::min(lo, r(i, j));
            out[std::size_t(cj) * cells + ci] = lo;
        }
    return out;
}

class KeyBytes {
public:
    template <class T>
    KeyBytes& add(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
        return *this;
    }
    // FNV-1a of one channel of a texture's texels (`stride` bytes apart, `bytes` each).
    KeyBytes& hash(const void* data, std::size_t size, std::size_t stride, std::size_t bytes) {
        std::uint64_t h = 1469598103934665603ull;
        for (std::size_t i = 0; i + bytes <= size; i += stride)
            for (std::size_t b = 0; b < bytes; ++b)
                h = (h ^ static_cast<const unsigned char*>(data)[i + b]) * 1099511628211ull;
        return add(std::uint64_t(size)).add(h);
    }
    const std::string& bytes() const { return bytes_; }

private:
    std::string bytes_;
};

}  // namespace

namespace {
std::vector<LightingVolume> lightingVolumes(const Scene& scene, const LayeredSettings& settings) {
    validate(settings);
    std::vector<LightingVolume> out;
    for (const Layer& layer : scene.layers)
        out.push_back(lightingCached(settings.lighting, lightingParameters(scene.medium, layer), settings.cacheDir));
    return out;
}
std::vector<ModulationTexture> modulationTextures(const Scene& scene, const ModulationSettings& settings) {
    std::vector<ModulationTexture> out;
    for (const Layer& layer : scene.layers) out.push_back(makeModulation(settings, layer.seed));
    return out;
}
}  // namespace

LayerVolumes::LayerVolumes(const Scene& scene, const LayeredSettings& settings, double timeSeconds)
    : LayerVolumes(scene, lightingVolumes(scene, settings), modulationTextures(scene, settings.modulation),
                   settings.modulation, settings.extentFade, timeSeconds) {}

LayerVolumes::LayerVolumes(const Scene& scene, std::vector<LightingVolume> lighting,
                           std::vector<ModulationTexture> modulation, const ModulationSettings& modulationSettings,
                           double extentFade, double timeSeconds)
    : modulationSettings_(modulationSettings),
      extinction_(scene.medium.extinction),
      extentFade_(extentFade),
      time_(timeSeconds) {
    if (lighting.size() != scene.layers.size() || modulation.size() != scene.layers.size())
        throw std::invalid_argument("layer volumes: one lighting volume and one modulation texture per scene layer");
    if (!std::isfinite(timeSeconds)) throw std::invalid_argument("layer volumes: the time must be finite");
    if (!(extentFade >= 0 && extentFade <= 1))
        throw std::invalid_argument("layer volumes: extentFade must be in [0, 1]");
    for (std::size_t i = 0; i < scene.layers.size(); ++i) {
        const int size = modulation[i].size;
        if (size < 1 || modulation[i].texels.size() != std::size_t(size) * size * 2)
            throw std::invalid_argument("layer volumes: a modulation texture's texels do not match its size");
        if (i == 0) {
            cells_ = std::max(1, size / kCellTexels);
            while (size % cells_ != 0) --cells_;  // whole texels per cell
        } else if (size != modulation[0].size) {
            throw std::invalid_argument("layer volumes: the modulation textures differ in size");
        }
        Entry e;
        e.layer = scene.layers[i];
        e.light = std::move(lighting[i]);
        e.modulation = std::move(modulation[i]);
        for (std::size_t k = 3; k < e.light.texels.size(); k += 4)
            e.peakA = std::max(e.peakA, e.light.texels[k] / 255.0);
        e.rMin = thresholdMinima(e.modulation, cells_);
        layers_.push_back(std::move(e));
    }
}

double LayerVolumes::extinction(const Vec3& p, const Vec3& eye) const {
    double sigma = 0;
    for (const Entry& e : layers_) {
        const Layer& l = e.layer;
        if (p.z < l.base || p.z > l.base + l.thickness) continue;
        const double h = glm::length(Vec2(p.x - eye.x, p.y - eye.y));
        if (h > l.extent) continue;
        // Cheap test first, as the shader: eq. (16) is 0 wherever r >= C (A <= 1).
        if (layerModulation(l, e.modulation, modulationSettings_, p.x, p.y, time_) <= 0) continue;
        const double fade = rimFade(l, extentFade_, h);
        if (fade > 0)
            sigma += extinction_ * fade * layerDensity(l, e.modulation, modulationSettings_, e.light, p, time_);
    }
    return sigma;
}

void LayerVolumes::majorant(const Vec3& o, const Vec3& d, double t0, double t1, const Vec3& eye,
                            std::vector<Bound>& out) const {
    for (const Entry& e : layers_) {
        double a = t0, b = std::min(t1, 1e300);
        if (e.layer.density <= 0 || extinction_ <= 0 ||
            !clipToLayer(o, d, e.layer.base, e.layer.base + e.layer.thickness, eye, e.layer.extent, a, b))
            continue;
        cellBounds(e, o, d, a, b, out);
    }
}

// Walks the coarse cells that o + t d crosses over [t0, t1] (2D DDA in the wind-moved
// pattern), one bound per cell.
void LayerVolumes::cellBounds(const Entry& e, const Vec3& o, const Vec3& d, double t0, double t1,
                              std::vector<Bound>& out) const {
    const Layer& l = e.layer;
    const double scale = cells_ / modulationSettings_.period;  // cells per m
    const double ox = (o.x - time_ * l.wind.x) * scale, oy = (o.y - time_ * l.wind.y) * scale;
    const double dx = d.x * scale, dy = d.y * scale;
    auto bound = [&](double cx, double cy) {
        auto wrap = [this](double c) { return int(((std::int64_t(std::floor(c)) % cells_) + cells_) % cells_); };
        const double r = e.rMin[std::size_t(wrap(cy)) * cells_ + wrap(cx)];
        return extinction_ * l.density * std::max(e.peakA - (r + 1 - l.coverage), 0.0);
    };
    // Per axis: the t of the next cell boundary and the t between boundaries.
    auto axis = [&](double p0, double dp, double& next, double& step) {
        if (std::fabs(dp) < 1e-15) {
            next = step = 1e300;
            return;
        }
        const double p = p0 + t0 * dp;
        const double edge = dp > 0 ? std::floor(p) + 1 : std::ceil(p) - 1;
        next = t0 + (edge - p) / dp;
        step = 1 / std::fabs(dp);
    };
    double nx, sx, ny, sy;
    axis(ox, dx, nx, sx);
    axis(oy, dy, ny, sy);
    for (double t = t0; t < t1;) {
        const double end = std::min({nx, ny, t1});
        const double mid = 0.5 * (t + end);
        const double b = bound(ox + mid * dx, oy + mid * dy);
        if (b > 0 && end > t) {
            if (!out.empty() && out.back().t1 == t && out.back().bound == b) out.back().t1 = end;
            else out.push_back({t, end, b});
        }
        if (end >= t1) break;
        if (nx <= ny) nx += sx;
        else ny += sy;
        t = end;
    }
}

std::string LayerVolumes::key() const {
    KeyBytes k;
    const ModulationSettings& ms = modulationSettings_;
    k.add(kLayerKeyVersion);
    k.add(extinction_).add(extentFade_).add(time_);
    k.add(ms.size).add(ms.period).add(ms.octaves).add(ms.cells).add(ms.maxThreshold);
    k.add(layers_.size());
    for (const Entry& e : layers_) {
        const Layer& l = e.layer;
        const LightingSettings& ls = e.light.settings;
        k.add(l.base)
            .add(l.thickness)
            .add(l.coverage)
            .add(l.density)
            .add(l.wind.x)
            .add(l.wind.y)
            .add(l.extent)
            .add(l.seed);
        k.add(ls.width).add(ls.height).add(ls.depth).add(ls.tilePeriod);
        // Only what the density reads: the lighting volume's A (alpha) and the modulation's r.
        k.hash(e.light.texels.data() + 3, e.light.texels.size() - 3, 4, 1);
        k.hash(e.modulation.texels.data(), e.modulation.texels.size() * sizeof(float), 2 * sizeof(float),
               sizeof(float));
    }
    return k.bytes();
}

}  // namespace nephele
