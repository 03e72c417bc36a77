#include "nephele/cloud_light_textures.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace nephele {
using namespace gl;

void CloudLightTextures::grow(int slots) {
    GLint max3d = 0;
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
    const int perAxis = std::max(1, int(max3d) / size_);
    const int gx = std::min(perAxis, int(std::ceil(std::cbrt(double(slots)))));
    const int gy = std::min(perAxis, int(std::ceil(std::sqrt(double(slots) / gx))));
    const int gz = (slots + gx * gy - 1) / (gx * gy);
    if (gz > perAxis)
        throw GlError("cloud light grids: " + std::to_string(slots) + " clouds of " + std::to_string(size_) +
                      "^3 voxels do not fit GL_MAX_3D_TEXTURE_SIZE " + std::to_string(max3d) + "; lower the grid size");
    slots_ = glm::ivec3(gx, gy, gz);
    for (Texture& t : textures_) {
        t = Texture::create(GL_TEXTURE_3D);
        glTextureStorage3D(t.id(), 1, GL_RGBA16F, gx * size_, gy * size_, gz * size_);
    }
    resident_.clear();  // every grid is uploaded again into the new textures
}

void CloudLightTextures::upload(const CloudRadiance& grid, int slot) {
    const int gx = slots_.x, gy = slots_.y;
    const glm::ivec3 origin = glm::ivec3(slot % gx, slot / gx % gy, slot / (gx * gy)) * size_;
    const std::vector<glm::vec4>* data[3] = {&grid.sunDiffuse, &grid.skyTau, &grid.skyFlux};
    // The upload reads tightly packed client memory whatever the host's unpack state is; that
    // state is the host's again afterwards.
    constexpr GLenum kUnpack[6] = {GL_UNPACK_ALIGNMENT, GL_UNPACK_ROW_LENGTH, GL_UNPACK_IMAGE_HEIGHT,
                                   GL_UNPACK_SKIP_PIXELS, GL_UNPACK_SKIP_ROWS, GL_UNPACK_SKIP_IMAGES};
    GLint saved[6], unpackBuffer = 0;
    for (int i = 0; i < 6; ++i) glGetIntegerv(kUnpack[i], &saved[i]);
    glGetIntegerv(GL_PIXEL_UNPACK_BUFFER_BINDING, &unpackBuffer);
    for (int i = 0; i < 6; ++i) glPixelStorei(kUnpack[i], i == 0 ? 4 : 0);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    for (int k = 0; k < 3; ++k)
        glTextureSubImage3D(textures_[k].id(), 0, origin.x, origin.y, origin.z, size_, size_, size_, GL_RGBA, GL_FLOAT,
                            data[k]->data());
    for (int i = 0; i < 6; ++i) glPixelStorei(kUnpack[i], saved[i]);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, GLuint(unpackBuffer));
    resident_[&grid] = slot;
}

int CloudLightTextures::update(const std::vector<PlacedRadiance>& placed) {
    if (!sampler_) sampler_ = linearSampler(GL_CLAMP_TO_EDGE);
    int uploaded = 0;
    std::vector<std::shared_ptr<const CloudRadiance>> inUse;
    for (const PlacedRadiance& p : placed)
        if (std::find(inUse.begin(), inUse.end(), p.grid) == inUse.end()) inUse.push_back(p.grid);
    const int size = placed.empty() ? 4 : placed.front().grid->size;
    const int capacity = slots_.x * slots_.y * slots_.z;
    if (size != size_ || int(inUse.size()) > capacity || !textures_[0]) {
        size_ = size;
        grow(std::max({int(inUse.size()), 2 * capacity, 1}));
    }
    // Slots of grids no longer in use are free again; new grids take the free ones.
    std::map<const CloudRadiance*, int> kept;
    std::vector<bool> taken(std::size_t(slots_.x) * slots_.y * slots_.z, false);
    for (const auto& g : inUse)
        if (auto it = resident_.find(g.get()); it != resident_.end()) kept[g.get()] = it->second, taken[it->second] = true;
    resident_ = kept;
    int next = 0;
    for (const auto& g : inUse) {
        if (resident_.count(g.get())) continue;
        while (taken[next]) ++next;
        taken[next] = true;
        upload(*g, next);
        ++uploaded;
    }
    keep_ = std::move(inUse);
    check("uploading the cloud light grids");
    return uploaded;
}

void CloudLightTextures::setBoxes(const std::vector<PlacedRadiance>& placed, const Vec3& eye) {
    // Camera-relative (float precision stays at the eye).
    std::vector<float> boxes;
    for (const PlacedRadiance& p : placed) {
        const Vec3 lo = p.boxMin() - eye, inv = 1.0 / p.grid->boxExtent;
        const int slot = resident_.at(p.grid.get());
        const glm::ivec3 origin = glm::ivec3(slot % slots_.x, slot / slots_.x % slots_.y, slot / (slots_.x * slots_.y)) * size_;
        boxes.insert(boxes.end(), {float(lo.x), float(lo.y), float(lo.z), 0.0f, float(inv.x), float(inv.y), float(inv.z), 0.0f,
                                   float(origin.x), float(origin.y), float(origin.z), 0.0f});
    }
    uploadDynamic(boxes_, boxesCapacity_, boxes.data(), boxes.size() * sizeof(float));
}

void CloudLightTextures::bind(const Program& program) const {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kBoxesBinding, boxes_.id());
    const char* names[3] = {"lightSunDiffuse", "lightSkyTau", "lightSkyFlux"};
    for (int k = 0; k < 3; ++k) {
        glBindTextureUnit(kFirstUnit + k, textures_[k].id());
        glBindSampler(kFirstUnit + k, sampler_.id());
        program.set(names[k], int(kFirstUnit + k));
    }
    program.set("lightGridSize", float(size_));
    program.set("lightInvTexels", glm::vec3(1.0 / (glm::dvec3(slots_) * double(size_))));
}

}  // namespace nephele
