// The 2D modulation texture (Wang et al. section 5) and the CPU twins of the shader's
// density, the near-LOD hook and the cloud shadows (19; compiled from shaders/layer_shadow.glsl).
#include "layer_model.hpp"
#include "nephele/layered.hpp"
#include "nephele/noise.hpp"
#include "parallel.hpp"

#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace nephele {

namespace {
double smoothstep(double e0, double e1, double x) {
    if (!(e1 > e0)) return x < e0 ? 0.0 : 1.0;  // a step (a rim of no width)
    const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3 - 2 * t);
}
}  // namespace

float ModulationTexture::sample(double u, double v, int c) const {
    const double x = u * size - 0.5, y = v * size - 0.5;
    const double fx = std::floor(x), fy = std::floor(y);
    const double ax = x - fx, ay = y - fy;
    auto wrap = [this](long i) { return int(((i % size) + size) % size); };
    const int x0 = wrap(long(fx)), x1 = wrap(long(fx) + 1), y0 = wrap(long(fy)), y1 = wrap(long(fy) + 1);
    auto t = [&](int i, int j) { return double(texels[(std::size_t(j) * size + i) * 2 + c]); };
    return float((1 - ay) * ((1 - ax) * t(x0, y0) + ax * t(x1, y0)) + ay * ((1 - ax) * t(x0, y1) + ax * t(x1, y1)));
}

ModulationTexture makeModulation(const ModulationSettings& s, unsigned seed) {
    if (s.size < 8 || s.size > 8192) throw std::invalid_argument("layered modulation: size must be 8..8192");
    if (s.octaves < 1 || s.octaves > 8) throw std::invalid_argument("layered modulation: octaves must be 1..8");
    if (s.cells < 1 || s.cells > 256) throw std::invalid_argument("layered modulation: cells must be 1..256");
    if (!(s.period > 0) || !(s.glowPeriod > 0))
        throw std::invalid_argument("layered modulation: periods must be > 0 m");
    if (!(s.maxThreshold > 0 && s.maxThreshold <= 1))
        throw std::invalid_argument("layered modulation: maxThreshold must be in (0, 1]");
    const int n = s.size;
    const int glowCells = std::max(1, int(std::lround(s.period / s.glowPeriod)));
    std::vector<float> noise(std::size_t(n) * n), city(std::size_t(n) * n);
    parallelFor(n, [&](int j) {
        for (int i = 0; i < n; ++i) {
            const double u = (i + 0.5) / n, v = (j + 0.5) / n;
            noise[std::size_t(j) * n + i] =
                fbm(glm::vec3(float(u * s.cells), float(v * s.cells), 0.5f), s.octaves, s.cells, seed);
            const double c =
                fbm(glm::vec3(float(u * glowCells), float(v * glowCells), 3.5f), 3, glowCells, seed ^ 0x9E3779B9u);
            city[std::size_t(j) * n + i] = float(smoothstep(0.1, 0.4, c));
        }
    });
    // Histogram equalisation: r is the rank of the fBm value, so that r is uniform on
    // [0, maxThreshold] and the area where C - r > 0 (cloud at the density's peak) is C / maxThreshold.
    std::vector<std::uint32_t> order(noise.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return noise[a] < noise[b]; });
    ModulationTexture m;
    m.size = n;
    m.texels.resize(noise.size() * 2);
    for (std::size_t rank = 0; rank < order.size(); ++rank) {
        m.texels[std::size_t(order[rank]) * 2] = float(double(rank) / double(order.size() - 1) * s.maxThreshold);
        m.texels[std::size_t(order[rank]) * 2 + 1] = city[order[rank]];
    }
    return m;
}

void validate(const LayeredSettings& s) {
    validate(s.background);
    auto bad = [](const std::string& what) { throw std::invalid_argument("layered settings: " + what); };
    if (s.layers < 2 || s.layers > 1024) bad("layers (N) must be 2..1024, got " + std::to_string(s.layers));
    if (!(s.lod0Radius >= 0)) bad("lod0Radius must be >= 0 m");
    if (!(s.lod0Spacing > 0)) bad("lod0Spacing must be > 0 m");
    if (!(s.lod0Radius / s.lod0Spacing <= kMaxBillboardSlices))
        bad("lod0Radius / lod0Spacing must be <= " + std::to_string(kMaxBillboardSlices) + " (billboard slices)");
    if (!(s.extentFade >= 0 && s.extentFade <= 1)) bad("extentFade must be in [0, 1]");
    if (!(s.nearRadius >= 0)) bad("nearRadius must be >= 0 m");
    if (!(s.blendBand >= 0)) bad("blendBand must be >= 0 m");
    if (s.segments < 8 || s.segments > 4096) bad("segments must be 8..4096");
    if (s.downsample < 1 || s.downsample > 4) bad("downsample must be 1..4, got " + std::to_string(s.downsample));
    if (s.reusePeriod < 1 || s.reusePeriod > 16) bad("reusePeriod must be 1..16, got " + std::to_string(s.reusePeriod));
    if (!(s.reuseError > 0 && s.reuseError <= 1000)) bad("reuseError must be in (0, 1000] reduced pixels");
    if (!std::isfinite(s.glowHeight)) bad("glowHeight must be finite");
    if (s.resourceMegabytes < 1 || s.resourceMegabytes > 65536) bad("resourceMegabytes must be 1..65536");
}

