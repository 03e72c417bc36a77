// Free-flight sampling and transmittance estimation along one ray through a heterogeneous
// medium bounded by a piecewise-constant majorant: delta (Woodcock) tracking and ratio
// tracking (Novak, Selle & Jarosz 2014). Internal to nephele_reference; a header so that the
// tests can drive the trackers with analytic densities. Distances t in metres along a unit
// ray, extinction coefficients in 1/m.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

namespace nephele::detail {

// PCG32 (O'Neill 2014): 64-bit LCG state, XSH-RR output. Seeded per (seed, pixel, sample)
// by the renderer, so images do not depend on thread scheduling.
class Pcg32 {
public:
    Pcg32(std::uint64_t state, std::uint64_t stream) : inc_((stream << 1) | 1u) {
        next();
        state_ += state;
        next();
    }
    std::uint32_t next() {
        const std::uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        const auto xorshifted = std::uint32_t(((old >> 18) ^ old) >> 27);
        const auto rot = std::uint32_t(old >> 59);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }
    double uniform() { return next() * 0x1.0p-32; }  // [0, 1)

private:
    std::uint64_t state_ = 0, inc_;
};

// SplitMix64 finaliser: a well-mixed 64-bit hash.
inline std::uint64_t mix64(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

// The generator of one sample of one pixel.
inline Pcg32 sampleRng(unsigned seed, std::uint64_t pixel, std::uint64_t sample) {
    const std::uint64_t h = mix64(mix64(mix64(seed) ^ pixel) ^ sample);
    return Pcg32(h, mix64(h));
}

// A stretch [t0, t1) of the ray over which the extinction never exceeds `majorant`.
struct MajorantSegment {
    double t0, t1;    // m
    double majorant;  // 1/m, > 0
};

// One bound of the extinction over [t0, t1] (e.g. one ellipsoid's chord, or part of it).
struct MajorantPiece {
    double t0, t1;  // m
    double bound;   // 1/m, >= 0
};

// Sums overlapping pieces into disjoint segments sorted by t (a sweep over the sorted ends);
// stretches with no piece are left out. `events` is scratch space.
inline void buildMajorant(std::span<const MajorantPiece> pieces, std::vector<std::pair<double, double>>& events,
                          std::vector<MajorantSegment>& out) {
    out.clear();
    events.clear();
    for (const MajorantPiece& p : pieces)
        if (p.t1 > p.t0 && p.bound > 0) {
            events.emplace_back(p.t0, p.bound);
            events.emplace_back(p.t1, -p.bound);
        }
    std::sort(events.begin(), events.end());
    double sum = 0;
    int active = 0;
    for (std::size_t i = 0; i < events.size();) {
        const double t = events[i].first;
        for (; i < events.size() && events[i].first == t; ++i) {
            sum += events[i].second;
            active += events[i].second > 0 ? 1 : -1;
        }
        if (active == 0) sum = 0;  // no round-off residue between clouds
        if (i < events.size() && sum > 0) {
            // Slack of 1e-12 covers the round-off of the running sum.
            const MajorantSegment s{t, events[i].first, sum * (1 + 1e-12)};
            if (!out.empty() && out.back().t1 == s.t0 && out.back().majorant == s.majorant)
                out.back().t1 = s.t1;
            else
                out.push_back(s);
        }
    }
}

constexpr double kNoCollision = std::numeric_limits<double>::infinity();

// Delta tracking: the distance of the first real collision with extinction sigma(t) (1/m)
// along the segments, or kNoCollision. Unbiased provided sigma(t) <= majorant everywhere.
template <class Sigma>
double deltaTrack(std::span<const MajorantSegment> segments, const Sigma& sigma, Pcg32& rng) {
    for (const MajorantSegment& s : segments)
        for (double t = s.t0;;) {
            t -= std::log(1.0 - rng.uniform()) / s.majorant;  // exponential step, mean 1/majorant
            if (t >= s.t1) break;                             // memoryless: restart at the next segment
            if (rng.uniform() * s.majorant < sigma(t)) return t;
        }
    return kNoCollision;
}

// Ratio tracking: an unbiased estimate of the transmittance exp(-integral of sigma) over the
// segments, in [0, 1].
template <class Sigma>
double ratioTrack(std::span<const MajorantSegment> segments, const Sigma& sigma, Pcg32& rng) {
    double transmittance = 1;
    for (const MajorantSegment& s : segments)
        for (double t = s.t0;;) {
            t -= std::log(1.0 - rng.uniform()) / s.majorant;
            if (t >= s.t1) break;
            transmittance *= std::max(0.0, 1.0 - sigma(t) / s.majorant);
            if (transmittance == 0) return 0;
        }
    return transmittance;
}

// Images renderPathTraced has computed in this process (cache hits do not count); for tests.
std::uint64_t pathTracedImagesComputed();

}  // namespace nephele::detail
