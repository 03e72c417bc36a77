// The detail field's CPU side (see nephele/detail.hpp).
#include "nephele/detail.hpp"

#include "parallel.hpp"

#include <algorithm>
#include <cmath>

namespace nephele {
namespace {

// One feature point per Worley cell, in [0, 1)^3 of the cell, from the PCG hash of its index
// (reduced modulo the period, so the texture tiles) and of the channel.
glm::vec3 featurePoint(int i, int j, int k, int cells, std::uint32_t channel) {
    const auto wrap = [cells](int v) { return std::uint32_t(((v % cells) + cells) % cells); };
    std::uint32_t h =
        model::detailHash(wrap(i) ^ model::detailHash(wrap(j) ^ model::detailHash(wrap(k) ^ (0xC0FFEEu + channel))));
    glm::vec3 p;
    for (int a = 0; a < 3; ++a) {
        h = model::detailHash(h);
        p[a] = float(h >> 8) * (1.0f / 16777216.0f);
    }
    return p;
}

// The distance (in cells) from p to the nearest feature point: the 27 cells around p's.
float worleyF1(const glm::vec3& p, int cells, std::uint32_t channel) {
    const glm::ivec3 c(glm::floor(p));
    float best = 1e9f;
    for (int k = -1; k <= 1; ++k)
        for (int j = -1; j <= 1; ++j)
            for (int i = -1; i <= 1; ++i) {
                const glm::ivec3 n = c + glm::ivec3(i, j, k);
                const glm::vec3 q = glm::vec3(n) + featurePoint(n.x, n.y, n.z, cells, channel);
                best = std::min(best, glm::dot(q - p, q - p));
            }
    return std::sqrt(best);
}

// The standard deviation of channel c of v as the filter reads it, at 4096 fixed points.
float sampledDeviation(const DetailVolume& v, int c) {
    double sum = 0, squares = 0;
    std::uint32_t h = 1;
    const int n = 4096;
    for (int i = 0; i < n; ++i) {
        glm::vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = float((h = model::detailHash(h)) >> 8) * (1.0f / 16777216.0f);
        const double x = v.sample(p)[c];
        sum += x, squares += x * x;
    }
    return float(std::sqrt(std::max(squares / n - (sum / n) * (sum / n), 0.0)));
}

DetailVolume makeDetailVolume() {
    const int size = kDetailTextureSize;
    DetailVolume v;
    v.size = size;
    v.texels.resize(std::size_t(size) * size * size);
    parallelFor(size, [&](int k) {
        for (int j = 0; j < size; ++j)
            for (int i = 0; i < size; ++i) {
                const glm::vec3 centre = glm::vec3(float(i), float(j), float(k)) + 0.5f;
                glm::vec3& texel = v.texels[std::size_t(i) + std::size_t(size) * (j + std::size_t(size) * k)];
                for (int c = 0; c < model::kDetailGroup; ++c) {
                    const int cells = int(model::kDetailTextureCells) << c;
                    const float f =
                        std::min(worleyF1(centre * (float(cells) / float(size)), cells, std::uint32_t(c)), 1.0f);
                    texel[c] = f * f;
                }
            }
    });
    // With fewer texels a cell the filter smooths the finer channels (4 texels a cell read about
    // 0.9 of the deviation of 16): each is spread about its mean to channel 0's, so that every
    // octave bites as deep as its weight says. Then rounded to the texture's bytes.
    glm::vec3 mean(0.0f);
    for (const glm::vec3& t : v.texels) mean += t / float(v.texels.size());
    glm::vec3 spread(1.0f);
    const float deviation0 = sampledDeviation(v, 0);
    for (int c = 1; c < model::kDetailGroup; ++c) spread[c] = deviation0 / sampledDeviation(v, c);
    for (glm::vec3& t : v.texels) t = glm::round(glm::clamp(mean + (t - mean) * spread, 0.0f, 1.0f) * 255.0f) / 255.0f;
    return v;
}

}  // namespace

glm::vec3 DetailVolume::sample(const glm::vec3& uvw) const { return sampleLinearRepeat(texels, size, uvw); }

const DetailVolume& detailVolume() {
    static const DetailVolume volume = makeDetailVolume();
    return volume;
}

glm::vec3 detailVolumeMeans() {
    static const glm::vec3 means = [] {
        glm::dvec3 sum(0);
        for (const glm::vec3& t : detailVolume().texels) sum += glm::dvec3(t);
        return glm::vec3(sum / double(detailVolume().texels.size()));
    }();
    return means;
}

model::DetailParams detailParams(const Medium::Detail& detail, const Vec3& eye) {
    model::DetailParams p{};
    p.origin = glm::vec3(eye - detail.drift);
    p.erosion = float(detail.erosion);
    p.scale = float(detail.scale);
    p.smallest = float(detail.smallest);
    p.octaves = int(std::floor(std::log2(detail.scale / detail.smallest) + 1e-9)) + 1;
    p.kind = detail.kind == Medium::Detail::Kind::Reference ? model::kDetailReference : model::kDetailNephele;
    p.mean = p.kind == model::kDetailReference ? glm::vec3(kDetailReferenceMean) : detailVolumeMeans();
    return p;
}

int exactPieces(const model::DetailParams& p, float chord, float nearest) {
    const float finest = detailFinestWavelength(nearest, p.smallest);
    return int(std::clamp(std::ceil(4.0f * chord / finest), 1.0f, float(kExactPiecesMax)));
}

float detailErosionAt(const Medium::Detail& detail, const Vec3& eye, const Vec3& x) {
    if (!detail.on()) return 0.0f;
    const model::DetailParams p = detailParams(detail, eye);
    return model::detailErosion(detailVolume(), p, glm::vec3(x - eye));
}

}  // namespace nephele
