// The ellipsoid clouds' matter (nephele/cloud_matter.hpp).
#include "nephele/cloud_matter.hpp"

#include "nephele/ellipsoid_space.hpp"
#include "nephele/gardner_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace nephele {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kLeafSize = 4;   // ellipsoids per BVH leaf
constexpr int kMaxDepth = 64;  // the traversal's stack: a median split halves, so 2^32 ellipsoids fit
}  // namespace

CloudMatter::CloudMatter(const Scene& scene, const NoiseVolume* noise, const Vec3& eye, double maxOpticalDepth,
                         bool weights)
    : noise_(noise), detail_(scene.medium.detail) {
    const Medium& m = scene.medium;
    amp_ = m.noise;
    period_ = m.noiseScale * NoiseSettings{}.cells;  // m: one period of the noise volume
    if (amp_ > 0) {
        if (!noise_ || noise_->texels.empty())
            throw std::invalid_argument("cloud matter: medium.noise > 0 needs a noise volume");
        double maxAbs = 0;
        for (float v : noise_->texels) maxAbs = std::max(maxAbs, double(std::fabs(v)));
        // max(0, 1 + amp n) <= this: trilinear filtering stays within the texels' range (the
        // slack covers its float round-off).
        noiseBound_ = 1 + amp_ * maxAbs * (1 + 1e-5);
    }
    const unsigned noiseSeed = NoiseSettings{}.seed;  // the model's default offsets, as every method reads them
    for (std::size_t ci = 0; ci < scene.clouds.size(); ++ci) {
        const Cloud& cloud = scene.clouds[ci];
        const double w = weights ? std::clamp(cloud.weight, 0.0, 1.0) : 1.0;
        const std::size_t noiseCloud = cloud.noiseId ? std::size_t(cloud.noiseId) : ci;
        for (std::size_t ei = 0; ei < cloud.ellipsoids.size(); ++ei) {
            const Ellipsoid& e = cloud.ellipsoids[ei];
            if (!(e.density > 0) || !(m.extinction > 0) || !(w > 0)) continue;
            Shape s;
            s.noiseOffset = glm::vec3(ellipsoidNoiseOffset(noiseCloud, ei, noiseSeed));
            s.unit = ellipsoidToUnit(e);
            s.center = e.center;
            const double rMin = std::min({e.radii.x, e.radii.y, e.radii.z});
            s.sigma = w * std::min(m.extinction * e.density, maxOpticalDepth / (16.0 / 15.0 * rMin));
            const glm::dmat3 axes =
                rotationFromDegrees(e.rotationDeg) * glm::dmat3(e.radii.x, 0, 0, 0, e.radii.y, 0, 0, 0, e.radii.z);
            Vec3 half;  // half extent of the exact world box
            for (int i = 0; i < 3; ++i) half[i] = glm::length(Vec3(axes[0][i], axes[1][i], axes[2][i])) * (1 + 1e-9);
            s.lo = e.center - half;
            s.hi = e.center + half;
            shapes_.push_back(s);
        }
    }
    if (!shapes_.empty()) build(0, int(shapes_.size()));
    frame_ = detailFrame(eye);
}

CloudMatter::DetailFrame CloudMatter::detailFrame(const Vec3& eye) const {
    DetailFrame f;
    f.eye = eye;
    if (detail_.on()) f.params = detailParams(detail_, eye);
    return f;
}

std::pair<Vec3, Vec3> CloudMatter::bounds() const {
    return nodes_.empty() ? std::pair{Vec3(kInf), Vec3(-kInf)} : std::pair{nodes_[0].lo, nodes_[0].hi};
}

// One ellipsoid's extinction where 1 - q = h > 0 (the terms of the header's sum).
double CloudMatter::matter(const Shape& shape, double h, const glm::vec3& uvw, float e) const {
    double phi = detailOn() ? erodedProfile(1 - h, e) : h * h;
    if (amp_ > 0) phi *= std::max(0.0, 1 + amp_ * noise_->sample(uvw + shape.noiseOffset));
    return shape.sigma * phi;
}

float CloudMatter::erosionAt(const Vec3& x, const DetailFrame& frame) const {
    return model::detailErosion(detailVolume(), frame.params, glm::vec3(x - frame.eye));
}

double CloudMatter::extinction(const Vec3& x, const DetailFrame& frame) const {
    if (shapes_.empty()) return 0;
    double s = 0;
    glm::vec3 uvw(0.0f);
    if (amp_ > 0) uvw = glm::vec3(x / period_);
    float e = -1.0f;  // the detail's erosion at x: read once, and only where there is matter
    int stack[kMaxDepth], top = 0;
    stack[top++] = 0;
    while (top) {
        const int index = stack[--top];
        const Node& n = nodes_[std::size_t(index)];
        if (glm::any(glm::lessThan(x, n.lo)) || glm::any(glm::greaterThan(x, n.hi))) continue;
        if (n.count == 0) {
            stack[top++] = n.second;
            stack[top++] = index + 1;
            continue;
        }
        for (int i = n.first; i < n.first + n.count; ++i) {
            const Shape& shape = shapes_[std::size_t(i)];
            const Vec3 u = shape.unit * (x - shape.center);
            const double h = 1 - glm::dot(u, u);  // 1 - q
            if (h <= 0) continue;
            if (detailOn() && e < 0) e = erosionAt(x, frame);
            s += matter(shape, h, uvw, e);
        }
    }
    return s;
}

