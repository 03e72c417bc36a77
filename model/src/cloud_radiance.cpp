// The per-cloud radiance grid (nephele/cloud_radiance.hpp): the cloud's extinction voxelised
// on the grid, the sun's optical depth in closed form, and the diffuse light by photons traced
// through the voxelised extinction with the path tracer's physics, scored by track length.
#include "nephele/cloud_radiance.hpp"
#include "grid_erosion.hpp"
#include "grid_sampling.hpp"
#include "phase_sampling.hpp"

#include "nephele/gardner_model.hpp"
#include "parallel.hpp"
#include "nephele/ellipsoid_space.hpp"

#include <glm/gtc/matrix_access.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace nephele {

Vec3 environmentMean(const Sky& sky) {
    // Over the upper hemisphere the format's sky is horizon + (zenith - horizon) d.z, whose
    // mean over solid angle is (zenith + horizon) / 2 (the mean of d.z is 1/2); below, ground.
    return 0.5 * (0.5 * (sky.zenith + sky.horizon)) + 0.5 * sky.ground;
}

Vec3 cloudAmbient(const Sky& sky) { return environmentMean(sky); }

namespace {

using Rng = detail::PhotonRng;
using detail::basis;
using detail::sampleHg;

// The half extents of the ellipsoid's axis-aligned box: the lengths of the rows of R diag(r).
Vec3 halfExtents(const Ellipsoid& e) {
    const glm::dmat3 a =
        rotationFromDegrees(e.rotationDeg) * glm::dmat3(e.radii.x, 0, 0, 0, e.radii.y, 0, 0, 0, e.radii.z);
    return Vec3(glm::length(glm::row(a, 0)), glm::length(glm::row(a, 1)), glm::length(glm::row(a, 2)));
}

// The voxel grid a photon walks: extinction per voxel (1/m), world box; periodic across (x
// and y) for a tiled cloud (Cloud::tileMin).
struct Grid {
    int n = 0;
    Vec3 lo{0.0}, cell{1.0};  // m
    bool periodic = false;
    std::vector<float> sigma;

    Vec3 hi() const { return lo + cell * double(n); }

