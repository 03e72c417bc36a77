// Expansion of `generate` entries into ellipsoid clouds (see nephele/generate.hpp).
#include "nephele/generate.hpp"

#include "nephele/limits.hpp"

#include "input_file.hpp"
#include "obj_reader.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>
#include <string_view>
#include <vector>
#include <unordered_map>

namespace nephele {

ObjError::ObjError(std::string file, int line, std::string fault)
    : std::runtime_error(file + ":" + std::to_string(line) + ": " + fault),
      file_(std::move(file)),
      line_(line),
      fault_(std::move(fault)) {}

namespace {

// Portable random variates: std::mt19937's output is fixed by the standard, the mappings
// below are ours (std::uniform_real_distribution and std::normal_distribution are not).
class Random {
public:
    explicit Random(unsigned seed) : engine_(seed) {}
    // Uniform in [0, 1) with 53 random bits.
    double uniform() {
        const std::uint32_t a = engine_() >> 5, b = engine_() >> 6;  // 27 and 26 bits
        return (a * 67108864.0 + b) * (1.0 / 9007199254740992.0);
    }
    // Uniform in [-1, 1).
    double symmetric() { return 2.0 * uniform() - 1.0; }
    // Two independent standard normal variates (Box-Muller).
    std::pair<double, double> normalPair() {
        const double u1 = 1.0 - uniform();  // (0, 1]: log is finite
        const double u2 = uniform();
        const double r = std::sqrt(-2.0 * std::log(u1));
        return {r * std::cos(2.0 * std::numbers::pi * u2), r * std::sin(2.0 * std::numbers::pi * u2)};
    }

private:
    std::mt19937 engine_;
};

// ---------------------------------------------------------------- cumulus

// The hollow core (paper, text before eq. 17; its y is our z): offsets in m, sigma in m.
bool inHollowCore(const Vec3& offset, const Vec3& sigma) {
    return std::abs(offset.x) < 0.75 * sigma.x && std::abs(offset.y) < 0.75 * sigma.y &&
           std::abs(offset.z) < sigma.z / 3.0;
}

struct Placed {
    Vec3 offset;    // m, from the cloud centre
    double radius;  // m, before aspect
};

// Eq. 17's containment pruning, exact for ellipsoids sharing axes and aspect: in space scaled
// by 1/aspect they are spheres. Visits the alive ones largest first and drops one inside any
// kept one (containment is transitive, so comparing against the kept ones is the same as
// against all). j is inside i only if |c_i - c_j| <= r_i - r_j <= rMax - rMin, so only the kept
// ones in the 27 grid cells of that size around c_j are compared: linear in the count for a
// Gaussian cloud (the full comparison took 27 s at count 100000), and the same answer.
int pruneContained(const std::vector<Placed>& placed, const std::vector<size_t>& alive, const Vec3& aspect,
                   std::vector<bool>& keep) {
    std::vector<size_t> order = alive;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return placed[a].radius > placed[b].radius; });
    if (order.empty()) return 0;
    const double rMax = placed[order.front()].radius, rMin = placed[order.back()].radius;
    const double cell = std::max(rMax - rMin, 1e-6 * rMax) * (1 + 1e-9);
    // Cell indices are clamped to +-2^19: clamping keeps neighbours within one cell of each
    // other, so the answer stays exact however far a hostile clamp range spreads the cloud.
    auto cellOf = [&](const Vec3& c) {
        return glm::i64vec3(glm::clamp(glm::floor(c / cell), Vec3(-524288.0), Vec3(524288.0)));
    };
    auto key = [](const glm::i64vec3& k) {
        return std::uint64_t(k.x + 524289) << 42 | std::uint64_t(k.y + 524289) << 21 | std::uint64_t(k.z + 524289);
    };
    std::unordered_map<std::uint64_t, std::vector<size_t>> kept;
    int contained = 0;
    for (size_t j : order) {
        const Vec3 cj = placed[j].offset / aspect;
        const glm::i64vec3 home = cellOf(cj);
        bool inside = false;
        for (int dz = -1; dz <= 1 && !inside; ++dz)
            for (int dy = -1; dy <= 1 && !inside; ++dy)
                for (int dx = -1; dx <= 1 && !inside; ++dx) {
                    const auto it = kept.find(key(home + glm::i64vec3(dx, dy, dz)));
                    if (it == kept.end()) continue;
                    for (size_t i : it->second)
                        if (glm::length(placed[i].offset / aspect - cj) + placed[j].radius <= placed[i].radius) {
                            inside = true;
                            break;
                        }
                }
        if (inside) {
            keep[j] = false;
            ++contained;
        } else {
            kept[key(home)].push_back(j);
        }
    }
    return contained;
}