double nearFade(const LayeredSettings& s, double horizontal) {
    if (horizontal < s.nearRadius) return 0;
    if (s.blendBand <= 0) return 1;
    return smoothstep(s.nearRadius, s.nearRadius + s.blendBand, horizontal);
}

double rimFade(const Layer& layer, double extentFade, double horizontal) {
    return 1 - smoothstep(layer.extent * (1 - extentFade), layer.extent, horizontal);
}

namespace {
double threshold(const Layer& layer, const ModulationTexture& m, const ModulationSettings& ms, double x, double y,
                 double t) {
    const Vec2 drift = layerDrift(layer, t);
    return m.sample((x - drift.x) / ms.period, (y - drift.y) / ms.period, 0);
}
}  // namespace

double layerModulation(const Layer& layer, const ModulationTexture& m, const ModulationSettings& ms, double x, double y,
                       double t) {
    return layer.density * std::max(layer.coverage - threshold(layer, m, ms, x, y, t), 0.0);
}

double layerDensity(const Layer& layer, const ModulationTexture& m, const ModulationSettings& ms,
                    const LightingVolume& light, const Vec3& p, double t) {
    const double z = (p.z - layer.base) / layer.thickness;
    if (z < 0 || z > 1) return 0;
    const double period = light.settings.tilePeriod;
    const Vec2 drift = layerDrift(layer, t);
    const double a = light.sampleDensity((p.x - drift.x) / period, (p.y - drift.y) / period, z);
    const double r = threshold(layer, m, ms, p.x, p.y, t);
    return layer.density * std::max(a - (r + 1 - layer.coverage), 0.0);  // eq. (16)
}

double layerDensityIntegral(const Layer& layer, const ModulationTexture& m, const ModulationSettings& ms,
                            const LightingVolume& light, const Vec3& o, const Vec3& d, double reach, double t,
                            double step, int maxSteps) {
    double t0 = 0, t1 = reach / std::max(std::hypot(d.x, d.y), 1e-12);
    if (std::abs(d.z) > 1e-12) {
        double a = (layer.base - o.z) / d.z, b = (layer.base + layer.thickness - o.z) / d.z;
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a), t1 = std::min(t1, b);
    } else if (o.z < layer.base || o.z > layer.base + layer.thickness) {
        return 0;
    }
    if (!(t1 > t0)) return 0;
    const int steps = std::clamp(int(std::ceil((t1 - t0) / step)), 1, maxSteps);
    const double dt = (t1 - t0) / steps;
    double sum = 0;
    for (int i = 0; i < steps; ++i) sum += layerDensity(layer, m, ms, light, o + d * (t0 + (i + 0.5) * dt), t);
    return sum * dt;
}

double sunTransmittance(const Layer& layer, const ModulationTexture& m, const ModulationSettings& ms, const Vec3& sun,
                        const Vec3& p, double t) {
    if (sun.z <= 0) return 1;  // no shadow pass either (ShadowPass::shadowingLayers)
    // shaders/layer_shadow.glsl in float, as the shadow pass; the point in double (world, not
    // relative to an eye).
    const float h = float(p.z), mid = float(layer.base + 0.5 * layer.thickness);
    const glm::dvec2 q = glm::dvec2(p.x, p.y) + glm::dvec2(model::shadowRayOffset(glm::vec3(sun), h, mid));
    const float r = float(threshold(layer, m, ms, q.x, q.y, t));
    return model::layerShadow(h, mid, r, float(layer.coverage), float(layer.density));
}

double groundSunShare(const Sun& sun, const Sky& sky) {
    auto luminance = [](const Vec3& c) { return glm::dot(c, Vec3(model::kLuminance)); };
    const double eSun = luminance(sun.color) * sun.intensity * std::max(sun.direction.z, 0.0);
    const double eSky = std::max(glm::pi<double>() * luminance(sky.horizon) +
                                     2 * glm::pi<double>() / 3 * (luminance(sky.zenith) - luminance(sky.horizon)),
                                 0.0);
    return eSun + eSky > 0 ? eSun / (eSun + eSky) : 0;
}

}  // namespace nephele