    std::size_t index(int x, int y, int z) const { return (std::size_t(z) * n + y) * n + x; }
};

// Mean extinction over each voxel: the field at 2x2x2 points per voxel (the finer grid's voxel
// centres, where `erosion` is read), each ellipsoid over the voxels of its box only; on a
// periodic grid what reaches past a side comes back through the opposite one.
std::vector<float> voxelise(const Scene& scene, const Cloud& cloud, const Grid& g, const GridErosion& erosion) {
    static_assert(kSunRefinement == 2, "voxelise samples the finer grid's voxel centres");
    std::vector<float> sigma(std::size_t(g.n) * g.n * g.n, 0.0f);
    struct Shape {
        glm::dmat3 unit;
        Vec3 centre;
        double sigma;
        glm::ivec3 lo, hi;
    };
    std::vector<Shape> shapes;
    for (const Ellipsoid& e : cloud.ellipsoids) {
        if (!(e.density > 0)) continue;
        const Vec3 half = halfExtents(e);
        const Vec3 from = glm::floor((e.center - half - g.lo) / g.cell),
                   to = glm::floor((e.center + half - g.lo) / g.cell);
        glm::ivec3 lo = glm::clamp(glm::ivec3(from), 0, g.n - 1), hi = glm::clamp(glm::ivec3(to), 0, g.n - 1);
        if (g.periodic)  // unclamped across, at most two periods
            for (int k = 0; k < 2; ++k) {
                lo[k] = int(std::clamp(from[k], -double(g.n), double(g.n)));
                hi[k] = std::min(int(std::clamp(to[k], -1.0, 2.0 * g.n)), lo[k] + 2 * g.n - 1);
            }
        shapes.push_back({ellipsoidToUnit(e), e.center, scene.medium.extinction * e.density, lo, hi});
    }
    parallelFor(g.n, [&](int z) {
        for (const Shape& e : shapes) {
            if (z < e.lo.z || z > e.hi.z) continue;
            for (int y = e.lo.y; y <= e.hi.y; ++y)
                for (int x = e.lo.x; x <= e.hi.x; ++x) {
                    double sum = 0;
                    for (int k = 0; k < 8; ++k) {
                        const glm::ivec3 sub(k & 1, (k >> 1) & 1, k >> 2);
                        const Vec3 u = e.unit * (g.lo + (Vec3(x, y, z) + 0.25 + 0.5 * Vec3(sub)) * g.cell - e.centre);
                        const double q = glm::dot(u, u);
                        if (q >= 1) continue;
                        sum += erosion.on()
                                   ? erodedProfile(q, erosion.atFine(2 * x + sub.x, 2 * y + sub.y, 2 * z + sub.z))
                                   : (1 - q) * (1 - q);
                    }
                    const int wx = ((x % g.n) + g.n) % g.n, wy = ((y % g.n) + g.n) % g.n;  // x, y on a periodic grid
                    sigma[g.index(wx, wy, z)] += float(e.sigma * sum / 8);
                }
        }
    });
    return sigma;
}

// Voxel steps a flight takes at most on a periodic grid (a photon travelling level in a
// clear row would never leave): past them it counts as gone.
constexpr int kMaxPeriodicSteps = 1 << 15;

// Walks the photon (x, w) through the grid until it has crossed optical depth `tau`, scoring
// length into the voxels crossed. Returns false when it leaves the box (on a periodic grid: its
// top or bottom), else moves x to the collision.
template <class Score>
bool flightTo(const Grid& g, Vec3& x, const Vec3& w, double tau, Score&& score) {
    Vec3 p = (x - g.lo) / g.cell;  // voxel units
    Vec3 shift(0.0);               // m, the periods crossed on a periodic grid
    int cell[3], step[3];
    double tNext[3], tDelta[3];
    for (int k = 0; k < 3; ++k) {
        cell[k] = std::clamp(int(std::floor(p[k])), 0, g.n - 1);
        if (w[k] > 0) {
            step[k] = 1;
            tDelta[k] = g.cell[k] / w[k];
            tNext[k] = (cell[k] + 1 - p[k]) * g.cell[k] / w[k];
        } else if (w[k] < 0) {
            step[k] = -1;
            tDelta[k] = -g.cell[k] / w[k];
            tNext[k] = (p[k] - cell[k]) * g.cell[k] / -w[k];
        } else {
            step[k] = 0;
            tDelta[k] = tNext[k] = INFINITY;
        }
    }
    double t = 0;
    for (int steps = 0;; ++steps) {
        const int axis = tNext[0] < tNext[1] ? (tNext[0] < tNext[2] ? 0 : 2) : (tNext[1] < tNext[2] ? 1 : 2);
        const double length = std::max(tNext[axis] - t, 0.0);
        const std::size_t i = g.index(cell[0], cell[1], cell[2]);
        const double s = g.sigma[i];
        if (s * length >= tau) {  // collides in this voxel
            const double l = tau / s;
            score(i, l);
            x += (t + l) * w + shift;
            return true;
        }
        score(i, length);
        tau -= s * length;
        t = tNext[axis];
        cell[axis] += step[axis];
        if (cell[axis] < 0 || cell[axis] >= g.n) {
            if (!g.periodic || axis == 2 || steps >= kMaxPeriodicSteps) return false;
            const double period = g.cell[axis] * g.n;
            cell[axis] = cell[axis] < 0 ? g.n - 1 : 0;
            shift[axis] += cell[axis] == 0 ? -period : period;
        }
        tNext[axis] += tDelta[axis];
    }
}

// A free flight: to an optical depth drawn from e^-tau.
template <class Score>
bool flight(const Grid& g, Vec3& x, const Vec3& w, Rng& rng, Score&& score) {
    return flightTo(g, x, w, -std::log(rng.uniform()), score);
}

// Where a ray from outside enters the box [lo, hi] along w: false if it misses.
bool enterBox(const Vec3& lo, const Vec3& hi, Vec3& x, const Vec3& w) {
    double t0 = 0, t1 = INFINITY;
    for (int k = 0; k < 3; ++k) {
        if (std::fabs(w[k]) < 1e-300) {
            if (x[k] < lo[k] || x[k] > hi[k]) return false;
            continue;
        }
        double a = (lo[k] - x[k]) / w[k], b = (hi[k] - x[k]) / w[k];
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
    }
    if (t0 >= t1) return false;
    x += (t0 + 1e-9 * (t1 - t0)) * w;
    return true;
}

constexpr int kBatches = 8;  // photon batches: a fixed split, so the result is thread-count free
constexpr int kMaxBounces = 4096;

// Sums per-batch tallies in batch order: the result does not depend on the threads. Batches
// skipped by a cancel are empty.
void sumBatches(const std::vector<std::vector<glm::vec4>>& batches, std::vector<glm::vec4>& out) {
    for (const auto& b : batches)
        if (b.size() == out.size())
            for (std::size_t i = 0; i < out.size(); ++i) out[i] += b[i];
}

// The launch of a beam of photons along unit `travel` over the grid's box: a square of side
// 2R across the beam, upstream of the box's bounding sphere (radius R).
struct Beam {
    Vec3 centre, u, v, travel;
    double radius;
    Beam(const Grid& g, const Vec3& w) : travel(w) {
        const Vec3 hi = g.lo + g.cell * double(g.n);
        centre = 0.5 * (g.lo + hi);
        radius = 0.5 * glm::length(hi - g.lo);
        basis(w, u, v);
    }
    // A point of the square at (a, b) in [0, 1)^2, moved to where it enters the box (false: misses).
    bool launch(const Grid& g, double a, double b, Vec3& x) const {
        x = centre + (2 * a - 1) * radius * u + (2 * b - 1) * radius * v - 2 * radius * travel;
        return enterBox(g.lo, g.lo + g.cell * double(g.n), x, travel);
    }
    double area() const { return 4 * radius * radius; }
};

// Photons along unit `travel` into a grid: a beam over its bounding sphere, or on a periodic
// grid the top face (travelling down) or the bottom one (up), the face's area seen along the
// beam (nothing travels level into an endless layer).
struct Launcher {
    Beam beam;
    bool face = false;
    double areaAcross = 0;
    Launcher(const Grid& g, const Vec3& w) : beam(g, w), face(g.periodic) {
        const Vec3 e = g.hi() - g.lo;
        areaAcross = face ? (std::fabs(w.z) > 1e-6 ? e.x * e.y * std::fabs(w.z) : 0.0) : beam.area();
    }
    bool launch(const Grid& g, double a, double b, Vec3& x) const {
        if (!face) return beam.launch(g, a, b, x);
        if (areaAcross <= 0) return false;
        const Vec3 hi = g.hi();
        x = Vec3(g.lo.x + a * (hi.x - g.lo.x), g.lo.y + b * (hi.y - g.lo.y), beam.travel.z < 0 ? hi.z : g.lo.z);
        x.z += (beam.travel.z < 0 ? -1e-9 : 1e-9) * (hi.z - g.lo.z);
        return true;
    }
};

// Sun photons, stratified over the beam's square (a jittered m x m grid). The first flight ends
// at the first scattering, which single scattering accounts for exactly; every later flight is
// scored, fluence and net flux per unit irradiance: into `few` after 1 to kFewScatterings
// scatterings, into `many` after more.
void traceSun(const Scene& scene, const Grid& g, const RadianceGridSettings& s, std::vector<glm::vec4>& few,
              std::vector<glm::vec4>& many, const std::atomic<bool>* cancel) {
    few.assign(g.sigma.size(), glm::vec4(0.0f));
    many.assign(g.sigma.size(), glm::vec4(0.0f));
    if (s.sunPhotons == 0) return;
    const Launcher beam(g, -scene.sun.direction);
    const int side = std::max(1, int(std::sqrt(double(s.sunPhotons))));
    const int total = side * side, perBatch = (total + kBatches - 1) / kBatches;
    const double power = beam.areaAcross / total;
    const double albedo = scene.medium.albedo, hg = scene.medium.hgG;
    std::vector<std::vector<glm::vec4>> talliesFew(kBatches), talliesMany(kBatches);
    parallelFor(kBatches, [&](int b) {
        if (cancel && *cancel) return;
        Rng rng(std::uint64_t(s.seed) * 0x9E3779B97F4A7C15ull + std::uint64_t(b) * 2 + 1);
        talliesFew[b].assign(g.sigma.size(), glm::vec4(0.0f));
        talliesMany[b].assign(g.sigma.size(), glm::vec4(0.0f));
        for (int j = b * perBatch; j < std::min(total, (b + 1) * perBatch); ++j) {
            Vec3 x, w = beam.beam.travel;
            // Drawn one by one: a call's arguments are evaluated in the compiler's order (GCC's
            // right to left is kept, so that Clang's build traces the same photons).
            const double v = (j / side + rng.uniform()) / side, u = (j % side + rng.uniform()) / side;
            if (!beam.launch(g, u, v, x)) continue;
            if (!flight(g, x, w, rng, [](std::size_t, double) {})) continue;
            double weight = power;
            for (int bounce = 0; bounce < kMaxBounces; ++bounce) {
                weight *= albedo;
                w = sampleHg(w, hg, rng);
                const glm::vec4 dir(glm::vec3(w), 1.0f);
                std::vector<glm::vec4>& tally = bounce < kFewScatterings ? talliesFew[b] : talliesMany[b];
                if (!flight(g, x, w, rng, [&](std::size_t i, double l) { tally[i] += float(weight * l) * dir; })) break;
                if (weight < 1e-3 * power) {  // Russian roulette
                    if (rng.uniform() < 0.5) break;
                    weight *= 2;
                }
            }
        }
    });
    sumBatches(talliesFew, few);
    sumBatches(talliesMany, many);
}

// The format's environment radiance seen looking along unit v.
Vec3 skyRadianceAlong(const Sky& sky, const Vec3& v) {
    return v.z >= 0 ? sky.horizon + (sky.zenith - sky.horizon) * v.z : sky.ground;
}

// Sky and ground photons: directions on a spherical Fibonacci lattice (one per photon, the
// lattice turned at random per seed), each from a random point of its beam's square, carrying
// the environment's radiance from where it comes. Every flight is scored (the unscattered
// skylight inside the cloud is part of this light): rgb fluence, luminance flux and c20.
void traceSky(const Scene& scene, const Grid& g, const RadianceGridSettings& s, std::vector<glm::vec4>& rgb,
              std::vector<glm::vec4>& flux, const std::atomic<bool>* cancel) {
    rgb.assign(g.sigma.size(), glm::vec4(0.0f));
    flux.assign(g.sigma.size(), glm::vec4(0.0f));
    if (s.skyPhotons == 0) return;
    const int total = s.skyPhotons, perBatch = (total + kBatches - 1) / kBatches;
    const double albedo = scene.medium.albedo, hg = scene.medium.hgG;
    const double turn = 2 * std::numbers::pi * Rng(s.seed ^ 0xABCDEFull).uniform();
    std::vector<std::vector<glm::vec4>> tallyRgb(kBatches), tallyFlux(kBatches);
    parallelFor(kBatches, [&](int b) {
        if (cancel && *cancel) return;
        Rng rng(std::uint64_t(s.seed) * 0xC2B2AE3D27D4EB4Full + std::uint64_t(b) * 2 + 1);
        tallyRgb[b].assign(g.sigma.size(), glm::vec4(0.0f));
        tallyFlux[b].assign(g.sigma.size(), glm::vec4(0.0f));
        for (int j = b * perBatch; j < std::min(total, (b + 1) * perBatch); ++j) {
            const double cz = 1 - 2 * (j + 0.5) / total, phi = turn + j * 2.399963229728653,
                         sz = std::sqrt(1 - cz * cz);
            Vec3 w(sz * std::cos(phi), sz * std::sin(phi), cz);
            const Launcher beam(g, w);
            Vec3 x;
            const double v = rng.uniform(), u = rng.uniform();  // one by one, as above
            if (!beam.launch(g, u, v, x)) continue;
            // Radiance L from a direction of solid angle 4 pi / total through the square.
            Vec3 weight = skyRadianceAlong(scene.sky, -w) * (4 * std::numbers::pi * beam.areaAcross / total);
            for (int bounce = 0; bounce < kMaxBounces; ++bounce) {
                const glm::vec3 c(weight), dir(w);
                const float lum = glm::dot(c, glm::vec3(0.2126f, 0.7152f, 0.0722f));
                const glm::vec4 f(lum * dir, lum * 0.3153916f * (3 * dir.z * dir.z - 1));
                const bool hit = flight(g, x, w, rng, [&](std::size_t i, double l) {
                    tallyRgb[b][i] += glm::vec4(c * float(l), 0.0f);
                    tallyFlux[b][i] += f * float(l);
                });
                if (!hit) break;
                weight *= albedo;
                w = sampleHg(w, hg, rng);
                if (lum < 1e-4f) {  // Russian roulette
                    if (rng.uniform() < 0.5) break;
                    weight *= 2;
                }
            }
        }
    });
    sumBatches(tallyRgb, rgb);
    sumBatches(tallyFlux, flux);
}

// The optical depth along unit w from p (inside the periodic grid g) beyond where the ray first
// leaves the box across (x or y): 0 when it leaves through the top or the bottom first.
double beyondTile(const Grid& g, const Vec3& p, const Vec3& w) {
    double exitAcross = INFINITY, exitZ = INFINITY;
    const Vec3 hi = g.hi();
    for (int k = 0; k < 3; ++k) {
        if (w[k] == 0) continue;
        const double t = ((w[k] > 0 ? hi[k] : g.lo[k]) - p[k]) / w[k];
        (k == 2 ? exitZ : exitAcross) = std::min(k == 2 ? exitZ : exitAcross, t);
    }
    if (!(exitAcross < exitZ)) return 0;
    Vec3 x = p + exitAcross * w;
    for (int k = 0; k < 2; ++k) {  // through the side: in again at the opposite one
        const double period = hi[k] - g.lo[k];
        if (x[k] >= hi[k] - 1e-9 * period && w[k] > 0) x[k] -= period;
        else if (x[k] <= g.lo[k] + 1e-9 * period && w[k] < 0) x[k] += period;
        x[k] = std::clamp(x[k], g.lo[k], hi[k]);
    }
    double tau = 0;
    flightTo(g, x, w, INFINITY, [&](std::size_t i, double l) { tau += g.sigma[i] * l; });
    return tau;
}

// The eroded profile's depth along the ray p + t s (o, d: its unit-space origin and direction in
// one ellipsoid) for t >= 0, as erodedSegmentDepth: in pieces of at most `piece` metres, each
// eroded by the grid's delta at its middle.
double erodedSunDepth(const GridErosion& erosion, const glm::vec3& o, const glm::vec3& d, const Vec3& p, const Vec3& s,
                      double piece) {
    const model::ChordSpan c = model::chordSpan(o, d, 0.0f, 1e30f);
    if (c.h2 <= 0.0f || !(c.u1 > c.u0)) return 0;
    const int pieces = std::max(1, int(std::ceil((c.u1 - c.u0) / c.len / piece)));
    const float step = (c.u1 - c.u0) / float(pieces);
    double sum = 0;
    for (int i = 0; i < pieces; ++i) {
        const float ua = c.u0 + float(i) * step;
        const double t = (c.tc + ua + 0.5f * step) / c.len;
        sum += model::erodedPiece(c.h2, ua, ua + step, erosion.at(p + t * s));
    }
    return std::max(sum, 0.0) / c.len;
}

// The sun's transmittance at the centres of the voxels of the finer grid (`n` per side over
// g's box), its optical depth closed form through every ellipsoid (with the detail, in pieces
// of a fine voxel, each closed form); on a periodic grid, past
// where the ray first leaves the box across, on through g's voxelised field of the tiles beyond
// until it leaves through the top or the bottom.
std::vector<float> sunTransmittances(const Scene& scene, const Cloud& cloud, const Grid& g, int n,
                                     const GridErosion& erosion, double power) {
    // Per ellipsoid, the arguments of model::segmentDepth(M (p - c), M s, 0, infinity), M (p - c)
    // stepped from voxel to voxel rather than multiplied out: the finer grid has
    // kSunRefinement^3 times the voxels of the diffuse light's.
    struct Shape {
        Vec3 origin, step[3];
        glm::vec3 sun;
        double weight;
        Vec3 center;
        double radius;
    };
    const Vec3 cell = g.cell * double(g.n) / double(n), sun = scene.sun.direction;
    std::vector<Shape> shapes;
    for (const Ellipsoid& e : cloud.ellipsoids) {
        if (!(e.density > 0)) continue;
        const glm::dmat3 unit = ellipsoidToUnit(e);
        shapes.push_back({unit * (g.lo + 0.5 * cell - e.center),
                          {unit * Vec3(cell.x, 0, 0), unit * Vec3(0, cell.y, 0), unit * Vec3(0, 0, cell.z)},
                          glm::vec3(unit * sun),
                          e.density * scene.medium.extinction,
                          e.center,
                          std::max({e.radii.x, e.radii.y, e.radii.z})});
    }
    // Only the voxels whose ray towards the sun can reach an ellipsoid cross it: those in the
    // shadow of its bounding sphere (radius R), p = c + q - t s with |q| <= R and t >= 0. Every
    // voxel crossing every ellipsoid cost n^3 N: one generated cumulus of 100000 ellipsoids took
    // minutes (issue 38); the shadows cost about N R^2 n / cell^2. The sums are the same, term
    // by term (a voxel outside every shadow gets a 0 from each).
    const Vec3 boxHi = g.lo + cell * double(n);
    const double piece = std::max({cell.x, cell.y, cell.z});
    std::vector<float> out(std::size_t(n) * n * n);
    parallelFor(n, [&](int z) {
        std::vector<double> tau(std::size_t(n) * n, 0.0);
        const double pz = g.lo.z + (z + 0.5) * cell.z;
        for (const Shape& e : shapes) {
            const Vec3 c = e.center;
            const double r = e.radius;
            // The t of the points of the shadow in this slice.
            double t0 = 0, t1 = glm::length(boxHi - g.lo) + glm::length(c - 0.5 * (g.lo + boxHi)) + r;
            if (std::abs(sun.z) > 1e-12) {
                double a = (c.z - r - pz) / sun.z, b = (c.z + r - pz) / sun.z;
                if (a > b) std::swap(a, b);
                t0 = std::max(t0, a), t1 = std::min(t1, b);
            } else if (std::abs(pz - c.z) > r) {
                continue;
            }
            if (t0 > t1) continue;
            int lo[2], hi[2];
            for (int k = 0; k < 2; ++k) {  // x, y: c - t s +- R over [t0, t1], in voxels, one voxel's margin
                const double u = c[k] - t0 * sun[k], v = c[k] - t1 * sun[k];
                lo[k] = std::max(0, int(std::floor((std::min(u, v) - r - g.lo[k]) / cell[k] - 0.5)) - 1);
                hi[k] = std::min(n - 1, int(std::ceil((std::max(u, v) + r - g.lo[k]) / cell[k] - 0.5)) + 1);
            }
            for (int y = lo[1]; y <= hi[1]; ++y)
                for (int x = lo[0]; x <= hi[0]; ++x) {
                    const glm::vec3 o(e.origin + double(x) * e.step[0] + double(y) * e.step[1] + double(z) * e.step[2]);
                    if (glm::dot(o, o) >= 1 && glm::dot(o, e.sun) >= 0)
                        continue;  // outside it, the sun away from it: 0
                    tau[std::size_t(y) * n + x] +=
                        e.weight * (erosion.on() ? erodedSunDepth(erosion, o, e.sun,
                                                                  g.lo + (Vec3(x, y, z) + 0.5) * cell, sun, piece)
                                                 : model::segmentDepth(o, e.sun, 0.0f, 1e30f));
                }
        }
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                double t = tau[std::size_t(y) * n + x];
                if (g.periodic) t += beyondTile(g, g.lo + (Vec3(x, y, z) + 0.5) * cell, sun);
                out[(std::size_t(z) * n + y) * n + x] = float(std::exp(-power * t));
            }
    });
    return out;
}

