// The ray-marcher's host side: its density on the CPU, the no-duplicate
// tracing of Algorithm 2 (the tests check the GPU against them).
#include "nephele/raymarch.hpp"

#include "nephele/cloud_radiance.hpp"
#include "nephele/gardner_model.hpp"
#include "parallel.hpp"
#include "nephele/ellipsoid_space.hpp"

#include <algorithm>
#include <cmath>

namespace nephele {

namespace {

// Steps of one light march at most: its step is at least the candidates' span / this. At the
// largest light grid (128) that is still over 4 steps per voxel along the grid's diagonal, so
// usual clouds (at 25 m, under 25 km across) are marched at the step asked for.
constexpr double kMaxMarchSteps = 1024;

// One ellipsoid in the form the march needs: world offset -> unit sphere.
struct UnitEllipsoid {
    glm::dmat3 unit;  // M = diag(1/r) R^T
    Vec3 center;      // m, world
    double density;   // the format's density scale
};

std::vector<UnitEllipsoid> prepare(const Cloud& cloud) {
    std::vector<UnitEllipsoid> out;
    for (const Ellipsoid& e : cloud.ellipsoids)
        if (e.density > 0) out.push_back({ellipsoidToUnit(e), e.center, e.density});
    return out;
}

// The noise's density factor at x, max(0, 1 + kappa n(x)) (raymarch.hpp).
double noiseFactor(double kappa, const Vec3& x, const NoiseVolume* noise, double period) {
    if (kappa <= 0 || !noise) return 1.0;
    return std::max(0.0, 1.0 + kappa * noise->sample(glm::vec3(x / period)));
}

// A candidate of the march (Algorithm 1's list entry): the ray meets the ellipsoid over
// [in, out]; q(l) = a (l - lc)^2 + qmin in unit space.
struct Candidate {
    double in, out, a, lc, qmin, density;
};

// Candidates along o + l dir, l >= 0, sorted by entry with insertion sort (Algorithm 1).
std::vector<Candidate> candidates(const std::vector<UnitEllipsoid>& ells, const Vec3& o, const Vec3& dir) {
    std::vector<Candidate> list;
    for (const UnitEllipsoid& e : ells) {
        const Vec3 ou = e.unit * (o - e.center), du = e.unit * dir;
        const double a = glm::dot(du, du);
        const double lc = -glm::dot(ou, du) / a;
        const Vec3 perp = ou + lc * du;
        const double qmin = glm::dot(perp, perp);
        if (qmin >= 1) continue;
        const double h = std::sqrt((1 - qmin) / a);
        const double in = std::max(lc - h, 0.0), out = lc + h;
        if (out <= in) continue;
        list.push_back({in, out, a, lc, qmin, e.density});
        for (std::size_t h2 = list.size() - 1; h2 > 0 && list[h2].in < list[h2 - 1].in; --h2)
            std::swap(list[h2], list[h2 - 1]);
    }
    return list;
}

// Sum of the active candidates' densities at l (candidates sorted by entry).
double densityAlong(const std::vector<Candidate>& list, double l) {
    double sum = 0;
    for (const Candidate& c : list) {
        if (c.in > l) break;
        if (l >= c.out) continue;
        const double d = l - c.lc;
        const double q = c.a * d * d + c.qmin;
        if (q < 1) sum += c.density * (1 - q) * (1 - q);
    }
    return sum;
}

double marchNdt(const std::vector<UnitEllipsoid>& ells, double kappa, const Vec3& o, const Vec3& dir, double step,
                const NoiseVolume* noise, double period, double stopDepth) {
    const std::vector<Candidate> list = candidates(ells, o, dir);
    if (list.empty()) return 0;
    // At most kMaxMarchSteps steps over the candidates' whole span, whatever the step asked for
    // and the clouds' size (a cloud of 1e9 m at 25 m took 10^7 steps a voxel).
    double last = list[0].out;
    for (const Candidate& c : list) last = std::max(last, c.out);
    step = std::max(step, (last - list[0].in) / kMaxMarchSteps);
    // Algorithm 2: lambda only moves forward; a candidate already passed is skipped, a gap
    // before the next candidate is jumped over.
    double lambda = list[0].in, depth = 0;
    for (const Candidate& c : list) {
        if (lambda > c.out) continue;
        if (lambda < c.in) lambda = c.in;
        while (lambda < c.out) {
            // The step always moves lambda, even where it is under the precision of the distance.
            const double end = std::max(std::min(lambda + step, c.out), std::nextafter(lambda, INFINITY));
            const double mid = 0.5 * (lambda + end);
            const double density = densityAlong(list, mid);
            if (density > 0) depth += density * noiseFactor(kappa, o + mid * dir, noise, period) * (end - lambda);
            lambda = end;
            if (depth > stopDepth) return depth;
        }
    }
    return depth;
}

}  // namespace

NoiseSettings raymarchNoiseSettings(const RaymarchSettings& settings) {
    NoiseSettings n;
    n.octaves = settings.octaves;
    return n;
}

double raymarchNoisePeriod(const Medium& medium, const NoiseSettings& noise) { return medium.noiseScale * noise.cells; }

bool raymarchCloudBox(const Cloud& cloud, Vec3& lo, Vec3& hi) {
    cloudBox(cloud, lo, hi);
    return !cloud.ellipsoids.empty();
}

double raymarchExtinction(const Medium& medium, const Cloud& cloud, const Vec3& x, const NoiseVolume* noise,
                          double noisePeriod) {
    double sum = 0;
    for (const UnitEllipsoid& e : prepare(cloud)) {
        const Vec3 p = e.unit * (x - e.center);
        const double q = glm::dot(p, p);
        if (q < 1) sum += e.density * (1 - q) * (1 - q);
    }
    return sum > 0 ? medium.extinction * sum * noiseFactor(std::max(medium.noise, 0.0), x, noise, noisePeriod) : 0.0;
}

double marchDensityNdt(const Medium& medium, const Cloud& cloud, const Vec3& o, const Vec3& dir, double step,
                       const NoiseVolume* noise, double noisePeriod, double stopDepth) {
    return marchNdt(prepare(cloud), std::max(medium.noise, 0.0), o, glm::normalize(dir), step, noise, noisePeriod,
                    stopDepth);
}

}  // namespace nephele
