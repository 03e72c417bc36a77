// The lighting precomputation of Wang, Ji & Zhang 2011, section 3: multiple forward
// scattering along the light (eqs. 5-7), eye scattering (8), Cornette-Shanks (10), stored as
// vectors whose length is the intensity, n' = n / 2 + 0.5, in an RGBA8 3D texture.
#include "fingerprint.hpp"
#include "nephele/layered.hpp"
#include "nephele/log.hpp"
#include "nephele/noise.hpp"
#include "parallel.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/gtc/constants.hpp>
#include <unistd.h>

namespace nephele {

namespace {
constexpr double kPi = glm::pi<double>();
constexpr char kMagic[8] = {'N', 'P', 'H', 'L', 'A', 'Y', 'R', '\0'};
// Bump when the file layout OR the precomputation changes: the cache key and the header carry it,
// so a volume computed by an older algorithm is never reused.
constexpr std::uint32_t kVersion = 2;
constexpr double kMaxSubstepTau = 0.1;  // the Riemann sum of eq. (5) needs thin particles: tau <= 0.1 each

std::string num(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.17g", v);
    return b;
}

void checkSettings(const LightingSettings& s, const LightingParameters& p) {
    auto bad = [](const std::string& what) { throw std::invalid_argument("layered lighting: " + what); };
    if (s.width < 2 || s.height < 2 || s.depth < 2 || s.width > 4096 || s.height > 4096 || s.depth > 1024)
        bad("size must be 2..4096 x 2..4096 x 2..1024 texels, got " + std::to_string(s.width) + "x" +
            std::to_string(s.height) + "x" + std::to_string(s.depth));
    if (!(s.tilePeriod > 0)) bad("tilePeriod must be > 0 m, got " + num(s.tilePeriod));
    if (!(s.forwardConeDeg > 0 && s.forwardConeDeg <= 90)) bad("forwardConeDeg must be in (0, 90], got " + num(s.forwardConeDeg));
    if (s.octaves < 1 || s.octaves > 8) bad("octaves must be 1..8, got " + std::to_string(s.octaves));
    if (s.cells < 1 || s.cells > 64) bad("cells must be 1..64, got " + std::to_string(s.cells));
    if (!(p.extinction >= 0)) bad("extinction must be >= 0, got " + num(p.extinction));
    if (!(p.albedo >= 0 && p.albedo <= 1)) bad("albedo must be in [0, 1], got " + num(p.albedo));
    if (!(p.csG > -1 && p.csG < 1)) bad("phase asymmetry must be in (-1, 1), got " + num(p.csG));
    if (!(p.thickness > 0)) bad("thickness must be > 0 m, got " + num(p.thickness));
}

// The vertical profile of the volume's density: 0 at the layer's bottom and top, 1 at mid-height.
double profile(double z) { return std::sqrt(std::max(std::sin(kPi * std::clamp(z, 0.0, 1.0)), 0.0)); }

template <class T>
void put(std::ofstream& out, const T& v) {
    out.write(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
bool get(std::ifstream& in, T& v) {
    return bool(in.read(reinterpret_cast<char*>(&v), sizeof v));
}
}  // namespace

double cornetteShanks(double cosTheta, double f) {
    const double f2 = f * f;
    const double denom = std::max(1 + f2 - 2 * f * cosTheta, 1e-300);
    return 3 * (1 - f2) / (2 * (2 + f2)) * (1 + cosTheta * cosTheta) / std::pow(denom, 1.5);
}

double forwardCoefficient(double albedo, double f, double coneDeg) {
    const double gamma = 2 * kPi * (1 - std::cos(glm::radians(coneDeg)));  // sr
    return std::min(albedo * cornetteShanks(1.0, f) * gamma / (4 * kPi), albedo);
}

std::vector<double> forwardScatter(const std::vector<double>& taus, double forward, double i0, double* exit) {
    std::vector<double> incident(taus.size());
    double i = i0;  // I_1 = I_0
    for (std::size_t k = 0; k < taus.size(); ++k) {
        incident[k] = i;
        const double g = forward * taus[k] * i;  // eq. (6)
        i = g + std::exp(-taus[k]) * i;          // eq. (7)
    }
    if (exit) *exit = i;
    return incident;
}

double eyeScatter(const std::vector<double>& taus, const std::vector<double>& incident, double albedo, double phase) {
    double e = 0;
    for (std::size_t k = 0; k < taus.size(); ++k) {
        const double s = albedo * taus[k] * phase * incident[k] / (4 * kPi);
        e = s + std::exp(-taus[k]) * e;  // eq. (8)
    }
    return e;
}

std::uint8_t encodeComponent(double n) {
    return std::uint8_t(std::lround(std::clamp(n * 0.5 + 0.5, 0.0, 1.0) * 255.0));
}
double decodeComponent(std::uint8_t byte) { return byte / 255.0 * 2.0 - 1.0; }

glm::dvec3 LightingVolume::vectorAt(int i, int j, int k) const {
    const std::uint8_t* t = &texels[(std::size_t(k) * settings.height + j) * settings.width * 4 + std::size_t(i) * 4];
    return {decodeComponent(t[0]), decodeComponent(t[1]), decodeComponent(t[2])};
}
double LightingVolume::densityAt(int i, int j, int k) const {
    return texels[(std::size_t(k) * settings.height + j) * settings.width * 4 + std::size_t(i) * 4 + 3] / 255.0;
}

double LightingVolume::sampleDensity(double u, double v, double z) const {
    const int w = settings.width, h = settings.height, d = settings.depth;
    const double x = u * w - 0.5, y = v * h - 0.5, zz = std::clamp(z * d - 0.5, 0.0, double(d - 1));
    const double fx = std::floor(x), fy = std::floor(y), fz = std::min(std::floor(zz), double(d - 2));
    const double ax = x - fx, ay = y - fy, az = zz - fz;
    auto wrap = [](long i, int n) { return int(((i % n) + n) % n); };
    double sum = 0;
    for (int c = 0; c < 8; ++c) {
        const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
        const double wgt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay) * (dz ? az : 1 - az);
        sum += wgt * densityAt(wrap(long(fx) + dx, w), wrap(long(fy) + dy, h), int(fz) + dz);
    }
    return sum;
}

LightingVolume precomputeLighting(const LightingSettings& s, const LightingParameters& p) {
    checkSettings(s, p);
    const auto start = std::chrono::steady_clock::now();
    const int w = s.width, h = s.height, d = s.depth;
    const std::size_t columns = std::size_t(w) * h;
    // Density A in [0, 1] at texel centres: tileable fBm in x, y shaped by the profile.
    std::vector<float> density(columns * d);
    const double zCells = std::max(s.cells * p.thickness / s.tilePeriod, 1.0);
    parallelFor(d, [&](int k) {
        const double z = (k + 0.5) / d;
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const glm::vec3 q(float((i + 0.5) / w * s.cells), float((j + 0.5) / h * s.cells), float(z * zCells));
                const double n = fbm(q, s.octaves, s.cells, s.seed);
                density[(std::size_t(k) * h + j) * w + i] = float(profile(z) * std::clamp(0.8 + 0.7 * n, 0.0, 1.0));
            }
    });
    // Light from the zenith, column by column from the top slice down (the paper's slices
    // sorted by distance to the light); each slice is split into particles of tau <= 0.1.
    const double dz = p.thickness / d;
    const double forward = forwardCoefficient(p.albedo, p.csG, s.forwardConeDeg);
    const double phase0 = cornetteShanks(1.0, p.csG);
    std::vector<float> intensity(columns * d);
    std::vector<double> eyePerOpacity(columns, -1.0);
    parallelFor(h, [&](int j) {
        std::vector<double> taus;
        std::vector<int> sliceOf;
        for (int i = 0; i < w; ++i) {
            taus.clear();
            sliceOf.clear();
            double column = 0;
            for (int k = d - 1; k >= 0; --k) {
                const double tau = p.extinction * density[(std::size_t(k) * h + j) * w + i] * dz;
                const int n = std::max(1, int(std::ceil(tau / kMaxSubstepTau)));
                for (int m = 0; m < n; ++m) taus.push_back(tau / n), sliceOf.push_back(k);
                column += tau;
            }
            const std::vector<double> inc = forwardScatter(taus, forward, 1.0);
            for (std::size_t q = 0; q < taus.size(); ++q)
                if (q == 0 || sliceOf[q] != sliceOf[q - 1])  // the light incident on the slice's first particle
                    intensity[(std::size_t(sliceOf[q]) * h + j) * w + i] = float(inc[q]);
            const double opacity = 1 - std::exp(-column);
            if (opacity > 0.01) eyePerOpacity[std::size_t(j) * w + i] = eyeScatter(taus, inc, p.albedo, phase0) / opacity;
        }
    });
    LightingVolume v;
    v.settings = s;
    v.parameters = p;
    double sum = 0;
    long count = 0;
    for (double e : eyePerOpacity)
        if (e >= 0) sum += e, ++count;
    v.eyeScatterPeak = count ? sum / count : 0;
    // phi: where the phase function falls to 10% of its forward peak (the paper: "only 10% ...
    // when the scattering angle is greater than 10 degrees"); 90 degrees if it never does.
    double lo = 0, hi = kPi / 2;
    if (cornetteShanks(0.0, p.csG) > 0.1 * phase0) lo = hi;
    for (int it = 0; it < 60 && hi - lo > 1e-12; ++it) {
        const double mid = 0.5 * (lo + hi);
        (cornetteShanks(std::cos(mid), p.csG) > 0.1 * phase0 ? lo : hi) = mid;
    }
    v.eyeScatterCosPhi = std::cos(lo);
    // Vectors: length I, direction grad I (physical units), the zenith where I is flat.
    v.texels.resize(columns * d * 4);
    const double dx = s.tilePeriod / w, dy = s.tilePeriod / h;
    auto at = [&](int i, int j, int k) {
        i = (i + w) % w, j = (j + h) % h, k = std::clamp(k, 0, d - 1);
        return double(intensity[(std::size_t(k) * h + j) * w + i]);
    };
    parallelFor(d, [&](int k) {
        const double zs = (k == 0 || k == d - 1) ? dz : 2 * dz;
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                glm::dvec3 g((at(i + 1, j, k) - at(i - 1, j, k)) / (2 * dx), (at(i, j + 1, k) - at(i, j - 1, k)) / (2 * dy),
                             (at(i, j, k + 1) - at(i, j, k - 1)) / zs);
                const double len = glm::length(g);
                const glm::dvec3 dir = len > 1e-9 ? g / len : glm::dvec3(0, 0, 1);
                const glm::dvec3 n = dir * std::clamp(at(i, j, k), 0.0, 1.0);
                std::uint8_t* t = &v.texels[((std::size_t(k) * h + j) * w + i) * 4];
                t[0] = encodeComponent(n.x), t[1] = encodeComponent(n.y), t[2] = encodeComponent(n.z);
                t[3] = std::uint8_t(std::lround(std::clamp<double>(density[(std::size_t(k) * h + j) * w + i], 0.0, 1.0) * 255));
            }
    });
    v.precomputeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return v;
}