// The power p of the sun's transmittance the finer grid holds (CloudRadiance::sunPower): 1 where
// a fine voxel holds little optical depth, towards 0 (the optical depth interpolated) where it
// holds much. Across a fine voxel of matter whose depth to the sun grows by delta, T interpolated
// between its ends overestimates T by up to cosh(delta / 2): 18% for delta = 1.2 (real cumulus,
// 0.075 /m, in 16 m voxels); T^p interpolated, by cosh(p delta / 2)^(1 / p), about
// exp(p delta^2 / 8). Across a shadow's edge, where the depth steps, T interpolated is the
// better guess (the edge anywhere in the voxel) and T^p with p < 1 darkens it: cumulus27's
// single scattering read 0.96 of the path tracer's with the depth interpolated, 0.986 with T.
// So p keeps the interior's error near kSunInterpolationError, and is 1 wherever that allows.
// delta: the mean extinction of the voxels with matter across a mean fine voxel side.
constexpr double kSunInterpolationError = 0.02;
constexpr double kMinSunPower = 0.05;
double sunInterpolationPower(const Grid& g, int fine) {
    double sum = 0;
    std::size_t count = 0;
    for (float s : g.sigma)
        if (s > 0) sum += s, ++count;
    if (count == 0) return 1;
    const Vec3 cell = g.cell * double(g.n) / double(fine);
    const double delta = sum / double(count) * (cell.x + cell.y + cell.z) / 3;
    return std::clamp(8 * kSunInterpolationError / (delta * delta), kMinSunPower, 1.0);
}

