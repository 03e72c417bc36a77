// The clouds of one update() as a field the host can query (cloud_field.hpp).
#include "cloud_field.hpp"

#include "layer_geometry.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace nephele {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kLayerStep = 20;     // m: the layers' quadrature step (a modulation texel is 58 m)
constexpr int kLayerMaxSteps = 4000;  // per layer and ray: past 80 km the steps grow
constexpr int kChordMinPieces = 8;    // midpoints per run of overlapping chords, at least (the noise, the detail)
constexpr int kChordMaxPieces = 1024;
constexpr double kDepthFirstRadius = 2;  // m
constexpr double kDepthGrowth = 0.15;    // each radius 15% beyond the last (at least kDepthFirstRadius)
constexpr int kDepthBisections = 10;

// The directions insideCloud looks along: the cube's 6 faces, 12 edges and 8 corners.
std::array<Vec3, 26> searchDirections() {
    std::array<Vec3, 26> out{};
    int n = 0;
    for (int x = -1; x <= 1; ++x)
        for (int y = -1; y <= 1; ++y)
            for (int z = -1; z <= 1; ++z)
                if (x || y || z) out[std::size_t(n++)] = glm::normalize(Vec3(x, y, z));
    return out;
}

}  // namespace

CloudField::CloudField(std::shared_ptr<const CloudMatter> explicitClouds, std::shared_ptr<const CloudMatter> nearClouds,
                       const Medium& medium, const LayeredSettings& layered, std::vector<LayerEntry> layers,
                       const Vec3& eye, double time)
    : explicit_(std::move(explicitClouds)),
      near_(std::move(nearClouds)),
      noiseScale_(medium.noise > 0 ? medium.noiseScale : 0),
      extinctionPerDensity_(medium.extinction),
      layered_(layered),
      layers_(std::move(layers)),
      eye_(eye),
      time_(time) {
    detail_.eye = eye;
    if (medium.detail.on()) detail_.params = detailParams(medium.detail, eye);
    std::erase_if(layers_, [&](const LayerEntry& e) {
        return !(e.light && e.modulation && e.layer.density > 0 && e.layer.coverage > 0 && medium.extinction > 0);
    });
}

double CloudField::layerExtinction(const LayerEntry& e, const Vec3& p) const {
    const Layer& l = e.layer;
    if (p.z < l.base || p.z > l.base + l.thickness) return 0;
    const double h = glm::length(Vec2(p.x - eye_.x, p.y - eye_.y));
    if (h > l.extent) return 0;
    double fade = rimFade(l, layered_.extentFade, h);
    if (e.nearLod) fade *= nearFade(layered_, h);
    // Cheap test first, as the shader: eq. (16) is 0 wherever r >= C (A <= 1).
    if (!(fade > 0) || layerModulation(l, *e.modulation, layered_.modulation, p.x, p.y, time_) <= 0) return 0;
    return extinctionPerDensity_ * fade * layerDensity(l, *e.modulation, layered_.modulation, *e.light, p, time_);
}

double CloudField::extinction(const Vec3& p) const {
    double sigma = explicit_ ? explicit_->extinction(p, detail_) : 0.0;
    if (near_) sigma += near_->extinction(p, detail_);
    for (const LayerEntry& e : layers_) sigma += layerExtinction(e, p);
    return sigma;
}