void LightingVolume::save(const std::string& path) const {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw LightingFileError(path + ": cannot open for writing");
    out.write(kMagic, sizeof kMagic);
    put(out, kVersion);
    put(out, std::uint32_t(settings.width)), put(out, std::uint32_t(settings.height)), put(out, std::uint32_t(settings.depth));
    put(out, settings.tilePeriod), put(out, settings.forwardConeDeg);
    put(out, std::uint32_t(settings.octaves)), put(out, std::uint32_t(settings.cells)), put(out, std::uint32_t(settings.seed));
    put(out, parameters.extinction), put(out, parameters.albedo), put(out, parameters.csG), put(out, parameters.thickness);
    put(out, eyeScatterPeak), put(out, eyeScatterCosPhi);
    out.write(reinterpret_cast<const char*>(texels.data()), std::streamsize(texels.size()));
    if (!out) throw LightingFileError(path + ": write failed");
}

LightingVolume LightingVolume::load(const std::string& path, const LightingSettings& es, const LightingParameters& ep) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw LightingFileError(path + ": cannot open the lighting volume");
    auto fail = [&](const std::string& what) { throw LightingFileError(path + ": " + what); };
    char magic[8];
    if (!in.read(magic, sizeof magic) || std::memcmp(magic, kMagic, sizeof magic) != 0)
        fail("not a Nephele lighting volume (bad magic)");
    std::uint32_t version = 0, w = 0, h = 0, d = 0, octaves = 0, cells = 0, seed = 0;
    if (!get(in, version)) fail("truncated header");
    if (version != kVersion)
        fail("version " + std::to_string(version) + ", this build reads version " + std::to_string(kVersion));
    LightingVolume v;
    LightingParameters& p = v.parameters;
    LightingSettings& s = v.settings;
    if (!(get(in, w) && get(in, h) && get(in, d) && get(in, s.tilePeriod) && get(in, s.forwardConeDeg) && get(in, octaves) &&
          get(in, cells) && get(in, seed) && get(in, p.extinction) && get(in, p.albedo) && get(in, p.csG) &&
          get(in, p.thickness) && get(in, v.eyeScatterPeak) && get(in, v.eyeScatterCosPhi)))
        fail("truncated header");
    s.width = int(w), s.height = int(h), s.depth = int(d), s.octaves = int(octaves), s.cells = int(cells), s.seed = seed;
    auto mismatch = [&](const char* what, const std::string& got, const std::string& want) {
        if (got != want) fail(std::string(what) + " is " + got + ", expected " + want);
    };
    mismatch("size", std::to_string(w) + "x" + std::to_string(h) + "x" + std::to_string(d),
             std::to_string(es.width) + "x" + std::to_string(es.height) + "x" + std::to_string(es.depth));
    mismatch("tilePeriod", num(s.tilePeriod), num(es.tilePeriod));
    mismatch("forwardConeDeg", num(s.forwardConeDeg), num(es.forwardConeDeg));
    mismatch("octaves", std::to_string(s.octaves), std::to_string(es.octaves));
    mismatch("cells", std::to_string(s.cells), std::to_string(es.cells));
    mismatch("seed", std::to_string(s.seed), std::to_string(es.seed));
    mismatch("extinction", num(p.extinction), num(ep.extinction));
    mismatch("albedo", num(p.albedo), num(ep.albedo));
    mismatch("phase asymmetry", num(p.csG), num(ep.csG));
    mismatch("thickness", num(p.thickness), num(ep.thickness));
    if (!std::isfinite(v.eyeScatterPeak) || !std::isfinite(v.eyeScatterCosPhi)) fail("non-finite derived values");
    v.texels.resize(std::size_t(w) * h * d * 4);
    if (!in.read(reinterpret_cast<char*>(v.texels.data()), std::streamsize(v.texels.size())))
        fail("truncated texels (expected " + std::to_string(v.texels.size()) + " bytes)");
    if (in.peek() != std::ifstream::traits_type::eof()) fail("trailing bytes after the texels");
    return v;
}