// [1 2 1] along each axis, clamped at the box's faces.
void smooth(std::vector<glm::vec4>& f, int n) {
    std::vector<glm::vec4> tmp(f.size());
    auto at = [n](int x, int y, int z) { return (std::size_t(z) * n + y) * n + x; };
    for (int axis = 0; axis < 3; ++axis) {
        for (int z = 0; z < n; ++z)
            for (int y = 0; y < n; ++y)
                for (int x = 0; x < n; ++x) {
                    int c[3] = {x, y, z}, lo[3] = {x, y, z}, hi[3] = {x, y, z};
                    lo[axis] = std::max(c[axis] - 1, 0);
                    hi[axis] = std::min(c[axis] + 1, n - 1);
                    tmp[at(x, y, z)] =
                        0.25f * f[at(lo[0], lo[1], lo[2])] + 0.5f * f[at(x, y, z)] + 0.25f * f[at(hi[0], hi[1], hi[2])];
                }
        f.swap(tmp);
    }
}

}  // namespace

void cloudBox(const Cloud& cloud, Vec3& lo, Vec3& hi) {
    lo = Vec3(INFINITY), hi = Vec3(-INFINITY);
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const Vec3 half = halfExtents(e);
        lo = glm::min(lo, e.center - half);
        hi = glm::max(hi, e.center + half);
    }
    if (cloud.ellipsoids.empty()) lo = hi = Vec3(0.0);
}

