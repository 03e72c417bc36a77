// The layered sky's light tables (layer_light.hpp): photons traced through the lighting volume's
// density with the path tracer's physics, scored by the column depths of their collisions.
#include "layer_light.hpp"

#include "layer_model.hpp"
#include "nephele/cloud_radiance.hpp"
#include "phase_sampling.hpp"

#include "parallel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

namespace nephele {

namespace {

constexpr int kBatch = 256;       // photons per deterministic batch
constexpr int kMaxEvents = 2000;  // scatterings per photon at most

using Rng = detail::PhotonRng;
using detail::sampleHg;

// The layer at one threshold (D = 1): a horizontally periodic slab z in [0, height].
struct ThresholdMedium {
    const LightingVolume& volume;
    double theta, period, height, extinction, majorant;
    double sigma(const Vec3& p) const {
        return extinction * std::max(volume.sampleDensity(p.x / period, p.y / period, p.z / height) - theta, 0.0);
    }
    glm::dvec2 coords(const Vec3& p) const {  // table coordinates of the point's column depths
        const glm::dvec2 t = volume.columnDepths(p.x / period, p.y / period, p.z / height, theta, 1.0);
        return {model::layerTableCoord(float(t.x)), model::layerTableCoord(float(t.y))};
    }
};

// Adds `value` to the four nodes around table coordinates u (bilinear weights), as GL_LINEAR
// with clamp-to-edge reads them back.
void deposit(std::vector<glm::dvec4>& grid, int bins, const glm::dvec2& u, const glm::dvec4& value) {
    const double x = std::clamp(u.x * bins - 0.5, 0.0, bins - 1.0), y = std::clamp(u.y * bins - 0.5, 0.0, bins - 1.0);
    const int i0 = std::min(int(x), bins - 2), j0 = std::min(int(y), bins - 2);  // bins >= 4
    const double fx = x - i0, fy = y - j0;
    grid[std::size_t(j0) * bins + i0] += (1 - fx) * (1 - fy) * value;
    grid[std::size_t(j0) * bins + i0 + 1] += fx * (1 - fy) * value;
    grid[std::size_t(j0 + 1) * bins + i0] += (1 - fx) * fy * value;
    grid[std::size_t(j0 + 1) * bins + i0 + 1] += fx * fy * value;
}

// A light source's photons: where they enter and which way they travel.
struct Source {
    enum Kind { Sun, SkyUniform, SkyZenith, Ground } kind;
    double mu = 1;  // the sun's elevation (sine)
    // Power per unit horizontal area entering the layer per unit irradiance (sun) or radiance (sky).
    double flux() const { return kind == Sun ? mu : kind == SkyZenith ? 2 * std::numbers::pi / 3 : std::numbers::pi; }
    void emit(const ThresholdMedium& m, Rng& rng, Vec3& x, Vec3& w) const {
        const double phi = 2 * std::numbers::pi * rng.uniform();
        // Drawn one by one: the order of a call's arguments is the compiler's (GCC's right to left
        // is kept, so that Clang's build draws the same photons).
        const double y = rng.uniform();
        x = Vec3(m.period * rng.uniform(), m.period * y, kind == Ground ? 0.0 : m.height);
        double cz;  // |w.z|: the sun's elevation; cosine-weighted (radiance 1); weighted by cos^2 (radiance d.z)
        if (kind == Sun) cz = mu;
        else if (kind == SkyZenith) cz = std::cbrt(rng.uniform());
        else cz = std::sqrt(rng.uniform());
        const double sz = std::sqrt(std::max(0.0, 1 - cz * cz));
        w = kind == Sun ? Vec3(-sz, 0, -cz) : Vec3(sz * std::cos(phi), sz * std::sin(phi), kind == Ground ? cz : -cz);
    }
};

// One photon: free flights by delta tracking under the medium's constant majorant; at each
// collision (but the sun's first, its direct light, which single scattering carries) scores its
// weight and direction of travel; then albedo and a Henyey-Greenstein turn. Russian roulette
// below weight 0.05.
template <class Score>  // score(x, w, weight, scatterings so far)
void tracePhoton(const ThresholdMedium& m, const Source& source, double albedo, double g, Rng& rng, Score&& score) {
    Vec3 x, w;
    source.emit(m, rng, x, w);
    double weight = 1;
    for (int event = 0; event < kMaxEvents; ++event) {
        for (;;) {
            x += w * (-std::log(rng.uniform()) / m.majorant);
            if (x.z < 0 || x.z > m.height) return;
            if (rng.uniform() * m.majorant < m.sigma(x)) break;
        }
        if (event > 0 || source.kind != Source::Sun) score(x, w, weight, event);
        weight *= albedo;
        if (weight < 0.05) {
            if (rng.uniform() < 0.5) return;
            weight *= 2;
        }
        w = sampleHg(w, g, rng);
    }
}

// The scores of one source over all thresholds: sum of weight x (1, w.x, w.z, Y20(w)) per node,
// of the light scattered 1 to kFewScatterings times (first) and more often (second): at its
// collision `event` a sun photon's light has scattered `event` times. (The sky's tables take
// the two together.)
struct Scores {
    std::vector<glm::dvec4> few, many;
};
// With `cancel` set, the batches not yet begun are skipped and LightingCancelled thrown.
Scores traceSource(const std::vector<ThresholdMedium>& media, const Source& source, const LightingVolume& v,
                   std::uint64_t seed, const std::atomic<bool>* cancel) {
    const int bins = v.settings.tableBins, batches = std::max(1, v.settings.photons / kBatch);
    std::vector<Scores> perBatch(std::size_t(batches) * media.size());
    parallelFor(int(perBatch.size()), [&](int b) {
        if (cancel && *cancel) return;
        const ThresholdMedium& m = media[std::size_t(b) / batches];
        std::vector<glm::dvec4>& few = perBatch[std::size_t(b)].few;
        std::vector<glm::dvec4>& many = perBatch[std::size_t(b)].many;
        few.assign(std::size_t(bins) * bins, glm::dvec4(0.0));
        many.assign(std::size_t(bins) * bins, glm::dvec4(0.0));
        Rng rng = Rng::fromState(seed * 1000003ull + std::uint64_t(b));
        for (int k = 0; k < kBatch; ++k)
            tracePhoton(m, source, v.parameters.albedo, v.parameters.csG, rng,
                        [&](const Vec3& x, const Vec3& w, double weight, int scatterings) {
                            const double y20 = model::kY20 * (3 * w.z * w.z - 1);
                            deposit(scatterings <= kFewScatterings ? few : many, bins, m.coords(x),
                                    weight * glm::dvec4(1, w.x, w.z, y20));
                        });
    });
    if (cancel && *cancel) throw LightingCancelled();
    Scores sum{std::vector<glm::dvec4>(std::size_t(bins) * bins, glm::dvec4(0.0)), {}};
    sum.many = sum.few;
    for (const Scores& batch : perBatch)  // in order: the same sum whatever the thread count
        for (std::size_t i = 0; i < sum.few.size(); ++i) sum.few[i] += batch.few[i], sum.many[i] += batch.many[i];
    return sum;
}

// The volume's extinction per node, summed over the thresholds: sigma at random points of the
// tile times the volume each stands for, deposited as the scores are.
std::vector<double> extinctionPerNode(const std::vector<ThresholdMedium>& media, const LightingVolume& v) {
    const int bins = v.settings.tableBins, points = 16 * v.settings.photons, batches = std::max(1, points / 4096);
    std::vector<std::vector<glm::dvec4>> perBatch(std::size_t(batches) * media.size());
    parallelFor(int(perBatch.size()), [&](int b) {
        const ThresholdMedium& m = media[std::size_t(b) / batches];
        std::vector<glm::dvec4>& grid = perBatch[std::size_t(b)];
        grid.assign(std::size_t(bins) * bins, glm::dvec4(0.0));
        Rng rng = Rng::fromState(0xC0FFEEull + std::uint64_t(b));
        const double volume = m.period * m.period * m.height / (double(batches) * 4096);
        for (int k = 0; k < 4096; ++k) {
            const double z = rng.uniform(), y = rng.uniform();  // one by one, as in emit()
            const Vec3 x(m.period * rng.uniform(), m.period * y, m.height * z);
            const double s = m.sigma(x);
            if (s > 0) deposit(grid, bins, m.coords(x), glm::dvec4(s * volume, 0, 0, 0));
        }
    });
    std::vector<double> sum(std::size_t(bins) * bins, 0.0);
    for (const auto& grid : perBatch)
        for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += grid[i].x;
    return sum;
}

// Nodes that no matter reached take the mean of their reached neighbours, repeatedly.
void fillUnreached(std::vector<glm::vec4>& table, std::vector<bool> reached, int bins) {
    for (int pass = 0; pass < 2 * bins; ++pass) {
        std::vector<bool> next = reached;
        bool all = true;
        for (int j = 0; j < bins; ++j)
            for (int i = 0; i < bins; ++i) {
                const std::size_t n = std::size_t(j) * bins + i;
                if (reached[n]) continue;
                glm::vec4 sum(0.0f);
                int count = 0;
                for (auto [di, dj] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
                    const int a = i + di, b = j + dj;
                    if (a < 0 || b < 0 || a >= bins || b >= bins || !reached[std::size_t(b) * bins + a]) continue;
                    sum += table[std::size_t(b) * bins + a], ++count;
                }
                if (count) table[n] = sum / float(count), next[n] = true;
                else all = false;
            }
        reached = std::move(next);
        if (all) return;
    }
}

}  // namespace

LayerLightTables traceLayerLight(const LightingVolume& v, const std::atomic<bool>* cancel) {
    const LightingSettings& s = v.settings;
    const LightingParameters& p = v.parameters;
    double peak = 0;
    for (std::size_t i = 3; i < v.texels.size(); i += 4) peak = std::max(peak, v.texels[i] / 255.0);
    std::vector<ThresholdMedium> media;
    const double sigma = lightingExtinction(p);
    for (int k = 0; k < 3; ++k)
        if (const double theta = model::kLayerKnots[k]; peak > theta && sigma > 0)
            media.push_back({v, theta, s.tilePeriod, p.thickness, sigma, sigma * (peak - theta) * (1 + 1e-9)});
    LayerLightTables t;
    t.bins = s.tableBins;
    t.sunMu.assign(std::begin(kLayerSunMu), std::end(kLayerSunMu));
    const std::size_t nodes = std::size_t(t.bins) * t.bins;
    t.sun.assign(nodes * t.sunMu.size(), glm::vec4(0.0f));
    t.sunMany = t.sun;
    t.sky.assign(nodes * 3, glm::vec4(0.0f));
    if (media.empty() || s.photons == 0) return t;  // no matter, or single scattering alone
    const std::vector<double> extinction = extinctionPerNode(media, v);
    double largest = 0;
    for (double e : extinction) largest = std::max(largest, e);
    std::vector<bool> reached(nodes);
    for (std::size_t n = 0; n < nodes; ++n) reached[n] = extinction[n] > 1e-4 * largest;
    // Power per photon: the source's flux through the tile's top (or bottom) over the photons.
    const double photonsPerMedium = double(std::max(1, s.photons / kBatch) * kBatch);
    // One table from a source's scores: (phi0, phi1 x, phi1 z, 0) for the sun, (phi0, phi1 z,
    // c20, 0) for the sky.
    auto write = [&](const Source& src, const std::vector<glm::dvec4>& scores, glm::vec4* out) {
        const double power = src.flux() * s.tilePeriod * s.tilePeriod / photonsPerMedium;
        std::vector<glm::vec4> values(nodes, glm::vec4(0.0f));
        for (std::size_t n = 0; n < nodes; ++n) {
            if (!reached[n]) continue;
            const glm::dvec4 m = scores[n] * (power / extinction[n]);  // (phi0, phi1 x, phi1 z, c20)
            values[n] = src.kind == Source::Sun ? glm::vec4(m.x, m.y, m.z, 0) : glm::vec4(m.x, m.z, m.w, 0);
        }
        fillUnreached(values, reached, t.bins);
        std::copy(values.begin(), values.end(), out);
    };
    // The sun's tables in its two parts, the sky's whole.
    for (std::size_t k = 0; k < t.sunMu.size(); ++k) {
        const Source sun{Source::Sun, t.sunMu[k]};
        const Scores scores = traceSource(media, sun, v, 17 + k, cancel);
        write(sun, scores.few, &t.sun[k * nodes]), write(sun, scores.many, &t.sunMany[k * nodes]);
    }
    const Source::Kind bases[3] = {Source::SkyUniform, Source::SkyZenith, Source::Ground};
    for (int b = 0; b < 3; ++b) {
        const Source sky{bases[b]};
        Scores scores = traceSource(media, sky, v, 101 + std::uint64_t(b), cancel);
        for (std::size_t n = 0; n < nodes; ++n) scores.few[n] += scores.many[n];
        write(sky, scores.few, &t.sky[std::size_t(b) * nodes]);
    }
    return t;
}

LayerFrameTables layerFrameTables(const LayerLightTables& t, const Scene& scene) {
    LayerFrameTables f;
    f.bins = t.bins;
    const std::size_t nodes = std::size_t(t.bins) * t.bins;
    f.sun.assign(nodes, glm::vec4(0.0f));
    f.sunMany = f.sky = f.sun;
    if (t.sun.size() < nodes * t.sunMu.size() || t.sunMany.size() < nodes * t.sunMu.size() ||
        t.sky.size() < nodes * 3 || t.sunMu.empty())
        return f;
    auto luminance = [](const Vec3& c) { return float(glm::dot(c, Vec3(model::kLuminance))); };
    // The sun's table at elevation |mu|: linear between the tabulated ones, clamped at the ends.
    auto sunAt = [&](double mu, std::size_t i, std::size_t j, const std::vector<glm::vec4>& table) {
        const auto& m = t.sunMu;
        const std::size_t k = std::size_t(std::upper_bound(m.begin(), m.end(), float(mu)) - m.begin());
        const std::size_t k0 = k == 0 ? 0 : std::min(k - 1, m.size() - 1), k1 = std::min(k, m.size() - 1);
        const float a = k0 == k1 ? 0.0f : float((mu - m[k0]) / (m[k1] - m[k0]));
        const std::size_t n = j * t.bins + i;
        return (1 - a) * table[k0 * nodes + n] + a * table[k1 * nodes + n];
    };
    // The table of a light of direction z (its z component): below the horizon its side is the
    // column's bottom (above and below swap) and its flux points up.
    auto fromSide = [&](double z, std::size_t i, std::size_t j, const std::vector<glm::vec4>& table) {
        glm::vec4 v = z < 0 ? sunAt(-z, j, i, table) : sunAt(z, i, j, table);
        if (z < 0) v.z = -v.z;
        return v;
    };
    const double sz = scene.sun.direction.z;
    const double lz = scene.skylight ? glm::normalize(scene.skylight->direction).z : 0.0;
    // The skylight's irradiance relative to the sun's, in double and capped: a sun far dimmer
    // than its skylight (or one whose colour times intensity is below float range) made this
    // ratio infinite in float, and the layer NaN (issue 38).
    const double sunLuminance = double(luminance(scene.sun.color)) * scene.sun.intensity;
    const float skylightShare =
        scene.skylight && sunLuminance > double(std::numeric_limits<float>::min())
            ? float(std::min(double(luminance(scene.skylight->color)) * scene.skylight->intensity / sunLuminance, 1e30))
            : 0.0f;
    const Vec3 colours[3] = {scene.sky.horizon, scene.sky.zenith - scene.sky.horizon, scene.sky.ground};
    for (int j = 0; j < t.bins; ++j)
        for (int i = 0; i < t.bins; ++i) {
            // (above, below) node.
            glm::vec4 sun = fromSide(sz, i, j, t.sun), many = fromSide(sz, i, j, t.sunMany);
            if (skylightShare > 0) {
                sun.x += skylightShare * fromSide(lz, i, j, t.sun).x;
                many.x += skylightShare * fromSide(lz, i, j, t.sunMany).x;
            }
            glm::vec4 sky(0.0f);
            for (int b = 0; b < 3; ++b) {
                const glm::vec4& basis = t.sky[std::size_t(b) * nodes + std::size_t(j) * t.bins + i];
                sky += glm::vec4(glm::vec3(colours[b]) * basis.x, luminance(colours[b]) * basis.y);
                sun.w += luminance(colours[b]) * basis.z;
            }
            f.sun[std::size_t(j) * t.bins + i] = sun;
            f.sunMany[std::size_t(j) * t.bins + i] = many;
            f.sky[std::size_t(j) * t.bins + i] = sky;
        }
    return f;
}

}  // namespace nephele