LightingParameters lightingParameters(const Medium& medium, const Layer& layer) {
    return {medium.extinction, medium.albedo, medium.hgG, layer.thickness};
}

LightingVolume lightingCached(const LightingSettings& s, const LightingParameters& p, const std::string& cacheDir) {
    if (cacheDir.empty()) return precomputeLighting(s, p);
    checkSettings(s, p);
    Fingerprint f;
    f.add(s.width).add(s.height).add(s.depth).add(s.tilePeriod).add(s.forwardConeDeg).add(s.octaves).add(s.cells).add(s.seed);
    f.add(p.extinction).add(p.albedo).add(p.csG).add(p.thickness).add(kVersion);
    char name[64];
    std::snprintf(name, sizeof name, "layered-light-%016llx.bin", static_cast<unsigned long long>(f.value()));
    const std::filesystem::path file = std::filesystem::path(cacheDir) / name;
    std::error_code ec;
    if (std::filesystem::exists(file, ec)) {
        try {
            return LightingVolume::load(file.string(), s, p);
        } catch (const LightingFileError& e) {
            logMessage(LogLevel::Warning, std::string("ignoring the cached lighting volume: ") + e.what());
        }
    }
    LightingVolume v = precomputeLighting(s, p);
    std::filesystem::create_directories(cacheDir, ec);
    // Written to a temporary name and renamed, so a reader never sees half a file.
    const std::filesystem::path tmp = file.string() + ".tmp" + std::to_string(::getpid());
    try {
        v.save(tmp.string());
        std::filesystem::rename(tmp, file);
    } catch (const std::exception& e) {
        std::filesystem::remove(tmp, ec);
        logMessage(LogLevel::Warning, "could not cache the lighting volume in " + cacheDir + ": " + e.what());
    }
    return v;
}

}  // namespace nephele