// The mean of sum_i (1 - q_i)^2 (density 1) over the volume the ellipsoids fill, on a grid of
// kMeanGrid^3 cell centres over their box: each ellipsoid adds (1 - q)^2 to the cells within
// its box, so the cost is the cells the ellipsoids cover. For unrotated ellipsoids (a cumulus').
double meanDensityOverVolume(const std::vector<Ellipsoid>& ellipsoids) {
    constexpr int kMeanGrid = 64;
    if (ellipsoids.empty()) return kProfileMean;
    Vec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const Ellipsoid& e : ellipsoids) lo = glm::min(lo, e.center - e.radii), hi = glm::max(hi, e.center + e.radii);
    const Vec3 cell = (hi - lo) / double(kMeanGrid);
    std::vector<double> sum(std::size_t(kMeanGrid) * kMeanGrid * kMeanGrid, 0.0);
    for (const Ellipsoid& e : ellipsoids) {
        const glm::ivec3 a = glm::clamp(glm::ivec3(glm::floor((e.center - e.radii - lo) / cell)), 0, kMeanGrid - 1);
        const glm::ivec3 b = glm::clamp(glm::ivec3(glm::floor((e.center + e.radii - lo) / cell)), 0, kMeanGrid - 1);
        for (int k = a.z; k <= b.z; ++k)
            for (int j = a.y; j <= b.y; ++j)
                for (int i = a.x; i <= b.x; ++i) {
                    const Vec3 u = (lo + (Vec3(i, j, k) + 0.5) * cell - e.center) / e.radii;
                    const double q = glm::dot(u, u);
                    if (q < 1) sum[(std::size_t(k) * kMeanGrid + j) * kMeanGrid + i] += (1 - q) * (1 - q);
                }
    }
    double total = 0;
    std::size_t filled = 0;
    for (const double v : sum)
        if (v > 0) total += v, ++filled;
    return filled ? total / double(filled) : kProfileMean;
}

}  // namespace

Cloud generateCumulus(const Generator& g, GenerateStats* stats) {
    Random rng(g.seed);
    std::vector<Placed> placed(static_cast<size_t>(g.count));
    for (Placed& p : placed) {
        // Eq. 14: three normal variates per ellipsoid (x, y from one pair, z from the next;
        // the fourth is discarded so that every ellipsoid draws the same amount).
        const auto [nx, ny] = rng.normalPair();
        const double nz = rng.normalPair().first;
        const Vec3 n(nx, ny, nz);
        const Vec3 z = glm::clamp(n, g.clampLo, g.clampHi);  // in units of sigma
        p.offset = z * g.sigma;
        // Eq. 16: r = eps (1 - 0.1 |offset / (2 sigma)|) = eps (1 - 0.05 d).
        const double d = glm::length(z);
        p.radius = g.maxRadius * std::max(1.0 - 0.05 * d, 0.05);
    }

    std::vector<size_t> alive;  // placement order
    int hollow = 0;
    for (size_t i = 0; i < placed.size(); ++i) {
        if (g.hollow && inHollowCore(placed[i].offset, g.sigma)) ++hollow;
        else alive.push_back(i);
    }

    std::vector<bool> keep(placed.size(), false);
    for (size_t i : alive) keep[i] = true;
    const int contained = g.pruneContained ? pruneContained(placed, alive, g.aspect, keep) : 0;

    Cloud cloud;
    cloud.name = g.name;
    for (size_t i = 0; i < placed.size(); ++i) {
        if (!keep[i]) continue;
        Ellipsoid e;
        e.center = g.center + placed[i].offset;
        e.radii = placed[i].radius * g.aspect;
        e.density = g.density;
        cloud.ellipsoids.push_back(e);
    }
    if (g.cumulusMedium) {
        const double scale = kProfileMean / meanDensityOverVolume(cloud.ellipsoids);
        for (Ellipsoid& e : cloud.ellipsoids) e.density *= scale;
    }
    if (stats) {
        *stats = GenerateStats{};
        stats->name = g.name;
        stats->placed = g.count;
        stats->prunedHollow = hollow;
        stats->prunedContained = contained;
        stats->kept = static_cast<int>(cloud.ellipsoids.size());
    }
    return cloud;
}

