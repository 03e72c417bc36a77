// The detail field's texture and uniforms (see model/internal/detail_texture.hpp).
#include "detail_texture.hpp"

#include "noise_texture.hpp"

namespace nephele {
using namespace gl;

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
    if (!texture_) texture_ = noiseTexture(detailVolume());
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
