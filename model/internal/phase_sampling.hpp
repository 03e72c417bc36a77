// The phase function and its sampling, one copy for every Monte Carlo tracer: the path tracer
// (reference/src/pathtrace.cpp), the clouds' radiance grids (model/src/cloud_radiance.cpp) and
// the layered sky's light tables (layered/src/layer_light.cpp): the Henyey-Greenstein phase,
// its exact inversion, an orthonormal basis, and the photon tracers' PCG32 generator. Internal
// to the libraries (model/internal, through nephele_internal).
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"
#include "pcg32.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

NEPHELE_API_BEGIN
namespace nephele::detail {

// PCG32 (core/internal/pcg32.hpp, the path tracer's generator), seeded through SplitMix64 in one
// of two ways (each tracer's images and tables depend on its own), its uniform numbers in (0, 1).
class PhotonRng {
public:
    // The radiance grids' seeding: PCG's srandom, the stream and the state from the seed.
    explicit PhotonRng(std::uint64_t seed) : g_(mix64(seed ^ 0x5DEECE66Dull), mix64(seed)) {}
    // The light tables' seeding: the state and the stream from the seed, one step.
    static PhotonRng fromState(std::uint64_t seed) {
        PhotonRng r(Pcg32::raw(mix64(seed), mix64(seed ^ 0x5DEECE66Dull)));
        r.next();
        return r;
    }
    std::uint32_t next() { return g_.next(); }
    double uniform() { return g_.uniformOpen(); }  // (0, 1)

private:
    explicit PhotonRng(const Pcg32& g) : g_(g) {}
    Pcg32 g_;
};

// The Henyey-Greenstein phase function (1/sr) in double; cosTheta between propagation
// directions. (The GLSL/C++ model's float twin is model::hgPhase in gardner_model.glsl.)
inline double hgPhase(double cosTheta, double g) {
    const double d = 1 + g * g - 2 * g * cosTheta;
    return (1 - g * g) / (4 * std::numbers::pi * d * std::sqrt(d));
}

// An orthonormal basis about unit w (Duff et al. 2017).
inline void basis(const Vec3& w, Vec3& u, Vec3& v) {
    const double sign = std::copysign(1.0, w.z), a = -1 / (sign + w.z), b = w.x * w.y * a;
    u = Vec3(1 + sign * w.x * w.x * a, sign * b, -sign * w.x);
    v = Vec3(b, sign + w.y * w.y * a, -w.y);
}

// A direction about unit w with the Henyey-Greenstein distribution of its angle to w (exact
// inversion). Draws two numbers from rng.uniform(), the cosine's first: the path tracer's Pcg32
// gives them in [0, 1), PhotonRng in (0, 1); each tracer keeps its own sequence.
template <class Rng>
inline Vec3 sampleHg(const Vec3& w, double g, Rng& rng) {
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

// A direction about unit n with the density cos(theta) / pi (Malley's method: a uniform point on
// the unit disc lifted onto the hemisphere), what a Lambertian surface's light is sampled by.
// Draws two numbers from rng.uniform().
template <class Rng>
inline Vec3 sampleCosine(const Vec3& n, Rng& rng) {
    const double r = std::sqrt(rng.uniform()), phi = 2 * std::numbers::pi * rng.uniform();
    const double z = std::sqrt(std::max(0.0, 1 - r * r));
    Vec3 u, v;
    basis(n, u, v);
    return glm::normalize(r * std::cos(phi) * u + r * std::sin(phi) * v + z * n);
}

}  // namespace nephele::detail
NEPHELE_API_END
