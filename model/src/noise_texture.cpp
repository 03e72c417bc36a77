// A NoiseVolume on the GPU (model/internal/noise_texture.hpp).
#include "noise_texture.hpp"

namespace nephele {
using namespace gl;

Texture noiseTexture(const NoiseVolume& v) {
    Texture t = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(t.id(), 1, GL_R32F, v.size, v.size, v.size);
    glTextureSubImage3D(t.id(), 0, 0, 0, 0, v.size, v.size, v.size, GL_RED, GL_FLOAT, v.texels.data());
    glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
        glTextureParameteri(t.id(), w, GL_REPEAT);
    return t;
}

}  // namespace nephele
