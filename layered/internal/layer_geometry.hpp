// A ray against a layer's volume as the layered sky draws it: the slab [lo, hi] within a
// horizontal radius of the eye. Shared by the path tracer's layer volumes (reference/) and the
// host's cloud queries (sky/). Internal to the libraries.
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

NEPHELE_API_BEGIN
namespace nephele {

// The interval of t where o + t d lies in the slab z in [lo, hi] and within `radius` of `c`
// horizontally, intersected with [t0, t1]; false when empty.
inline bool clipToLayer(const Vec3& o, const Vec3& d, double lo, double hi, const Vec3& c, double radius, double& t0,
                        double& t1) {
    if (std::fabs(d.z) < 1e-12) {
        if (o.z < lo || o.z > hi) return false;
    } else {
        double a = (lo - o.z) / d.z, b = (hi - o.z) / d.z;
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a), t1 = std::min(t1, b);
    }
    const Vec2 p(o.x - c.x, o.y - c.y), h(d.x, d.y);
    const double qa = glm::dot(h, h), qb = glm::dot(p, h), qc = glm::dot(p, p) - radius * radius;
    if (qa < 1e-24) {
        if (qc > 0) return false;
    } else {
        const double disc = qb * qb - qa * qc;
        if (disc < 0) return false;
        const double s = std::sqrt(disc);
        t0 = std::max(t0, (-qb - s) / qa), t1 = std::min(t1, (-qb + s) / qa);
    }
    return t1 > t0;
}

}  // namespace nephele
NEPHELE_API_END
