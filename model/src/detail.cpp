// The detail field's CPU side (see nephele/detail.hpp).
#include "nephele/detail.hpp"

#include "parallel.hpp"

#include <algorithm>
#include <cmath>

namespace nephele {
namespace {

// One feature point per Worley cell, in [0, 1)^3 of the cell, from the PCG hash of its index
// (reduced modulo the period, so the texture tiles).
glm::vec3 featurePoint(int i, int j, int k, int cells) {
    const auto wrap = [cells](int v) { return std::uint32_t(((v % cells) + cells) % cells); };
    std::uint32_t h = model::detailHash(wrap(i) ^ model::detailHash(wrap(j) ^ model::detailHash(wrap(k) ^ 0xC0FFEEu)));
    glm::vec3 p;
    for (int a = 0; a < 3; ++a) {
        h = model::detailHash(h);
        p[a] = float(h >> 8) * (1.0f / 16777216.0f);
    }
    return p;
}

// The distance (in cells) from p to the nearest feature point: the 27 cells around p's.
float worleyF1(const glm::vec3& p, int cells) {
    const glm::ivec3 c(glm::floor(p));
    float best = 1e9f;
    for (int k = -1; k <= 1; ++k)
        for (int j = -1; j <= 1; ++j)
            for (int i = -1; i <= 1; ++i) {
                const glm::ivec3 n = c + glm::ivec3(i, j, k);
                const glm::vec3 q = glm::vec3(n) + featurePoint(n.x, n.y, n.z, cells);
                best = std::min(best, glm::dot(q - p, q - p));
            }
    return std::sqrt(best);
}

NoiseVolume makeDetailVolume() {
    const int size = kDetailTextureSize, cells = int(model::kDetailTextureCells);
    NoiseVolume v;
    v.size = size;
    v.texels.resize(std::size_t(size) * size * size);
    const float scale = float(cells) / float(size);  // cells per texel
    parallelFor(size, [&](int k) {
        for (int j = 0; j < size; ++j)
            for (int i = 0; i < size; ++i) {
                const float f =
                    std::min(worleyF1((glm::vec3(float(i), float(j), float(k)) + 0.5f) * scale, cells), 1.0f);
                v.texels[std::size_t(i) + std::size_t(size) * (j + std::size_t(size) * k)] = f * f;
            }
    });
    return v;
}

}  // namespace

const NoiseVolume& detailVolume() {
    static const NoiseVolume volume = makeDetailVolume();
    return volume;
}

float detailVolumeMean() {
    static const float mean = [] {
        double sum = 0;
        for (float t : detailVolume().texels) sum += t;
        return float(sum / double(detailVolume().texels.size()));
    }();
    return mean;
}

model::DetailParams detailParams(const Medium::Detail& detail, const Vec3& eye) {
    model::DetailParams p{};
    p.origin = glm::vec3(eye - detail.drift);
    p.erosion = float(detail.erosion);
    p.scale = float(detail.scale);
    p.smallest = float(detail.smallest);
    p.octaves = int(std::floor(std::log2(detail.scale / detail.smallest) + 1e-9)) + 1;
    p.kind = detail.kind == Medium::Detail::Kind::Reference ? model::kDetailReference : model::kDetailNephele;
    p.mean = p.kind == model::kDetailReference ? kDetailReferenceMean : detailVolumeMean();
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
