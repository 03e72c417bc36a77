// The lighting precomputation of Wang, Ji & Zhang 2011, section 3: multiple forward
// scattering along the light (eqs. 5-7), eye scattering (8), Cornette-Shanks (10), stored as
// vectors whose length is the intensity, n' = n / 2 + 0.5, in an RGBA8 3D texture.
#include "cache_file.hpp"
#include "fingerprint.hpp"
#include "nephele/layered.hpp"
#include "nephele/log.hpp"
#include "nephele/noise.hpp"
#include "nephele/resources.hpp"
#include "parallel.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <glm/gtc/constants.hpp>

namespace nephele {

namespace {
constexpr double kPi = glm::pi<double>();
constexpr char kMagic[8] = {'N', 'P', 'H', 'L', 'A', 'Y', 'R', '\0'};
// Bump when the file layout OR the precomputation changes: the cache key and the header carry it,
// so a volume computed by an older algorithm is never reused. 3: a checksum ends the file.
constexpr std::uint32_t kVersion = 3;
constexpr double kMaxSubstepTau = 0.1;  // the Riemann sum of eq. (5) needs thin particles: tau <= 0.1 each
// A slice's optical depth is taken as at most this: its transmittance exp(-1e6) is 0 in double,
// so the light through it is the same, and the particle count stays finite.
constexpr double kMaxSliceTau = 1e6;

std::string num(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.17g", v);
    return b;
}

void checkSettings(const LightingSettings& s, const LightingParameters& p) {
    auto bad = [](const std::string& what) { throw std::invalid_argument("layered lighting: " + what); };
    const int m = kMaxLightingSize;
    if (s.width < 2 || s.height < 2 || s.depth < 2 || s.width > m || s.height > m || s.depth > m)
        bad("size must be 2.." + std::to_string(m) + " texels per side, got " + std::to_string(s.width) + "x" +
            std::to_string(s.height) + "x" + std::to_string(s.depth));
    if (!(s.tilePeriod > 0 && std::isfinite(s.tilePeriod))) bad("tilePeriod must be > 0 m, got " + num(s.tilePeriod));
    if (!(s.forwardConeDeg > 0 && s.forwardConeDeg <= 90)) bad("forwardConeDeg must be in (0, 90], got " + num(s.forwardConeDeg));
    if (s.octaves < 1 || s.octaves > 8) bad("octaves must be 1..8, got " + std::to_string(s.octaves));
    if (s.cells < 1 || s.cells > 64) bad("cells must be 1..64, got " + std::to_string(s.cells));
    if (!(p.extinction >= 0 && std::isfinite(p.extinction))) bad("extinction must be finite and >= 0, got " + num(p.extinction));
    if (!(p.albedo >= 0 && p.albedo <= 1)) bad("albedo must be in [0, 1], got " + num(p.albedo));
    if (!(p.csG > -1 && p.csG < 1)) bad("phase asymmetry must be in (-1, 1), got " + num(p.csG));
    if (!(p.thickness > 0 && std::isfinite(p.thickness))) bad("thickness must be finite and > 0 m, got " + num(p.thickness));
}

// The vertical profile of the volume's density: 0 at the layer's bottom and top, 1 at mid-height.
double profile(double z) { return std::sqrt(std::max(std::sin(kPi * std::clamp(z, 0.0, 1.0)), 0.0)); }

// One slice of a column, lit from above: its optical depth tau split into n = ceil(tau /
// kMaxSubstepTau) equal particles, the n identical steps of eqs. (7) and (8) taken in closed
// form (the cost does not grow with the optical depth). `i` is the light incident on the slice
// (the sun's at the top is 1), `e` the eye scattering (8) accumulated above it; both are
// advanced past the slice. eyeCoeff = albedo F(0) / 4pi.
void lightSlice(double tau, double forward, double eyeCoeff, double& i, double& e) {
    tau = std::min(tau, kMaxSliceTau);
    if (!(tau > 0)) return;  // an empty slice passes everything and scatters nothing
    const double n = std::ceil(tau / kMaxSubstepTau), tp = tau / n;
    const double r = std::exp(-tp), f = forward * tp + r;  // per particle: e' = c i + r e, i' = f i
    // e_out = r^n e + c i sum_{m<n} f^m r^(n-1-m), in logarithms: (f / r)^n may overflow.
    double sum = 1;
    if (n > 1) {
        const double q1 = forward * tp / r;  // f / r - 1 >= 0
        const double l = n * std::log1p(q1);  // log (f / r)^n
        const double logTerms = q1 > 0 ? (l > 30 ? l + std::log1p(-std::exp(-l)) : std::log(std::expm1(l))) - std::log(q1)
                                       : std::log(n);  // f == r: n terms of r^(n-1)
        sum = std::exp(-(n - 1) * tp + logTerms);
    }
    e = std::min(std::exp(-tau) * e + eyeCoeff * tp * i * sum, 1e30);
    i = std::min(i * std::pow(f, n), 1e30);
}

// The volume as stored in a file, before the cache's checksum: magic, version, sizes,
// parameters, derived values, texels.
class Bytes {
public:
    template <class T>
    void put(const T& v) { text_.append(reinterpret_cast<const char*>(&v), sizeof v); }
    void putRaw(const void* p, std::size_t n) { text_.append(static_cast<const char*>(p), n); }
    std::string& text() { return text_; }

private:
    std::string text_;
};

class Reader {
public:
    explicit Reader(const std::string& text) : text_(text) {}
    template <class T>
    bool get(T& v) { return getRaw(&v, sizeof v); }
    bool getRaw(void* p, std::size_t n) {
        if (text_.size() - at_ < n) return false;
        std::memcpy(p, text_.data() + at_, n);
        at_ += n;
        return true;
    }
    bool atEnd() const { return at_ == text_.size(); }

private:
    const std::string& text_;
    std::size_t at_ = 0;
};

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

double lightColumn(const std::vector<double>& sliceTaus, double forward, double albedo, double phase,
                   std::vector<double>& incident) {
    incident.resize(sliceTaus.size());
    double light = 1.0, eye = 0;
    for (std::size_t k = 0; k < sliceTaus.size(); ++k) {
        incident[k] = light;  // on the slice's first particle
        lightSlice(sliceTaus[k], forward, albedo * phase / (4 * kPi), light, eye);
    }
    return eye;
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

std::uint64_t lightingBytes(const LightingSettings& s) {
    // Per texel: density and intensity (float each) and the RGBA8 texels during the
    // precomputation, then the GL texture with its mipmaps (8/7 of 4 bytes).
    return std::uint64_t(s.width) * std::uint64_t(s.height) * std::uint64_t(s.depth) * (12 + 5);
}

LightingVolume precomputeLighting(const LightingSettings& s, const LightingParameters& p) {
    checkSettings(s, p);
    requireMemory("the " + std::to_string(s.width) + "x" + std::to_string(s.height) + "x" + std::to_string(s.depth) +
                      " layered lighting volume",
                  lightingBytes(s));
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
        std::vector<double> taus(d), incident;
        for (int i = 0; i < w; ++i) {
            double column = 0;
            for (int k = 0; k < d; ++k) {  // from the top slice down
                taus[k] = p.extinction * density[(std::size_t(d - 1 - k) * h + j) * w + i] * dz;
                column += taus[k];
            }
            const double eye = lightColumn(taus, forward, p.albedo, phase0, incident);
            for (int k = 0; k < d; ++k) intensity[(std::size_t(d - 1 - k) * h + j) * w + i] = float(incident[k]);
            const double opacity = 1 - std::exp(-column);
            if (opacity > 0.01) eyePerOpacity[std::size_t(j) * w + i] = eye / opacity;
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

namespace {
std::string serialise(const LightingVolume& v) {
    const LightingSettings& s = v.settings;
    const LightingParameters& p = v.parameters;
    Bytes out;
    out.putRaw(kMagic, sizeof kMagic);
    out.put(kVersion);
    out.put(std::uint32_t(s.width)), out.put(std::uint32_t(s.height)), out.put(std::uint32_t(s.depth));
    out.put(s.tilePeriod), out.put(s.forwardConeDeg);
    out.put(std::uint32_t(s.octaves)), out.put(std::uint32_t(s.cells)), out.put(std::uint32_t(s.seed));
    out.put(p.extinction), out.put(p.albedo), out.put(p.csG), out.put(p.thickness);
    out.put(v.eyeScatterPeak), out.put(v.eyeScatterCosPhi);
    out.putRaw(v.texels.data(), v.texels.size());
    return std::move(out.text());
}
}  // namespace

void LightingVolume::save(const std::string& path) const {
    const std::string why = cache::write(path, serialise(*this));
    if (!why.empty()) throw LightingFileError(why);
}

LightingVolume LightingVolume::load(const std::string& path, const LightingSettings& es, const LightingParameters& ep) {
    checkSettings(es, ep);
    auto fail = [&](const std::string& what) { throw LightingFileError(path + ": " + what); };
    std::string why;
    // The header is under 200 bytes; the texels are what the expected settings make.
    const std::optional<std::string> bytes = cache::read(path, 256 + lightingBytes(es), why);
    if (!bytes) fail(why.empty() ? "cannot open the lighting volume" : why);
    Reader in(*bytes);
    char magic[8];
    if (!in.getRaw(magic, sizeof magic) || std::memcmp(magic, kMagic, sizeof magic) != 0)
        fail("not a Nephele lighting volume (bad magic)");
    std::uint32_t version = 0, w = 0, h = 0, d = 0, octaves = 0, cells = 0, seed = 0;
    if (!in.get(version)) fail("truncated header");
    if (version != kVersion)
        fail("version " + std::to_string(version) + ", this build reads version " + std::to_string(kVersion));
    LightingVolume v;
    LightingParameters& p = v.parameters;
    LightingSettings& s = v.settings;
    if (!(in.get(w) && in.get(h) && in.get(d) && in.get(s.tilePeriod) && in.get(s.forwardConeDeg) && in.get(octaves) &&
          in.get(cells) && in.get(seed) && in.get(p.extinction) && in.get(p.albedo) && in.get(p.csG) &&
          in.get(p.thickness) && in.get(v.eyeScatterPeak) && in.get(v.eyeScatterCosPhi)))
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
    if (!in.getRaw(v.texels.data(), v.texels.size()))
        fail("truncated texels (expected " + std::to_string(v.texels.size()) + " bytes)");
    if (!in.atEnd()) fail("trailing bytes after the texels");
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
    const std::string file = (std::filesystem::path(cacheDir) / name).string();
    std::error_code ec;
    if (std::filesystem::exists(file, ec)) {  // a missing file is the usual miss; anything else is worth a word
        try {
            return LightingVolume::load(file, s, p);
        } catch (const LightingFileError& e) {
            logMessage(LogLevel::Warning, std::string("ignoring the cached lighting volume, computing it again: ") + e.what());
        }
    }
    LightingVolume v = precomputeLighting(s, p);
    std::filesystem::create_directories(cacheDir, ec);
    const std::string why = cache::write(file, serialise(v));
    if (!why.empty()) logMessage(LogLevel::Warning, "could not cache the lighting volume in " + cacheDir + ": " + why);
    return v;
}

}  // namespace nephele