void CloudMatter::chords(const Vec3& o, const Vec3& d, double t0, double t1, std::vector<Chord>& out) const {
    out.clear();
    if (shapes_.empty() || !(t1 > t0)) return;
    const Vec3 inv(1 / (d.x != 0 ? d.x : 1e-300), 1 / (d.y != 0 ? d.y : 1e-300), 1 / (d.z != 0 ? d.z : 1e-300));
    int stack[kMaxDepth], top = 0;
    stack[top++] = 0;
    while (top) {
        const int index = stack[--top];
        const Node& n = nodes_[std::size_t(index)];
        const Vec3 a = (n.lo - o) * inv, b = (n.hi - o) * inv;  // slab test
        const Vec3 lo = glm::min(a, b), hi = glm::max(a, b);
        if (std::max({lo.x, lo.y, lo.z, t0}) > std::min({hi.x, hi.y, hi.z, t1})) continue;
        if (n.count == 0) {
            stack[top++] = n.second;
            stack[top++] = index + 1;
        } else {
            for (int i = n.first; i < n.first + n.count; ++i) chord(o, d, t0, t1, i, out);
        }
    }
    std::sort(out.begin(), out.end(),
              [](const Chord& a, const Chord& b) { return a.tIn < b.tIn || (a.tIn == b.tIn && a.shape < b.shape); });
}

double CloudMatter::extinctionAlong(const Vec3& o, const Vec3& d, double t, std::span<const Chord> chords,
                                    const DetailFrame& frame) const {
    double s = 0;
    glm::vec3 uvw(0.0f);
    if (amp_ > 0) uvw = glm::vec3((o + t * d) / period_);
    float e = -1.0f;  // the detail's erosion at the point: read once, and only where there is matter
    for (const Chord& c : chords) {
        if (c.tIn > t) break;
        if (t > c.tOut) continue;
        const double u = t * c.len - c.tc, h = 1 - c.b2 - u * u;  // 1 - q
        if (h <= 0) continue;
        if (detailOn() && e < 0) e = erosionAt(o + t * d, frame);
        s += matter(shapes_[std::size_t(c.shape)], h, uvw, e);
    }
    return s;
}

double CloudMatter::smoothDepth(const Vec3& o, const Vec3& d, double t0, double t1,
                                const std::vector<Chord>& chords) const {
    double tau = 0;
    for (const Chord& c : chords) tau += smoothDepth(o, d, t0, t1, c);
    return tau;
}

double CloudMatter::smoothDepth(const Vec3& o, const Vec3& d, double t0, double t1, const Chord& c) const {
    const Shape& s = shapes_[std::size_t(c.shape)];
    // The float closed form of a short segment can round below 0: times a dense medium's sigma
    // that would be a transmittance of infinity.
    return s.sigma * std::max(0.0f, model::segmentDepth(glm::vec3(s.unit * (o - s.center)), glm::vec3(s.unit * d),
                                                        float(t0), float(std::min(t1, 1e30))));
}

double CloudMatter::chordSmooth(double t, const Chord& c) const {
    const double u = t * c.len - c.tc, h = 1 - c.b2 - u * u;  // 1 - q
    return h > 0 ? shapes_[std::size_t(c.shape)].sigma * h * h : 0.0;
}

void CloudMatter::chord(const Vec3& o, const Vec3& d, double t0, double t1, int i, std::vector<Chord>& out) const {
    const Shape& s = shapes_[std::size_t(i)];
    const Vec3 ou = s.unit * (o - s.center), du = s.unit * d;
    const double len = glm::length(du);
    const Vec3 dn = du / len;
    const double tc = -glm::dot(ou, dn);
    const Vec3 perp = ou + tc * dn;
    const double b2 = glm::dot(perp, perp);
    if (b2 >= 1) return;
    const double h = std::sqrt(1 - b2);
    const double tIn = std::max(t0, (tc - h) / len), tOut = std::min(t1, (tc + h) / len);
    if (tOut > tIn) out.push_back({tIn, tOut, len, tc, b2, i});
}

// Median split on the longest axis of the centres' box.
int CloudMatter::build(int first, int count) {
    const int index = int(nodes_.size());
    nodes_.emplace_back();
    Vec3 lo(kInf), hi(-kInf), clo(kInf), chi(-kInf);
    for (int i = first; i < first + count; ++i) {
        const Shape& s = shapes_[std::size_t(i)];
        lo = glm::min(lo, s.lo);
        hi = glm::max(hi, s.hi);
        const Vec3 c = 0.5 * (s.lo + s.hi);
        clo = glm::min(clo, c);
        chi = glm::max(chi, c);
    }
    nodes_[std::size_t(index)].lo = lo;
    nodes_[std::size_t(index)].hi = hi;
    if (count <= kLeafSize) {
        nodes_[std::size_t(index)].first = first;
        nodes_[std::size_t(index)].count = count;
        return index;
    }
    const Vec3 ext = chi - clo;
    const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
    const int half = count / 2;
    std::nth_element(
        shapes_.begin() + first, shapes_.begin() + first + half, shapes_.begin() + first + count,
        [axis](const Shape& a, const Shape& b) { return a.lo[axis] + a.hi[axis] < b.lo[axis] + b.hi[axis]; });
    build(first, half);
    const int second = build(first + half, count - half);
    nodes_[std::size_t(index)].second = second;
    return index;
}

}  // namespace nephele
