// Periodic improved Perlin noise, fBm and the tileable noise volume (see noise.hpp).
#include "nephele/noise.hpp"

#include "parallel.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace nephele {
namespace {

// PCG-RXS-M-XS 32-bit hash (Jarzynski & Olano, "Hash Functions for GPU Rendering",
// JCGT 2020). Pure unsigned arithmetic, so identical on every platform.
std::uint32_t pcgHash(std::uint32_t v) {
    const std::uint32_t state = v * 747796405u + 2891336453u;
    const std::uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Perlin 2002's grad(): the dot of (x,y,z) with one of the 12 cube-edge directions,
// picked by 4 hash bits (16 entries, 4 of them repeated, to avoid a division). The same
// table as his bit-twiddling version, as a lookup: no unpredictable branches. We use the
// top bits, the best mixed ones of the PCG output.
float grad(std::uint32_t hash, float x, float y, float z) {
    static constexpr float g[16][3] = {{1, 1, 0},  {-1, 1, 0},  {1, -1, 0}, {-1, -1, 0}, {1, 0, 1},  {-1, 0, 1},
                                       {1, 0, -1}, {-1, 0, -1}, {0, 1, 1},  {0, -1, 1},  {0, 1, -1}, {0, -1, -1},
                                       {1, 1, 0},  {0, -1, 1},  {-1, 1, 0}, {0, -1, -1}};
    const float* d = g[hash >> 28u];
    return d[0] * x + d[1] * y + d[2] * z;
}

// Perlin 2002's quintic fade 6t^5 - 15t^4 + 10t^3: C2 across cells.
float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
float lerp(float a, float b, float t) { return a + t * (b - a); }

// Non-negative remainder: the lattice index reduced into [0, n).
int wrap(int i, int n) {
    const int r = i % n;
    return r < 0 ? r + n : r;
}

// One axis of GL_LINEAR + GL_REPEAT (OpenGL 4.6 core, §8.14.2): u = s * size - 1/2, the
// two texels are floor(u) and floor(u) + 1, each wrapped modulo size, and the weight of
// the second is frac(u). Wrapping s into [0,1) first picks the same texels and weight
// and keeps frac(u) precise for large |s|.
struct Tap {
    int i0, i1;
    float a;
};
Tap linearRepeat(float s, int size) {
    s -= std::floor(s);  // may round to exactly 1 for tiny negative s: still wraps correctly
    const float u = s * float(size) - 0.5f;
    const float f = std::floor(u);
    const int i = int(f);
    return {wrap(i, size), wrap(i + 1, size), u - f};
}

// Perlin noise with the period already checked. The lattice hash is nested as in
// Jarzynski & Olano: pcg(x ^ pcg(y ^ pcg(z ^ pcg(seed)))), with x, y, z reduced modulo
// the period; the inner levels are shared between corners (2 + 4 + 8 hashes, not 32).
float perlinPeriodic(const glm::vec3& p, int period, unsigned seed) {
    const glm::vec3 cell = glm::floor(p);
    const glm::vec3 f = p - cell;  // position inside the cell, [0,1)
    // Lattice indices of the cell's two corners per axis, reduced modulo the period.
    const auto corners = [period](float c, std::uint32_t(&out)[2]) {
        const int i = wrap(int(c), period);
        out[0] = std::uint32_t(i);
        out[1] = std::uint32_t(i + 1 == period ? 0 : i + 1);
    };
    std::uint32_t x[2], y[2], z[2];
    corners(cell.x, x);
    corners(cell.y, y);
    corners(cell.z, z);
    const std::uint32_t s = pcgHash(seed);
    float n[2][2][2];  // n[c][b][a]: gradient contribution of corner (x[a], y[b], z[c])
    for (int c = 0; c < 2; ++c) {
        const std::uint32_t hz = pcgHash(z[c] ^ s);
        for (int b = 0; b < 2; ++b) {
            const std::uint32_t hyz = pcgHash(y[b] ^ hz);
            for (int a = 0; a < 2; ++a)
                n[c][b][a] = grad(pcgHash(x[a] ^ hyz), f.x - float(a), f.y - float(b), f.z - float(c));
        }
    }
    // Blend the 8 corners with the fade weights.
    const float u = fade(f.x), v = fade(f.y), w = fade(f.z);
    return lerp(lerp(lerp(n[0][0][0], n[0][0][1], u), lerp(n[0][1][0], n[0][1][1], u), v),
                lerp(lerp(n[1][0][0], n[1][0][1], u), lerp(n[1][1][0], n[1][1][1], u), v), w);
}

}  // namespace

float perlinNoise(const glm::vec3& p, int period, unsigned seed) {
    if (period < 1) throw std::invalid_argument("perlinNoise: period must be >= 1, got " + std::to_string(period));
    return perlinPeriodic(p, period, seed);
}

float fbm(const glm::vec3& p, int octaves, int period, unsigned seed) {
    if (octaves < 1 || octaves > 31)
        throw std::invalid_argument("fbm: octaves must be in [1, 31], got " + std::to_string(octaves));
    if (period < 1 || period > (INT_MAX >> (octaves - 1)))
        throw std::invalid_argument("fbm: period " + std::to_string(period) + " is < 1 or too large for " +
                                    std::to_string(octaves) + " octaves");
    float sum = 0.0f, amplitude = 1.0f, total = 0.0f, frequency = 1.0f;
    for (int o = 0; o < octaves; ++o) {
        // Lacunarity 2: frequency and period double together, so every octave repeats
        // every `period` in p. Each octave gets its own seed (golden-ratio step) so the
        // octaves do not share the gradient at the origin.
        sum += amplitude * perlinPeriodic(p * frequency, period << o, seed + unsigned(o) * 0x9E3779B9u);
        total += amplitude;
        amplitude *= 0.5f;
        frequency *= 2.0f;
    }
    return sum / total;
}

template <class T>
T sampleLinearRepeat(const std::vector<T>& texels, int size, const glm::vec3& uvw) {
    if (size <= 0) return T(0);
    const Tap x = linearRepeat(uvw.x, size), y = linearRepeat(uvw.y, size), z = linearRepeat(uvw.z, size);
    const auto at = [&](int i, int j, int k) {
        return texels[std::size_t(i) + std::size_t(size) * (j + std::size_t(size) * k)];
    };
    // (1-a)*t0 + a*t1 as in the GL specification's formula: at a = 0 it is t0 exactly.
    const auto mix = [](const T& t0, const T& t1, float a) { return (1.0f - a) * t0 + a * t1; };
    const T c00 = mix(at(x.i0, y.i0, z.i0), at(x.i1, y.i0, z.i0), x.a);
    const T c10 = mix(at(x.i0, y.i1, z.i0), at(x.i1, y.i1, z.i0), x.a);
    const T c01 = mix(at(x.i0, y.i0, z.i1), at(x.i1, y.i0, z.i1), x.a);
    const T c11 = mix(at(x.i0, y.i1, z.i1), at(x.i1, y.i1, z.i1), x.a);
    return mix(mix(c00, c10, y.a), mix(c01, c11, y.a), z.a);
}
template float sampleLinearRepeat(const std::vector<float>&, int, const glm::vec3&);
template glm::vec3 sampleLinearRepeat(const std::vector<glm::vec3>&, int, const glm::vec3&);

float NoiseVolume::sample(const glm::vec3& uvw) const { return sampleLinearRepeat(texels, size, uvw); }

NoiseVolume makeNoiseVolume(int size, int cells, int octaves, unsigned seed) {
    if (size < 2 || size > 1024)
        throw std::invalid_argument("makeNoiseVolume: size must be in [2, 1024], got " + std::to_string(size));
    if (cells < 1) throw std::invalid_argument("makeNoiseVolume: cells must be >= 1, got " + std::to_string(cells));
    if (octaves < 1)
        throw std::invalid_argument("makeNoiseVolume: octaves must be >= 1, got " + std::to_string(octaves));
    NoiseVolume volume;
    volume.size = size;
    volume.texels.resize(std::size_t(size) * size * size);
    const float scale = float(cells) / float(size);  // lattice cells per texel
    // One z slice per task: every texel depends only on its own position, so the result
    // does not depend on the number of threads.
    parallelFor(size, [&](int k) {
        float* slice = volume.texels.data() + std::size_t(size) * size * k;
        for (int j = 0; j < size; ++j)
            for (int i = 0; i < size; ++i)
                slice[i + size * j] =
                    fbm((glm::vec3(float(i), float(j), float(k)) + 0.5f) * scale, octaves, cells, seed);
    });
    double mean = 0.0;
    for (float t : volume.texels) mean += t;
    mean /= double(volume.texels.size());
    double largest = 0.0;
    for (float t : volume.texels) largest = std::max(largest, std::abs(double(t) - mean));
    // Division, not a reciprocal, so the largest |value| becomes exactly 1. A constant
    // volume (no variation at all) just becomes 0.
    for (float& t : volume.texels) t = largest > 0.0 ? float((double(t) - mean) / largest) : 0.0f;
    return volume;
}

NoiseVolume makeNoiseVolume(const NoiseSettings& settings) {
    return makeNoiseVolume(settings.size, settings.cells, settings.octaves, settings.seed);
}

namespace {
std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}
}  // namespace

glm::dvec3 ellipsoidNoiseOffset(std::size_t cloud, std::size_t index, unsigned seed) {
    // SplitMix64 of (cloud, index, seed), three draws of 53 bits each in [0, 1).
    std::uint64_t h = splitmix64((std::uint64_t(cloud) << 32) ^ std::uint64_t(index) ^ (std::uint64_t(seed) << 48));
    glm::dvec3 offset;
    for (int k = 0; k < 3; ++k) offset[k] = double((h = splitmix64(h)) >> 11) * 0x1.0p-53;
    return offset;
}

}  // namespace nephele
