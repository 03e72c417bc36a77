// A NoiseVolume on the GPU (model/internal/noise_texture.hpp).
#include "noise_texture.hpp"

namespace nephele {
using namespace gl;

Texture linearRepeatTexture3D(int size, GLenum internalFormat, GLenum format, GLenum type, const void* texels) {
    Texture t = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(t.id(), 1, internalFormat, size, size, size);
    glTextureSubImage3D(t.id(), 0, 0, 0, 0, size, size, size, format, type, texels);
    glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
        glTextureParameteri(t.id(), w, GL_REPEAT);
    return t;
}

Texture noiseTexture(const NoiseVolume& v) {
    return linearRepeatTexture3D(v.size, GL_R32F, GL_RED, GL_FLOAT, v.texels.data());
}

}  // namespace nephele
