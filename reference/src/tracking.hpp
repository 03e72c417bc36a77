// Free-flight sampling and transmittance estimation along one ray through a heterogeneous
// medium bounded by a piecewise-constant majorant: delta (Woodcock) tracking and ratio
// tracking (Novak, Selle & Jarosz 2014). Internal to nephele_reference; a header so that the
// tests can drive the trackers with analytic densities. Distances t in metres along a unit
// ray, extinction coefficients in 1/m.
#pragma once

// Pcg32, mix64: seeded per (seed, pixel, sample) below, so images do not depend on thread scheduling.
#include "pcg32.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

namespace nephele::detail {

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
            if (!out.empty() && out.back().t1 == s.t0 && out.back().majorant == s.majorant) out.back().t1 = s.t1;
            else out.push_back(s);
        }
    }
}

// One ray's chord through an ellipsoid, in the terms of its density: at distance t (m) the
// ray is at unit-space arc length u = t len - tc, where the density is rho (a - u^2)^2 for
// u^2 < a (a = 1 - b^2, b the impact parameter), 0 at the chord's natural ends u = +-sqrt(a).
struct Chord {
    double tIn, tOut;  // m, the chord clipped to the ray's interval
    double len, tc;    // unit-space length per metre; unit arc length of the closest approach
    double a;          // 1 - b^2, in (0, 1]
};

constexpr int kPieces = 4;            // uniform majorant pieces per chord
constexpr double kGradeAbove = 1000;  // optical depth of a chord's majorant above which it is graded

// Appends the majorant pieces of one chord of an ellipsoid whose extinction is at most
// bound (a - u^2)^2 (1/m): each piece bounds it by its largest value on the piece. kPieces
// uniform pieces; when the chord's majorant is optically deeper than kGradeAbove, also pieces
// of doubling length from each natural end towards the middle, the first so short that it
// holds about one tentative collision. Near an end the density rises from 0, so uniform pieces
// would make a free flight take up to bound^(2/3) tentative collisions there (10^8 at density
// 1e12); on a graded piece the bound is within about 4 times the field at its far end.
// `breaks` is scratch space.
inline void chordPieces(const Chord& c, double bound, std::vector<double>& breaks, std::vector<MajorantPiece>& out) {
    breaks.clear();
    for (int k = 0; k <= kPieces; ++k) breaks.push_back(k == kPieces ? c.tOut : c.tIn + (c.tOut - c.tIn) * k / kPieces);
    if (bound * c.a * c.a * (c.tOut - c.tIn) > kGradeAbove) {
        const double ua = std::sqrt(c.a);
        // Near an end h = a - u^2 ~ 2 ua du: a piece of du holds bound (2 ua du)^2 du / len of majorant depth.
        for (double du = std::cbrt(c.len / (4 * bound * c.a)); du < ua; du *= 2)
            for (double u : {-ua + du, ua - du}) {
                const double t = (u + c.tc) / c.len;
                if (t > c.tIn && t < c.tOut) breaks.push_back(t);
            }
        std::sort(breaks.begin(), breaks.end());
    }
    for (std::size_t k = 0; k + 1 < breaks.size(); ++k) {
        const double p0 = breaks[k], p1 = breaks[k + 1];
        if (!(p1 > p0)) continue;
        const double u0 = p0 * c.len - c.tc, u1 = p1 * c.len - c.tc;  // the piece in unit arc length
        const double uMin = (u0 <= 0 && u1 >= 0) ? 0 : std::min(std::fabs(u0), std::fabs(u1));
        const double h = std::max(0.0, c.a - uMin * uMin);  // 1 - smallest q
        out.push_back({p0, p1, bound * h * h});
    }
}

constexpr double kNoCollision = std::numeric_limits<double>::infinity();

// Tentative collisions one tracking call takes at most: a guard that fields the renderer
// allows never reach (their majorants are graded to within a small factor of the field, see
// pathtrace.cpp); past it the medium is taken as opaque where the walk stands.
constexpr long kMaxTrackingSteps = 1000000;

// The next tentative collision after t: an exponential step of mean 1/majorant. Sets `stuck`
// when the step is too short to move t at all (the majorant's mean free path is below the
// precision of the distance): the medium is opaque at that scale.
inline double nextTentative(double t, double majorant, Pcg32& rng, bool& stuck) {
    const double step = -std::log(1.0 - rng.uniform()) / majorant;
    stuck = step > 0 && t + step == t;  // a zero step (uniform() == 0) is a valid draw, not a stall
    return t + step;
}

// Delta tracking: the distance of the first real collision with extinction sigma(t) (1/m)
// along the segments, or kNoCollision. Unbiased provided sigma(t) <= majorant everywhere and
// the steps move t; where they cannot (see nextTentative), or after kMaxTrackingSteps, the
// collision is where the walk stands.
template <class Sigma>
double deltaTrack(std::span<const MajorantSegment> segments, const Sigma& sigma, Pcg32& rng) {
    long steps = 0;
    bool stuck = false;
    for (const MajorantSegment& s : segments)
        for (double t = s.t0;;) {
            const double next = nextTentative(t, s.majorant, rng, stuck);
            if (next >= s.t1) break;  // memoryless: restart at the next segment
            if (stuck || ++steps > kMaxTrackingSteps) return t;
            t = next;
            if (rng.uniform() * s.majorant < sigma(t)) return t;
        }
    return kNoCollision;
}

// Below this, ratio tracking plays Russian roulette: it goes on at this value with probability
// transmittance / kRouletteBelow, else returns 0 (unbiased). Without it a walk through dense
// matter multiplies its estimate down to a double's underflow, thousands of steps.
constexpr double kRouletteBelow = 1e-10;

// Ratio tracking: an unbiased estimate of the transmittance exp(-integral of sigma) over the
// segments, in [0, 1] (0 where delta tracking would collide where it stands, as above).
template <class Sigma>
double ratioTrack(std::span<const MajorantSegment> segments, const Sigma& sigma, Pcg32& rng) {
    double transmittance = 1;
    long steps = 0;
    bool stuck = false;
    for (const MajorantSegment& s : segments)
        for (double t = s.t0;;) {
            t = nextTentative(t, s.majorant, rng, stuck);
            if (t >= s.t1) break;
            if (stuck || ++steps > kMaxTrackingSteps) return 0;
            transmittance *= std::max(0.0, 1.0 - sigma(t) / s.majorant);
            if (transmittance < kRouletteBelow) {
                if (rng.uniform() * kRouletteBelow >= transmittance) return 0;
                transmittance = kRouletteBelow;
            }
        }
    return transmittance;
}

// Images renderPathTraced has computed in this process (cache hits do not count); for tests.
std::uint64_t pathTracedImagesComputed();

}  // namespace nephele::detail