// ---------------------------------------------------------------- rotations

Vec3 degreesFromRotation(const glm::dmat3& R) {
    // glm is column-major: R[col][row]. R = Rz(c) Ry(b) Rx(a):
    //   row 2 = (-sin b, cos b sin a, cos b cos a), column 0 = cos b (cos c, sin c, .)
    const double r20 = R[0][2], r21 = R[1][2], r22 = R[2][2];
    const double r00 = R[0][0], r10 = R[0][1], r01 = R[1][0], r02 = R[2][0];
    double a, b, c;
    if (std::abs(r20) < 1.0 - 1e-12) {
        b = std::asin(-r20);
        a = std::atan2(r21, r22);
        c = std::atan2(r10, r00);
    } else if (r20 < 0) {  // b = +90: R01 = sin(a - c), R02 = cos(a - c); take c = 0
        b = std::numbers::pi / 2;
        c = 0;
        a = std::atan2(r01, r02);
    } else {  // b = -90: R01 = -sin(a + c), R02 = -cos(a + c); take c = 0
        b = -std::numbers::pi / 2;
        c = 0;
        a = std::atan2(-r01, -r02);
    }
    return glm::degrees(Vec3(a, b, c));
}

// ---------------------------------------------------------------- mesh

namespace detail {

namespace {

bool parseDouble(std::string_view s, double& v) {
    const char* end = s.data() + s.size();
    const auto r = std::from_chars(s.data(), end, v);
    return r.ec == std::errc() && r.ptr == end && std::isfinite(v);
}

// The words of a line, split at spaces, tabs and carriage returns.
void splitWords(std::string_view line, std::vector<std::string_view>& words) {
    words.clear();
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
        size_t j = i;
        while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
        if (j > i) words.push_back(line.substr(i, j - i));
        i = j;
    }
}

std::string quoted(std::string_view word) {
    std::string s(word.substr(0, 40));
    for (char& c : s)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return "'" + s + (word.size() > 40 ? "...'" : "'");
}

void readVertex(const std::vector<std::string_view>& w, ObjMesh& mesh, const std::string& file, int lineNo) {
    // x y z [w], optionally followed by r g b (a common extension): take x y z.
    if (w.size() < 4)
        throw ObjError(file, lineNo, "a 'v' line needs 3 coordinates, got " + std::to_string(w.size() - 1));
    Vec3 v;
    for (int k = 0; k < 3; ++k)
        if (!parseDouble(w[1 + k], v[k]))
            throw ObjError(
                file, lineNo,
                "vertex coordinate " + std::to_string(k + 1) + " is not a finite number: " + quoted(w[1 + k]));
    mesh.vertices.push_back(v);
}

void readFace(const std::vector<std::string_view>& w, ObjMesh& mesh, const std::string& file, int lineNo,
              std::vector<size_t>& idx) {
    if (w.size() < 4)
        throw ObjError(file, lineNo, "a face needs at least 3 vertices, got " + std::to_string(w.size() - 1));
    idx.clear();
    for (size_t k = 1; k < w.size(); ++k) {
        const std::string_view ref = w[k].substr(0, w[k].find('/'));  // v, v/vt, v//vn, v/vt/vn
        long long i = 0;
        const auto r = std::from_chars(ref.data(), ref.data() + ref.size(), i);
        if (ref.empty() || r.ec != std::errc() || r.ptr != ref.data() + ref.size() || i == 0)
            throw ObjError(file, lineNo,
                           "face vertex " + std::to_string(k) + ": " + quoted(w[k]) +
                               " is not a vertex index (1-based, or negative from the end)");
        const long long n = static_cast<long long>(mesh.vertices.size());
        const long long resolved = i > 0 ? i - 1 : n + i;  // -1 = the last vertex so far
        if (resolved < 0 || resolved >= n)
            throw ObjError(file, lineNo,
                           "face vertex " + std::to_string(k) + ": index " + std::to_string(i) + " is out of range (" +
                               std::to_string(n) + " vertices defined so far)");
        idx.push_back(static_cast<size_t>(resolved));
    }
    if (double(mesh.triangles.size() + idx.size() - 2) > limits::kEllipsoidsPerEntry.value)
        throw ObjError(file, lineNo,
                       "more than " + limitValueText(limits::kEllipsoidsPerEntry) +
                           " triangles (one ellipsoid each), over the limit " + limitText(limits::kEllipsoidsPerEntry));
    for (size_t k = 1; k + 1 < idx.size(); ++k) mesh.triangles.push_back({idx[0], idx[k], idx[k + 1]});
}

}  // namespace