void radianceBox(const Cloud& cloud, Vec3& lo, Vec3& hi) {
    cloudBox(cloud, lo, hi);
    if (!cloud.tiled()) return;
    lo = Vec3(cloud.tileMin, lo.z);
    hi = Vec3(cloud.tileMax, hi.z);
}

void validate(const RadianceGridSettings& s) {
    validate(s.backgroundWork);
    if (s.size < 4 || s.size > 128) throw std::invalid_argument("radiance grid size must be 4..128 voxels");
    if (s.sunPhotons < 0 || s.sunPhotons > (1 << 26))
        throw std::invalid_argument("radiance grid sunPhotons must be 0..2^26");
    if (s.skyPhotons < 0 || s.skyPhotons > (1 << 26))
        throw std::invalid_argument("radiance grid skyPhotons must be 0..2^26");
    if (s.smoothing < 0 || s.smoothing > 8) throw std::invalid_argument("radiance grid smoothing must be 0..8 passes");
    if (!(s.megabytes >= 1 && s.megabytes <= 65536))
        throw std::invalid_argument("radiance grid megabytes must be 1..65536");
}

double cloudOpticalRadius(const Scene& scene, const Cloud& cloud) {
    Vec3 lo, hi;
    cloudBox(cloud, lo, hi);
    const Vec3 extent = glm::max(hi - lo, Vec3(1.0));
    double sum = 0, volume = 0;
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const double v = e.radii.x * e.radii.y * e.radii.z;
        sum += v * e.density, volume += v;
    }
    const double density = volume > 0 ? sum / volume : 0;
    return scene.medium.extinction * density * 0.5 * std::cbrt(extent.x * extent.y * extent.z);
}