// One cloud set's optical depth along o + t d over [0, length]: the smooth field in closed form
// per chord. With noise or detail, the chords are merged into runs of overlapping ones, and each
// run's closed form is scaled by the factor the noise and the detail give its matter at the run's
// midpoints (sum of the field over sum of the smooth field there): exact for the smooth field
// whatever the count, and the detail's erosion is read once per point, not once per chord.
double CloudField::cloudDepth(const CloudMatter& matter, const Vec3& o, const Vec3& d, double length) const {
    thread_local std::vector<CloudMatter::Chord> chords;
    matter.chords(o, d, 0, length, chords);
    if (!matter.varies()) return matter.smoothDepth(o, d, 0, length, chords);
    double tau = 0;
    for (std::size_t first = 0; first < chords.size();) {
        double b;
        const std::size_t end = CloudMatter::runEnd(chords, first, b);  // the run: chords [first, end)
        const double a = chords[first].tIn;
        double closed = 0;
        for (std::size_t c = first; c < end; ++c)
            closed += matter.smoothDepth(o, d, chords[c].tIn, chords[c].tOut, chords[c]);
        const double span = b - a;
        double pieces = kChordMinPieces;
        if (noiseScale_ > 0) pieces = std::max(pieces, std::ceil(2 * span / noiseScale_));  // two per noise cell
        if (matter.detailOn()) {
            const double nearest = glm::length(o + std::clamp(glm::dot(eye_ - o, d), a, b) * d - eye_);
            // A quarter of the finest wavelength drawn there (as exactPieces, over the whole run).
            const double finest = detailFinestWavelength(nearest, double(detail_.params.smallest));
            pieces = std::max(pieces, std::ceil(4 * span / finest));
        }
        const int n = int(std::min(pieces, double(kChordMaxPieces)));
        double full = 0, smooth = 0;
        for (int k = 0; k < n; ++k) {
            const double t = a + (k + 0.5) * span / n;
            full += matter.extinctionAlong(o, d, t, std::span(chords).subspan(first, end - first), detail_);
            for (std::size_t c = first; c < end; ++c) smooth += matter.chordSmooth(t, chords[c]);
        }
        if (smooth > 0) tau += closed * (full / smooth);
        first = end;
    }
    return tau;
}

double CloudField::layerDepth(const LayerEntry& e, const Vec3& o, const Vec3& d, double length) const {
    double t0 = 0, t1 = length;
    if (!clipToLayer(o, d, e.layer.base, e.layer.base + e.layer.thickness, eye_, e.layer.extent, t0, t1)) return 0;
    const int n = int(std::clamp(std::ceil((t1 - t0) / kLayerStep), 1.0, double(kLayerMaxSteps)));
    const double dt = (t1 - t0) / n;
    double tau = 0;
    for (int k = 0; k < n; ++k) tau += layerExtinction(e, o + (t0 + (k + 0.5) * dt) * d);
    return tau * dt;
}

double CloudField::transmittance(const Vec3& o, const Vec3& d, double length) const {
    double tau = 0;
    if (explicit_) tau += cloudDepth(*explicit_, o, d, length);
    if (near_) tau += cloudDepth(*near_, o, d, length);
    for (const LayerEntry& e : layers_) tau += layerDepth(e, o, d, length);
    return std::exp(-tau);
}

CloudPresence CloudField::presence(const Vec3& p) const {
    CloudPresence out;
    out.extinction = extinction(p);
    out.inside = out.extinction >= kInsideCloudExtinction;
    if (!out.inside) return out;
    static const std::array<Vec3, 26> dirs = searchDirections();
    auto outside = [&](const Vec3& x) { return extinction(x) < kInsideCloudExtinction; };
    double last = 0, r = kDepthFirstRadius;
    while (last < kCloudDepthReach) {
        double best = kInf;
        for (const Vec3& dir : dirs) {
            if (!outside(p + r * dir)) continue;
            double lo = last, hi = r;  // inside at lo (every direction was), outside at hi
            for (int i = 0; i < kDepthBisections; ++i) {
                const double mid = 0.5 * (lo + hi);
                (outside(p + mid * dir) ? hi : lo) = mid;
            }
            best = std::min(best, hi);
        }
        if (best < kInf) {
            out.depth = best;
            return out;
        }
        last = r;
        r = std::min(kCloudDepthReach, r + std::max(kDepthFirstRadius, kDepthGrowth * r));
    }
    out.depth = kCloudDepthReach;
    return out;
}

}  // namespace nephele