ObjMesh parseObj(std::string_view text, const std::string& file) {
    ObjMesh mesh;
    std::vector<std::string_view> w;
    std::vector<size_t> idx;
    int lineNo = 0;
    for (size_t start = 0; start < text.size();) {
        const size_t end = std::min(text.find('\n', start), text.size());
        const std::string_view line = text.substr(start, end - start);
        start = end + 1;
        ++lineNo;
        splitWords(line.substr(0, line.find('#')), w);
        if (w.empty()) continue;
        if (w[0] == "v") readVertex(w, mesh, file, lineNo);
        else if (w[0] == "f") readFace(w, mesh, file, lineNo, idx);
        // Everything else (vn, vt, o, g, s, usemtl, mtllib, l, p, ...) does not shape the cloud.
    }
    if (mesh.triangles.empty()) throw ObjError(file, 0, "has no faces ('f' lines): nothing to make ellipsoids of");
    return mesh;
}

ObjMesh readObj(const std::string& file, std::uint64_t* bytes) {
    std::string text;
    if (auto fault = readRegularFile(file, limits::kObjFileBytes, &text)) throw ObjError(file, 0, *fault);
    if (auto fault = nulByteFault(text)) throw ObjError(file, 0, *fault);
    if (bytes) *bytes = text.size();
    return parseObj(text, file);
}

}  // namespace detail

Cloud generateMesh(const Generator& g, GenerateStats* stats) {
    std::uint64_t bytes = 0;
    const detail::ObjMesh mesh = detail::readObj(g.resolvedPath, &bytes);
    Cloud cloud = detail::meshCloud(mesh, g, stats);
    if (stats) stats->objBytes = bytes;
    return cloud;
}

