// The detail field's texture and uniforms (see model/internal/detail_texture.hpp).
#include "detail_texture.hpp"

#include "noise_texture.hpp"

#include <cmath>
#include <cstdint>
#include <vector>

namespace nephele {
using namespace gl;

namespace {

// detailVolume() as GL_RGBA8 (alpha unused: a 3-byte texel is not a format llvmpipe samples
// fast), GL_LINEAR, GL_REPEAT. Its texels are multiples of 1/255 already: the bytes are exact.
Texture detailTexture(const DetailVolume& v) {
    std::vector<std::uint8_t> bytes(v.texels.size() * 4, 0);
    for (std::size_t i = 0; i < v.texels.size(); ++i)
        for (int c = 0; c < model::kDetailGroup; ++c)
            bytes[4 * i + std::size_t(c)] = std::uint8_t(std::lround(v.texels[i][c] * 255.0f));
    return linearRepeatTexture3D(v.size, GL_RGBA8, GL_RGBA, GL_UNSIGNED_BYTE, bytes.data());
}

}  // namespace

DetailTexture::Variant DetailTexture::variant(const Medium::Detail& detail) {
    if (!detail.on()) return Variant::Off;
    return detail.kind == Medium::Detail::Kind::Reference ? Variant::Reference : Variant::Nephele;
}

std::string DetailTexture::defines(Variant variant) {
    if (variant == Variant::Off) return "";
    const int kind = variant == Variant::Reference ? model::kDetailReference : model::kDetailNephele;
    return "#define DETAIL 1\n#define DETAIL_KIND " + std::to_string(kind) + "\n";
}

void DetailTexture::bind(const Program& program, const Medium::Detail& detail, const Vec3& eye) {
    program.set("detail.erosion", float(detail.erosion));
    if (!detail.on()) return;
    if (!texture_) texture_ = detailTexture(detailVolume());
    const model::DetailParams p = detailParams(detail, eye);
    program.set("detail.origin", p.origin);
    program.set("detail.scale", p.scale);
    program.set("detail.smallest", p.smallest);
    program.set("detail.mean", p.mean);
    program.set("detail.octaves", p.octaves);
    program.set("detail.kind", p.kind);
    program.set("detailPieces", kTilePieces);
    program.set("detailVolume", int(kUnit));
    glBindTextureUnit(kUnit, texture_.id());
    glBindSampler(kUnit, 0);
}

}  // namespace nephele
