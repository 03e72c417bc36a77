// The layered sky's lighting volume (after Wang, Ji & Zhang 2011, section 3, with issue #10's
// light): the density A of a tileable cloud volume, per texel the optical depth of the column
// above it at three thresholds of eq. (16) (and of the whole column), and the photon-traced
// light tables (layer_light.cpp); cached in checksummed files (cache_file.hpp).
#include "layer_light.hpp"
#include "layer_model.hpp"

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
#include <numbers>

namespace nephele {

namespace {
constexpr char kMagic[8] = {'N', 'P', 'H', 'L', 'A', 'Y', 'R', '\0'};
// Bump when the file layout OR the precomputation changes: the cache key and the header carry it,
// so a volume computed by an older algorithm is never reused. 3: a checksum ends the file (#14).
// 4: the paper's light vectors replaced by the column knots and the photon-traced light tables.
constexpr std::uint32_t kVersion = 5;  // 5: the sun's tables in two parts (sun, sunMany)

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
    if (s.photons != 0 && (s.photons < 64 || s.photons > (1 << 22)))
        bad("photons must be 0 (no diffuse light) or 64..2^22, got " + std::to_string(s.photons));
    if (s.tableBins < 4 || s.tableBins > 64) bad("tableBins must be 4..64, got " + std::to_string(s.tableBins));
    if (s.octaves < 1 || s.octaves > 8) bad("octaves must be 1..8, got " + std::to_string(s.octaves));
    if (s.cells < 1 || s.cells > 64) bad("cells must be 1..64, got " + std::to_string(s.cells));
    if (!(p.extinction >= 0 && std::isfinite(p.extinction)))
        bad("extinction must be finite and >= 0, got " + num(p.extinction));
    if (!(p.albedo >= 0 && p.albedo <= 1)) bad("albedo must be in [0, 1], got " + num(p.albedo));
    if (!(p.csG > -1 && p.csG < 1)) bad("phase asymmetry must be in (-1, 1), got " + num(p.csG));
    if (!(p.thickness > 0 && std::isfinite(p.thickness)))
        bad("thickness must be finite and > 0 m, got " + num(p.thickness));
}

// The vertical profile of the volume's density: 0 at the layer's bottom and top, 1 at mid-height.
double profile(double z) { return std::sqrt(std::max(std::sin(std::numbers::pi * std::clamp(z, 0.0, 1.0)), 0.0)); }

// The volume as stored in a file, before the cache's checksum (built and read in memory).
class Bytes {
public:
    template <class T>
    void put(const T& v) {
        text_.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
    template <class T>
    void putArray(const std::vector<T>& v) {
        text_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
    std::string& text() { return text_; }

private:
    std::string text_;
};

class Reader {
public:
    explicit Reader(const std::string& text) : text_(text) {}
    template <class T>
    bool get(T& v) {
        return getRaw(&v, sizeof v);
    }
    // Reads `count` values of T into v; false when the data is short.
    template <class T>
    bool getArray(std::vector<T>& v, std::size_t count) {
        if ((text_.size() - at_) / sizeof(T) < count) return false;
        v.resize(count);
        return getRaw(v.data(), count * sizeof(T));
    }
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

double LightingVolume::densityAt(int i, int j, int k) const {
    return texels[(std::size_t(k) * settings.height + j) * settings.width * 4 + std::size_t(i) * 4 + 3] / 255.0;
}

namespace {
// GL_LINEAR sampling of a w x h x d texture (x fastest, then y, then z): repeat in x and y,
// clamp in z; read(texel index) gives a texel's value (a number or a vector).
template <class Read>
auto trilinear(int w, int h, int d, double u, double v, double z, const Read& read) {
    const double x = u * w - 0.5, y = v * h - 0.5, zz = std::clamp(z * d - 0.5, 0.0, double(d - 1));
    const double fx = std::floor(x), fy = std::floor(y), fz = std::max(std::min(std::floor(zz), double(d - 2)), 0.0);
    const double ax = x - fx, ay = y - fy, az = d > 1 ? zz - fz : 0;
    auto wrap = [](long i, int n) { return int(((i % n) + n) % n); };
    decltype(read(std::size_t(0))) sum(0.0);
    for (int c = 0; c < (d > 1 ? 8 : 4); ++c) {
        const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
        const double wgt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay) * (dz ? az : 1 - az);
        sum += wgt * read((std::size_t(int(fz) + dz) * h + wrap(long(fy) + dy, h)) * w + wrap(long(fx) + dx, w));
    }
    return sum;
}
glm::dvec4 rgba(const std::vector<std::uint8_t>& texels, std::size_t i) {
    const std::uint8_t* t = &texels[i * 4];
    return glm::dvec4(t[0], t[1], t[2], t[3]) / 255.0;
}
}  // namespace

glm::dvec4 LightingVolume::sampleTexel(double u, double v, double z) const {
    return trilinear(settings.width, settings.height, settings.depth, u, v, z,
                     [&](std::size_t i) { return rgba(texels, i); });
}
glm::dvec4 LightingVolume::sampleColumn(double u, double v) const {
    return trilinear(settings.width, settings.height, 1, u, v, 0, [&](std::size_t i) { return rgba(columns, i); });
}
double LightingVolume::sampleDensity(double u, double v, double z) const {
    return trilinear(settings.width, settings.height, settings.depth, u, v, z,
                     [&](std::size_t i) { return texels[i * 4 + 3] / 255.0; });
}

glm::dvec2 LightingVolume::columnDepths(double u, double v, double z, double theta, double density) const {
    const glm::vec3 depths = model::layerColumnDepths(glm::vec3(sampleTexel(u, v, z)), glm::vec3(sampleColumn(u, v)),
                                                      float(theta), float(density));
    return {depths.x, depths.y};
}

namespace {
// The density A in [0, 1] at texel centres: tileable fBm in x, y shaped by the profile, as bytes.
std::vector<std::uint8_t> densityBytes(const LightingSettings& s, const LightingParameters& p) {
    const int w = s.width, h = s.height, d = s.depth;
    std::vector<std::uint8_t> density(std::size_t(w) * h * d);
    const double zCells = std::max(s.cells * p.thickness / s.tilePeriod, 1.0);
    parallelFor(d, [&](int k) {
        const double z = (k + 0.5) / d;
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const glm::vec3 q(float((i + 0.5) / w * s.cells), float((j + 0.5) / h * s.cells), float(z * zCells));
                const double n = fbm(q, s.octaves, s.cells, s.seed);
                const double a = profile(z) * std::clamp(0.8 + 0.7 * n, 0.0, 1.0);
                density[(std::size_t(k) * h + j) * w + i] = std::uint8_t(std::lround(std::clamp(a, 0.0, 1.0) * 255));
            }
    });
    return density;
}

// Per column, the optical depth per unit D from each texel centre up to the layer's top (and of
// the whole column) at the thresholds theta_k of shaders/layer_light.glsl: the integral of
// extinction max(A(z) - theta, 0) with A(z) as GL_LINEAR reads it (linear between texel
// centres, constant beyond the outer ones), by the midpoint rule in 8 steps per texel. Encoded
// into the texels' rgb and the columns' rgb.
void columnKnots(LightingVolume& v, const std::vector<std::uint8_t>& density) {
    const int w = v.settings.width, h = v.settings.height, d = v.settings.depth;
    const double dz = v.parameters.thickness / d, extinction = lightingExtinction(v.parameters);
    constexpr int kSteps = 8;
    v.columns.assign(std::size_t(w) * h * 4, 0);
    auto encode = [](double tau) { return std::uint8_t(std::lround(model::encodeLayerTau(float(tau)) * 255)); };
    parallelFor(h, [&](int j) {
        for (int i = 0; i < w; ++i) {
            auto a = [&](int k) { return density[(std::size_t(k) * h + j) * w + i] / 255.0; };
            for (int c = 0; c < 3; ++c) {
                const double theta = model::kLayerKnots[c];
                double tau = 0.5 * dz * std::max(a(d - 1) - theta, 0.0);  // above the top centre: constant
                for (int k = d - 1; k >= 0; --k) {
                    v.texels[((std::size_t(k) * h + j) * w + i) * 4 + c] = encode(extinction * tau);
                    if (k == 0) break;
                    for (int m = 0; m < kSteps; ++m) {  // from centre k down to centre k - 1
                        const double f = (m + 0.5) / kSteps;
                        tau += dz / kSteps * std::max(a(k) + (a(k - 1) - a(k)) * f - theta, 0.0);
                    }
                }
                tau += 0.5 * dz * std::max(a(0) - theta, 0.0);  // below the bottom centre
                v.columns[(std::size_t(j) * w + i) * 4 + c] = encode(extinction * tau);
            }
            v.columns[(std::size_t(j) * w + i) * 4 + 3] = 255;
        }
    });
}
}  // namespace

std::uint64_t lightingBytes(const LightingSettings& s) {
    // Per texel: the density bytes and the RGBA8 texels while it is computed, then the GL
    // texture with its mipmaps (8/7 of 4 bytes); per column the same for the columns' texels;
    // the photons' per-batch scratch grids (3 thresholds, bins x bins double4 each); the tables.
    const std::uint64_t texels = std::uint64_t(s.width) * std::uint64_t(s.height) * std::uint64_t(s.depth);
    const std::uint64_t columns = std::uint64_t(s.width) * std::uint64_t(s.height);
    const std::uint64_t nodes = std::uint64_t(s.tableBins) * std::uint64_t(s.tableBins);
    const std::uint64_t batches = std::max<std::uint64_t>(1, std::uint64_t(std::max(s.photons, 0)) * 16 / 4096);
    return texels * (1 + 4 + 5) + columns * (4 + 5) + batches * 3 * nodes * 32 + nodes * 8 * 16;
}

double lightingExtinction(const LightingParameters& p) {
    return std::min(p.extinction, kMaxLightingOpticalDepth / p.thickness);
}

LightingVolume precomputeLighting(const LightingSettings& s, const LightingParameters& p,
                                  const std::atomic<bool>* cancel) {
    checkSettings(s, p);
    requireMemory("the " + std::to_string(s.width) + "x" + std::to_string(s.height) + "x" + std::to_string(s.depth) +
                      " layered lighting volume",
                  lightingBytes(s));
    const auto start = std::chrono::steady_clock::now();
    LightingVolume v;
    v.settings = s;
    v.parameters = p;
    const std::vector<std::uint8_t> density = densityBytes(s, p);
    v.texels.assign(density.size() * 4, 0);
    for (std::size_t i = 0; i < density.size(); ++i) v.texels[i * 4 + 3] = density[i];
    columnKnots(v, density);
    v.tables = traceLayerLight(v, cancel);
    v.precomputeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return v;
}

namespace {
// The file's payload (cache::write appends the checksum): magic, version, sizes, parameters,
// the sun elevations, texels, columns, the sun's and the sky's tables.
std::string serialise(const LightingVolume& v) {
    const LightingSettings& s = v.settings;
    const LightingParameters& p = v.parameters;
    Bytes out;
    out.put(kMagic);
    out.put(kVersion);
    out.put(std::uint32_t(s.width)), out.put(std::uint32_t(s.height)), out.put(std::uint32_t(s.depth));
    out.put(s.tilePeriod);
    out.put(std::uint32_t(s.octaves)), out.put(std::uint32_t(s.cells)), out.put(std::uint32_t(s.seed));
    out.put(std::uint32_t(s.photons)), out.put(std::uint32_t(s.tableBins));
    out.put(p.extinction), out.put(p.albedo), out.put(p.csG), out.put(p.thickness);
    out.put(std::uint32_t(v.tables.sunMu.size()));
    out.putArray(v.tables.sunMu), out.putArray(v.texels), out.putArray(v.columns);
    out.putArray(v.tables.sun), out.putArray(v.tables.sunMany), out.putArray(v.tables.sky);
    return std::move(out.text());
}

// The header's settings and parameters against the expected ones: fails naming the first that differs.
template <class Fail>
void checkHeader(const LightingVolume& v, const LightingSettings& es, const LightingParameters& ep, const Fail& fail) {
    const LightingSettings& s = v.settings;
    const LightingParameters& p = v.parameters;
    auto mismatch = [&](const char* what, const std::string& got, const std::string& want) {
        if (got != want) fail(std::string(what) + " is " + got + ", expected " + want);
    };
    mismatch("size", std::to_string(s.width) + "x" + std::to_string(s.height) + "x" + std::to_string(s.depth),
             std::to_string(es.width) + "x" + std::to_string(es.height) + "x" + std::to_string(es.depth));
    mismatch("tilePeriod", num(s.tilePeriod), num(es.tilePeriod));
    mismatch("octaves", std::to_string(s.octaves), std::to_string(es.octaves));
    mismatch("cells", std::to_string(s.cells), std::to_string(es.cells));
    mismatch("seed", std::to_string(s.seed), std::to_string(es.seed));
    mismatch("photons", std::to_string(s.photons), std::to_string(es.photons));
    mismatch("table bins", std::to_string(s.tableBins), std::to_string(es.tableBins));
    mismatch("extinction", num(p.extinction), num(ep.extinction));
    mismatch("albedo", num(p.albedo), num(ep.albedo));
    mismatch("phase asymmetry", num(p.csG), num(ep.csG));
    mismatch("thickness", num(p.thickness), num(ep.thickness));
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
    // The header is under 200 bytes; the data are what the expected settings make.
    const std::optional<std::string> bytes = cache::read(path, 256 + lightingBytes(es), why);
    if (!bytes) fail(why.empty() ? "cannot open the lighting volume" : why);
    Reader in(*bytes);
    char magic[8];
    if (!in.getRaw(magic, sizeof magic) || std::memcmp(magic, kMagic, sizeof magic) != 0)
        fail("not a Nephele lighting volume (bad magic)");
    std::uint32_t version = 0, w = 0, h = 0, d = 0, octaves = 0, cells = 0, seed = 0, photons = 0, bins = 0, mus = 0;
    if (!in.get(version)) fail("truncated header");
    if (version != kVersion)
        fail("version " + std::to_string(version) + ", this build reads version " + std::to_string(kVersion));
    LightingVolume v;
    LightingParameters& p = v.parameters;
    LightingSettings& s = v.settings;
    if (!(in.get(w) && in.get(h) && in.get(d) && in.get(s.tilePeriod) && in.get(octaves) && in.get(cells) &&
          in.get(seed) && in.get(photons) && in.get(bins) && in.get(p.extinction) && in.get(p.albedo) &&
          in.get(p.csG) && in.get(p.thickness) && in.get(mus)))
        fail("truncated header");
    s.width = int(w), s.height = int(h), s.depth = int(d), s.octaves = int(octaves), s.cells = int(cells),
    s.seed = seed;
    s.photons = int(photons), s.tableBins = int(bins);
    checkHeader(v, es, ep, fail);
    if (mus < 1 || mus > 64) fail("bad number of sun elevations " + std::to_string(mus));
    LayerLightTables& t = v.tables;
    t.bins = s.tableBins;
    const std::size_t nodes = std::size_t(t.bins) * t.bins;
    if (!(in.getArray(t.sunMu, mus) && in.getArray(v.texels, std::size_t(w) * h * d * 4) &&
          in.getArray(v.columns, std::size_t(w) * h * 4) && in.getArray(t.sun, nodes * mus) &&
          in.getArray(t.sunMany, nodes * mus) && in.getArray(t.sky, nodes * 3)))
        fail("truncated data");
    if (!in.atEnd()) fail("trailing bytes after the data");
    for (const std::vector<glm::vec4>* table : {&t.sun, &t.sunMany, &t.sky})
        for (const glm::vec4& x : *table)
            if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z) || !std::isfinite(x.w))
                fail("non-finite light tables");
    return v;
}

LightingParameters lightingParameters(const Medium& medium, const Layer& layer) {
    return {medium.extinction, medium.albedo, medium.hgG,
            layer.lightingThickness > 0 ? layer.lightingThickness : layer.thickness};
}

LightingVolume lightingCached(const LightingSettings& s, const LightingParameters& p, const std::string& cacheDir,
                              const std::atomic<bool>* cancel) {
    if (cacheDir.empty()) return precomputeLighting(s, p, cancel);
    checkSettings(s, p);
    Fingerprint f;
    f.add(s.width).add(s.height).add(s.depth).add(s.tilePeriod).add(s.octaves).add(s.cells).add(s.seed).add(s.photons);
    f.add(s.tableBins);
    f.add(p.extinction).add(p.albedo).add(p.csG).add(p.thickness).add(kVersion);
    char name[64];
    std::snprintf(name, sizeof name, "layered-light-%016llx.bin", static_cast<unsigned long long>(f.value()));
    const std::string file = (std::filesystem::path(cacheDir) / name).string();
    std::error_code ec;
    if (std::filesystem::exists(file, ec)) {  // a missing file is the usual miss; anything else is worth a word
        try {
            return LightingVolume::load(file, s, p);
        } catch (const LightingFileError& e) {
            logMessage(LogLevel::Warning,
                       std::string("ignoring the cached lighting volume, computing it again: ") + e.what());
        }
    }
    LightingVolume v = precomputeLighting(s, p, cancel);
    std::filesystem::create_directories(cacheDir, ec);
    const std::string why = cache::write(file, serialise(v));
    if (!why.empty()) logMessage(LogLevel::Warning, "could not cache the lighting volume in " + cacheDir + ": " + why);
    return v;
}

}  // namespace nephele