Cloud detail::meshCloud(const ObjMesh& mesh, const Generator& g, GenerateStats* stats) {
    const glm::dmat3 M = rotationFromDegrees(g.rotationDeg);
    std::vector<Vec3> v(mesh.vertices.size());
    for (size_t i = 0; i < v.size(); ++i) v[i] = g.position + g.scale * (M * mesh.vertices[i]);

    Cloud cloud;
    cloud.name = g.name;
    int degenerate = 0;
    for (const auto& t : mesh.triangles) {
        const Vec3 A = v[t.a], B = v[t.b], C = v[t.c];
        const Vec3 G = (A + B + C) / 3.0;  // eq. 22
        // Steiner circumellipse: G + f1 cos s + f2 sin s passes through A, B, C (f1, f2 are
        // conjugate semi-diameters). Its semi-axes are the singular values of [f1 f2].
        const Vec3 f1 = A - G, f2 = (C - B) / std::sqrt(3.0);
        const double p = glm::dot(f1, f1), q = glm::dot(f1, f2), r = glm::dot(f2, f2);
        const double mean = 0.5 * (p + r), dev = std::sqrt(0.25 * (p - r) * (p - r) + q * q);
        const Vec3 normal = glm::cross(B - A, C - A);
        const double normalLength = glm::length(normal);
        // major * minor = |f1 x f2| (conjugate semi-diameters); this product keeps the minor
        // axis accurate for slivers, where mean - dev would cancel.
        const double major = std::sqrt(mean + dev), minor = major > 0 ? glm::length(glm::cross(f1, f2)) / major : 0.0;
        const double smallest = limits::kSmallestRadius.value;  // thinner is no matter worth drawing
        if (!(major > 0) || !(minor > 1e-9 * major) || !(normalLength > 0) || !(minor >= smallest) ||
            !(g.thicknessRatio * minor >= smallest)) {
            ++degenerate;
            continue;
        }
        // Eigenvector of [[p, q], [q, r]] for the larger eigenvalue mean + dev.
        Vec3 x;
        if (std::abs(q) > 1e-15 * (p + r)) {
            const glm::dvec2 e = glm::normalize(glm::dvec2(mean + dev - r, q));
            x = e.x * f1 + e.y * f2;
        } else {
            x = p >= r ? f1 : f2;
        }
        x = glm::normalize(x);
        const Vec3 z = normal / normalLength;
        x = glm::normalize(x - glm::dot(x, z) * z);  // exactly in the plane
        const Vec3 y = glm::cross(z, x);
        Ellipsoid e;
        e.center = G;
        e.radii = Vec3(major, minor, g.thicknessRatio * minor);
        e.rotationDeg = degreesFromRotation(glm::dmat3(x, y, z));
        e.density = g.density;
        cloud.ellipsoids.push_back(e);
    }
    if (stats) {
        *stats = GenerateStats{};
        stats->name = g.name;
        stats->placed = static_cast<int>(mesh.triangles.size());
        stats->degenerate = degenerate;
        stats->kept = static_cast<int>(cloud.ellipsoids.size());
    }
    return cloud;
}

// ---------------------------------------------------------------- lsystem

namespace {

std::string rewrite(const Generator& g, std::size_t maxSymbols) {
    std::string rule[256];
    bool hasRule[256] = {};
    for (const auto& [symbol, replacement] : g.rules) {
        rule[static_cast<unsigned char>(symbol)] = replacement;
        hasRule[static_cast<unsigned char>(symbol)] = true;
    }
    std::string s = g.axiom;
    for (int it = 0; it < g.iterations; ++it) {
        size_t length = 0;
        for (char c : s) {
            const unsigned char u = static_cast<unsigned char>(c);
            length += hasRule[u] ? rule[u].size() : 1;
            if (length > maxSymbols)
                throw std::length_error(
                    "rewriting " + std::to_string(it + 1) + " of " + std::to_string(g.iterations) +
                    " gives more than " + std::to_string(maxSymbols) + " symbols" +
                    (maxSymbols < kMaxLSystemSymbols ? " (what the scene's other L-systems left)" : "") +
                    ", over the limit " + limitText(limits::kLSystemSymbols) +
                    "; use fewer iterations or shorter rules");
        }
        std::string next;
        next.reserve(length);
        for (char c : s) {
            const unsigned char u = static_cast<unsigned char>(c);
            if (hasRule[u]) next += rule[u];
            else next += c;
        }
        s = std::move(next);
    }
    return s;
}

// Rotates a and b (orthonormal, both perpendicular to the axis) by `angle` radians about
// the axis a x b points along, right-handed: a turns towards b.
void turn(Vec3& a, Vec3& b, double angle) {
    const double c = std::cos(angle), s = std::sin(angle);
    const Vec3 na = c * a + s * b, nb = -s * a + c * b;
    a = na;
    b = nb;
}

}  // namespace