int radianceGridSize(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& s) {
    if (!s.fitToCloud) return s.size;
    const double tau = cloudOpticalRadius(scene, cloud);
    int n = 8;
    while (n < s.size && n < tau) n *= 2;
    return std::min(n, s.size);
}

Scene lightSources(const Scene& scene) {
    Scene s;
    s.sun = scene.sun, s.sky = scene.sky, s.medium = scene.medium;
    if (scene.lighting) s.sun.direction = scene.lighting->sunDirection, s.sky = scene.lighting->sky;
    return s;
}

CloudRadiance computeCloudRadiance(const Scene& sceneIn, const Cloud& cloud, const RadianceGridSettings& settings,
                                   const std::atomic<bool>* cancel) {
    validate(settings);
    const Scene scene = lightSources(sceneIn);  // what lights the grid (Scene::lighting)
    const auto start = std::chrono::steady_clock::now();
    const GridGeometry geometry = gridGeometry(scene, cloud, settings);
    RadianceGridSettings s = settings;
    s.size = geometry.size;
    if (s.size != settings.size) {  // photons in proportion to the cross-section (see fitToCloud)
        const double share = std::pow(double(s.size) / settings.size, 2);
        s.sunPhotons = int(std::lround(settings.sunPhotons * share));
        s.skyPhotons = int(std::lround(settings.skyPhotons * share));
    }
    CloudRadiance out;
    out.size = s.size;
    out.boxMin = geometry.lo;
    out.boxExtent = geometry.extent;
    Grid g;
    g.n = s.size;
    g.lo = out.boxMin;
    g.cell = out.boxExtent / double(s.size);
    g.periodic = cloud.tiled();
    const GridErosion erosion(scene, cloud, geometry);
    g.sigma = voxelise(scene, cloud, g, erosion);
    traceSun(scene, g, s, out.sunFew, out.sunMany, cancel);
    traceSky(scene, g, s, out.skyTau, out.skyFlux, cancel);
    if (cancel && *cancel) return CloudRadiance{};
    const float perVolume = float(1 / (g.cell.x * g.cell.y * g.cell.z));  // track length per volume: fluence
    for (std::size_t i = 0; i < out.voxels(); ++i) {
        out.sunFew[i] *= perVolume;
        out.sunMany[i] *= perVolume;
        out.skyTau[i] *= perVolume;
        out.skyFlux[i] *= perVolume;
    }
    for (int k = 0; k < s.smoothing; ++k) {
        smooth(out.sunFew, s.size);
        smooth(out.sunMany, s.size);
        smooth(out.skyTau, s.size);
        smooth(out.skyFlux, s.size);
    }
    out.sunPower = float(sunInterpolationPower(g, out.sunSize()));
    out.sunTransmittance = sunTransmittances(scene, cloud, g, out.sunSize(), erosion, out.sunPower);
    out.computeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return out;
}

RadianceSample sampleRadiance(const CloudRadiance& grid, const Vec3& world) {
    RadianceSample r;
    if (grid.size == 0) return r;
    trilinear(grid.boxMin, grid.boxExtent, grid.size, world, [&](std::size_t i, float w) {
        r.sunFew += w * grid.sunFew[i];
        r.sunMany += w * grid.sunMany[i];
        r.skyTau += w * grid.skyTau[i];
        r.skyFlux += w * grid.skyFlux[i];
    });
    float sunPowered = 0;  // T^p interpolated so (model::kMinSunTransmittance), as on the GPU
    trilinear(grid.boxMin, grid.boxExtent, grid.sunSize(), world,
              [&](std::size_t i, float w) { sunPowered += w * grid.sunTransmittance[i]; });
    r.skyTau.w = -std::log(std::max(sunPowered, model::kMinSunTransmittance)) / grid.sunPower;
    return r;
}

}  // namespace nephele
