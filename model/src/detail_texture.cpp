// The detail field's texture and uniforms (see model/internal/detail_texture.hpp).
#include "detail_texture.hpp"

#include "noise_texture.hpp"

namespace nephele {
using namespace gl;

std::string DetailTexture::kindDefine(Medium::Detail::Kind kind) {
    return "#define DETAIL_KIND " +
           std::to_string(kind == Medium::Detail::Kind::Reference ? model::kDetailReference : model::kDetailNephele) +
           "\n";
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