Cloud generateLSystem(const Generator& g, GenerateStats* stats, std::size_t maxSymbols) {
    const std::string s = rewrite(g, std::min(maxSymbols, kMaxLSystemSymbols));
    const size_t spheres = static_cast<size_t>(std::count(s.begin(), s.end(), 'F'));
    if (spheres > kMaxLSystemSpheres)
        throw std::length_error("the rewritten string places " + std::to_string(spheres) + " spheres, over the limit " +
                                limitText(limits::kEllipsoidsPerEntry) + "; use fewer iterations or shorter rules");
    struct Turtle {
        Vec3 position;
        Vec3 heading{1, 0, 0}, left{0, 1, 0}, up{0, 0, 1};  // heading x left = up
    };
    Random rng(g.seed);
    const double angle = g.angleDeg * std::numbers::pi / 180.0;
    Turtle t;
    t.position = g.center;
    std::vector<Turtle> stack;
    Cloud cloud;
    cloud.name = g.name;
    cloud.ellipsoids.reserve(spheres);
    for (char c : s) {
        switch (c) {
            case 'F': {
                const double step = g.step * (1.0 + g.jitter * rng.symmetric());
                const double radius = g.radius * (1.0 + g.jitter * rng.symmetric());
                Ellipsoid e;
                e.center = t.position + 0.5 * step * t.heading;
                e.radii = Vec3(radius);
                e.density = g.density;
                cloud.ellipsoids.push_back(e);
                t.position += step * t.heading;
                break;
            }
            case '+': turn(t.heading, t.left, angle); break;             // yaw left about up
            case '-': turn(t.heading, t.left, -angle); break;            // yaw right
            case '&': turn(t.heading, t.up, -angle); break;              // pitch down about left
            case '^': turn(t.heading, t.up, angle); break;               // pitch up
            case '\\': turn(t.left, t.up, angle); break;                 // roll left about heading
            case '/': turn(t.left, t.up, -angle); break;                 // roll right
            case '|': turn(t.heading, t.left, std::numbers::pi); break;  // turn around
            case '[':
                if (double(stack.size()) >= limits::kLSystemDepth.value)
                    throw std::length_error("the rewritten string nests '[' deeper than the limit " +
                                            limitText(limits::kLSystemDepth));
                stack.push_back(t);
                break;
            case ']':
                if (!stack.empty()) {
                    t = stack.back();
                    stack.pop_back();
                }
                break;
            default: break;
        }
    }
    if (stats) {
        *stats = GenerateStats{};
        stats->name = g.name;
        stats->placed = static_cast<int>(cloud.ellipsoids.size());
        stats->kept = stats->placed;
        stats->symbols = static_cast<std::int64_t>(s.size());
    }
    return cloud;
}

// ---------------------------------------------------------------- scene

