// The detail field's texture and uniforms (see model/internal/detail_texture.hpp).
#include "detail_texture.hpp"

namespace nephele {
using namespace gl;

void DetailTexture::bind(const Program& program, const Medium::Detail& detail, const Vec3& eye) {
    program.set("detail.erosion", float(detail.erosion));
    if (!detail.on()) return;
    if (!texture_) {
        const NoiseVolume& v = detailVolume();
        texture_ = Texture::create(GL_TEXTURE_3D);
        glTextureStorage3D(texture_.id(), 1, GL_R32F, v.size, v.size, v.size);
        glTextureSubImage3D(texture_.id(), 0, 0, 0, 0, v.size, v.size, v.size, GL_RED, GL_FLOAT, v.texels.data());
        glTextureParameteri(texture_.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(texture_.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) glTextureParameteri(texture_.id(), w, GL_REPEAT);
    }
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
