// The photon tracers' sampling (the clouds' radiance grids, ellipsoid/src/cloud_radiance.cpp,
// and the layered sky's light tables, layered/src/layer_light.cpp): a PCG32 generator, an
// orthonormal basis and Henyey-Greenstein directions. Internal to the library.
#pragma once

#include "nephele/scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace nephele::detail {

// PCG32 (O'Neill 2014), as the path tracer's (reference/src/tracking.hpp), seeded through
// SplitMix64 in one of two ways (each tracer's images and tables depend on its own).
class PhotonRng {
public:
    // The radiance grids' seeding: the stream from the seed, then the state as PCG's srandom.
    explicit PhotonRng(std::uint64_t seed) : state_(0), inc_((mix(seed) << 1) | 1u) {
        next();
        state_ += mix(seed ^ 0x5DEECE66Dull);
        next();
    }
    // The light tables' seeding: the state and the stream from the seed, one step.
    static PhotonRng fromState(std::uint64_t seed) {
        PhotonRng r(mix(seed), mix(seed ^ 0x5DEECE66Dull));
        r.next();
        return r;
    }
    std::uint32_t next() {
        const std::uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        const auto x = std::uint32_t(((old >> 18) ^ old) >> 27);
        const auto rot = std::uint32_t(old >> 59);
        return (x >> rot) | (x << ((32u - rot) & 31u));
    }
    double uniform() { return (next() + 0.5) * 0x1.0p-32; }  // (0, 1)

private:
    PhotonRng(std::uint64_t state, std::uint64_t stream) : state_(state), inc_((stream << 1) | 1u) {}
    static std::uint64_t mix(std::uint64_t x) {
        x += 0x9E3779B97F4A7C15ull;
        x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
        x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
        return x ^ (x >> 31);
    }
    std::uint64_t state_, inc_;
};

// An orthonormal basis about unit w (Duff et al. 2017).
inline void basis(const Vec3& w, Vec3& u, Vec3& v) {
    const double sign = std::copysign(1.0, w.z), a = -1 / (sign + w.z), b = w.x * w.y * a;
    u = Vec3(1 + sign * w.x * w.x * a, sign * b, -sign * w.x);
    v = Vec3(b, sign + w.y * w.y * a, -w.y);
}

// A direction about unit w with the Henyey-Greenstein distribution of its angle to w.
inline Vec3 sampleHg(const Vec3& w, double g, PhotonRng& rng) {
    const double xi = rng.uniform(), phi = 2 * std::numbers::pi * rng.uniform();
    double c = 1 - 2 * xi;
    if (std::fabs(g) >= 1e-4) {
        const double s = (1 - g * g) / (1 - g + 2 * g * xi);
        c = std::clamp((1 + g * g - s * s) / (2 * g), -1.0, 1.0);
    }
    const double sn = std::sqrt(std::max(0.0, 1 - c * c));
    Vec3 u, v;
    basis(w, u, v);
    return glm::normalize(sn * std::cos(phi) * u + sn * std::sin(phi) * v + c * w);
}

}  // namespace nephele::detail