namespace {

std::string numberText(double v) {
    char buf[64];
    return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}
std::string vectorText(const Vec3& v) {
    return "[" + numberText(v.x) + ", " + numberText(v.y) + ", " + numberText(v.z) + "]";
}

// A generated cloud keeps the limits an explicit one is held to on load (scene.cpp).
void checkGenerated(const Cloud& cloud, const Medium& medium, const std::string& file, const std::string& at) {
    using namespace limits;
    for (size_t k = 0; k < cloud.ellipsoids.size(); ++k) {
        const Ellipsoid& e = cloud.ellipsoids[k];
        auto fail = [&](const std::string& what) {
            throw SceneError(file, at,
                             "makes ellipsoid " + std::to_string(k) + " (centre " + vectorText(e.center) +
                                 " m, radii " + vectorText(e.radii) + " m) " + what);
        };
        for (int a = 0; a < 3; ++a) {
            if (!withinLimit(std::abs(e.center[a]), kCoordinate)) fail("beyond the limit " + limitText(kCoordinate));
            if (!withinLimit(e.radii[a], kEllipsoidRadius))
                fail("with a radius over the limit " + limitText(kEllipsoidRadius));
            if (!withinLimit(e.radii[a], kSmallestRadius))
                fail("with a radius under the limit " + limitText(kSmallestRadius));
        }
        const double tau = medium.extinction * e.density * (16.0 / 15.0) * e.maxRadius();
        if (!withinLimit(tau, kOpticalDepth))
            fail("with an optical depth of " + numberText(tau) + ", over the limit " + limitText(kOpticalDepth));
    }
}

// Expands one generator within what the scene has left of its budgets.
Cloud expandOne(const Generator& g, std::size_t room, std::size_t symbolsLeft, GenerateStats& stats,
                const std::string& file, const std::string& at) {
    const std::string over =
        ", over the limit " + limitText(limits::kEllipsoids) + " with the scene's other ellipsoids";
    try {
        switch (g.type) {
            case Generator::Type::Cumulus:
                if (std::size_t(g.count) > room)
                    throw SceneError(file, at + ".count",
                                     "places " + std::to_string(g.count) + " ellipsoids; the scene has room for " +
                                         std::to_string(room) + " more" + over);
                return generateCumulus(g, &stats);
            case Generator::Type::Mesh: return generateMesh(g, &stats);
            case Generator::Type::LSystem: return generateLSystem(g, &stats, symbolsLeft);
        }
    } catch (const ObjError& e) {
        throw SceneError(file, at + ".path", e.what());
    } catch (const std::length_error& e) {
        throw SceneError(file, at, e.what());
    }
    return {};
}

}  // namespace

std::vector<GenerateStats> expandGenerators(Scene& scene) {
    std::size_t ellipsoids = 0, symbols = 0;
    std::uint64_t objBytes = 0;
    for (const Cloud& c : scene.clouds) ellipsoids += c.ellipsoids.size();
    for (const GenerateStats& s : scene.generated) symbols += std::size_t(s.symbols), objBytes += s.objBytes;
    std::vector<GenerateStats> result;
    for (size_t i = scene.generated.size(); i < scene.generators.size(); ++i) {
        const std::string at = "generate[" + std::to_string(i) + "]";
        if (double(scene.clouds.size()) + 1 > limits::kClouds.value)
            throw SceneError(scene.file, at,
                             "makes cloud " + std::to_string(scene.clouds.size() + 1) + ", over the limit " +
                                 limitText(limits::kClouds));
        const std::size_t room =
            std::size_t(limits::kEllipsoids.value) - std::min(ellipsoids, std::size_t(limits::kEllipsoids.value));
        GenerateStats stats;
        Cloud cloud = expandOne(scene.generators[i], room, std::size_t(limits::kLSystemSymbols.value) - symbols, stats,
                                scene.file, at);
        if (cloud.ellipsoids.size() > room)
            throw SceneError(scene.file, at,
                             "makes " + std::to_string(cloud.ellipsoids.size()) +
                                 " ellipsoids; the scene has room for " + std::to_string(room) +
                                 " more, over the limit " + limitText(limits::kEllipsoids) +
                                 " with the scene's other ellipsoids");
        objBytes += stats.objBytes;
        if (double(objBytes) > limits::kObjBytesPerScene.value)
            throw SceneError(scene.file, at + ".path",
                             "brings the OBJ data read to " + std::to_string(objBytes) + " bytes, over the limit " +
                                 limitText(limits::kObjBytesPerScene));
        checkGenerated(cloud, scene.medium, scene.file, at);
        ellipsoids += cloud.ellipsoids.size();
        symbols += std::size_t(stats.symbols);
        scene.clouds.push_back(std::move(cloud));
        scene.generated.push_back(stats);
        result.push_back(stats);
    }
    return result;
}

}  // namespace nephele
