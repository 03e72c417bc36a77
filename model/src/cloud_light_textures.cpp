#include "cloud_light_textures.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_set>

namespace nephele {
using namespace gl;

void CloudLightTextures::grow(int slots) {
    GLint max3d = 0;
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
    const int perAxis = std::max(1, int(max3d) / (kSunRefinement * size_));  // the sun's texture is the largest
    const int gx = std::min(perAxis, int(std::ceil(std::cbrt(double(slots)))));
    const int gy = std::min(perAxis, int(std::ceil(std::sqrt(double(slots) / gx))));
    const int gz = (slots + gx * gy - 1) / (gx * gy);
    if (gz > perAxis)
        throw GlError("cloud light grids: " + std::to_string(slots) + " slots of " + std::to_string(size_) +
                      "^3 voxels do not fit GL_MAX_3D_TEXTURE_SIZE " + std::to_string(max3d) + "; lower the grid size");
    slots_ = glm::ivec3(gx, gy, gz);
    for (Texture& t : textures_) {
        t = Texture::create(GL_TEXTURE_3D);
        glTextureStorage3D(t.id(), 1, GL_RGBA16F, gx * size_, gy * size_, gz * size_);
    }
    const int fine = kSunRefinement * size_;
    sunTexture_ = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(sunTexture_.id(), 1, GL_R16F, gx * fine, gy * fine, gz * fine);
    slotUse_.assign(std::size_t(gx) * gy * gz, Slot{});
    resident_.clear();  // every grid is uploaded again into the new textures
}

std::size_t CloudLightTextures::textureBytes() const {
    const std::size_t voxels = std::size_t(slots_.x) * slots_.y * slots_.z * size_ * size_ * size_;
    return voxels * 4 * 8 + voxels * kSunRefinement * kSunRefinement * kSunRefinement * 2;
}

// The side of a grid's place: the smallest power of two at or above its size that divides
// the slot (the whole slot when the slot's side is no power of two).
int CloudLightTextures::blockFor(int gridSize) const {
    int block = 1;
    while (block < gridSize) block *= 2;
    return block > size_ || size_ % block != 0 ? size_ : block;
}

// A free place of blockFor(grid.size) in a slot of places of that side.
bool CloudLightTextures::place(const CloudRadiance& grid, Place& out) {
    const int block = blockFor(grid.size);
    const int per = size_ / block, places = per * per * per;
    int freeSlot = -1;
    for (int k = 0; k < int(slotUse_.size()); ++k) {
        Slot& slot = slotUse_[k];
        if (slot.block == 0) {
            if (freeSlot < 0) freeSlot = k;
            continue;
        }
        if (slot.block != block) continue;
        for (int i = 0; i < places; ++i)
            if (!slot.taken[i]) {
                slot.taken[i] = true;
                out = {k, i, block};
                return true;
            }
    }
    if (freeSlot < 0) return false;
    Slot& slot = slotUse_[freeSlot];
    slot.block = block;
    slot.taken.assign(places, false);
    slot.taken[0] = true;
    out = {freeSlot, 0, block};
    return true;
}

void CloudLightTextures::release(const Place& p) {
    Slot& slot = slotUse_[p.slot];
    slot.taken[p.index] = false;
    if (std::none_of(slot.taken.begin(), slot.taken.end(), [](bool t) { return t; })) slot = Slot{};
}

glm::ivec3 CloudLightTextures::origin(const Place& p) const {
    const int per = size_ / p.block;
    const glm::ivec3 slot(p.slot % slots_.x, p.slot / slots_.x % slots_.y, p.slot / (slots_.x * slots_.y));
    const glm::ivec3 within(p.index % per, p.index / per % per, p.index / (per * per));
    return slot * size_ + within * p.block;
}

void CloudLightTextures::upload(const CloudRadiance& grid, const Place& p) {
    const glm::ivec3 at = origin(p);
    const std::vector<glm::vec4>* data[4] = {&grid.sunFew, &grid.sunMany, &grid.skyTau, &grid.skyFlux};
    // A grid whose arrays do not match its size (made by hand, not by computeCloudRadiance)
    // would have the upload read past them.
    const std::size_t fineVoxels = std::size_t(grid.sunSize()) * grid.sunSize() * grid.sunSize();
    bool whole = grid.sunTransmittance.size() == fineVoxels;
    for (const auto* d : data) whole = whole && d->size() == grid.voxels();
    if (!whole)
        throw GlError("cloud light grid of " + std::to_string(grid.size) + "^3 voxels: its arrays do not hold " +
                      std::to_string(grid.voxels()) + " voxels and " + std::to_string(fineVoxels) +
                      " sun transmittances");
    // The shaders divide by it (the sun's texture holds T^p, CloudRadiance::sunPower).
    if (!(grid.sunPower > 0 && grid.sunPower <= 1))
        throw GlError("cloud light grid of " + std::to_string(grid.size) + "^3 voxels: its sunPower " +
                      std::to_string(grid.sunPower) + " is not in (0, 1]");
    // The upload reads tightly packed client memory whatever the host's unpack state is; that
    // state is the host's again afterwards.
    constexpr GLenum kUnpack[6] = {GL_UNPACK_ALIGNMENT,   GL_UNPACK_ROW_LENGTH, GL_UNPACK_IMAGE_HEIGHT,
                                   GL_UNPACK_SKIP_PIXELS, GL_UNPACK_SKIP_ROWS,  GL_UNPACK_SKIP_IMAGES};
    GLint saved[6], unpackBuffer = 0;
    for (int i = 0; i < 6; ++i) glGetIntegerv(kUnpack[i], &saved[i]);
    glGetIntegerv(GL_PIXEL_UNPACK_BUFFER_BINDING, &unpackBuffer);
    for (int i = 0; i < 6; ++i) glPixelStorei(kUnpack[i], i == 0 ? 4 : 0);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    for (int k = 0; k < 4; ++k)
        glTextureSubImage3D(textures_[k].id(), 0, at.x, at.y, at.z, grid.size, grid.size, grid.size, GL_RGBA, GL_FLOAT,
                            data[k]->data());
    const int fine = grid.sunSize();
    glTextureSubImage3D(sunTexture_.id(), 0, kSunRefinement * at.x, kSunRefinement * at.y, kSunRefinement * at.z, fine,
                        fine, fine, GL_RED, GL_FLOAT, grid.sunTransmittance.data());
    for (int i = 0; i < 6; ++i) glPixelStorei(kUnpack[i], saved[i]);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, GLuint(unpackBuffer));
    resident_[&grid] = p;
}

int CloudLightTextures::update(const std::vector<PlacedRadiance>& placed) {
    if (!sampler_) sampler_ = linearSampler(GL_CLAMP_TO_EDGE);
    std::unordered_set<const CloudRadiance*> used;
    std::vector<std::shared_ptr<const CloudRadiance>> inUse;
    for (const PlacedRadiance& p : placed)
        if (used.insert(p.grid.get()).second) inUse.push_back(p.grid);
    // A slot holds the largest grid in use, or several smaller ones; room for them all at once
    // (and for a part-filled slot of each smaller block size): no regrowth grid by grid on the
    // first frame.
    int size = 4;
    for (const auto& g : inUse) size = std::max(size, g->size);
    const bool larger = size > size_ || !textures_[0];
    if (larger) size_ = size;
    double need = 0;
    for (const auto& g : inUse) need += std::pow(double(blockFor(g->size)) / size_, 3);
    const int slots = int(std::ceil(need)) + 2, have = int(slotUse_.size());
    if (larger) grow(std::max(slots, have));
    else if (slots > have) grow(std::max(slots, 2 * have));
    // Places of grids no longer in use are free again; new grids take free ones, the textures
    // growing (doubling their slots, every grid uploaded again) when none is left.
    for (auto it = resident_.begin(); it != resident_.end();) {
        if (used.count(it->first)) {
            ++it;
        } else {
            release(it->second);
            it = resident_.erase(it);
        }
    }
    int uploaded = 0;
    for (std::size_t k = 0; k < inUse.size(); ++k) {
        const CloudRadiance& g = *inUse[k];
        if (resident_.count(&g)) continue;
        Place p;
        if (!place(g, p)) {
            grow(2 * int(slotUse_.size()));
            k = std::size_t(-1);  // again from the first, into the new textures
            continue;
        }
        upload(g, p);
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
        const Vec3 lo = p.lo - eye, inv = 1.0 / p.extent;
        const glm::ivec3 at = origin(resident_.at(p.grid.get()));
        boxes.insert(boxes.end(),
                     {float(lo.x), float(lo.y), float(lo.z), 0.0f, float(inv.x), float(inv.y), float(inv.z),
                      1.0f / p.grid->sunPower, float(at.x), float(at.y), float(at.z), float(p.grid->size)});
    }
    uploadDynamic(boxes_, boxesCapacity_, boxes.data(), boxes.size() * sizeof(float));
}

void CloudLightTextures::bind(const Program& program) const {
    // The block's binding is said here only (cloud_light_grid.glsl gives none), as the samplers' units.
    program.bindStorageBlock("CloudLightBoxes", kBoxesBinding);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kBoxesBinding, boxes_.id());
    const char* names[4] = {"lightSunFew", "lightSunMany", "lightSkyTau", "lightSkyFlux"};
    for (int k = 0; k < 4; ++k) {
        glBindTextureUnit(kFirstUnit + k, textures_[k].id());
        glBindSampler(kFirstUnit + k, sampler_.id());
        program.set(names[k], int(kFirstUnit + k));
    }
    glBindTextureUnit(kSunUnit, sunTexture_.id());
    glBindSampler(kSunUnit, sampler_.id());
    program.set("lightSunTransmittance", int(kSunUnit));
    program.set("lightSunRefinement", float(kSunRefinement));
    program.set("lightInvTexels", glm::vec3(1.0 / (glm::dvec3(slots_) * double(size_))));
}

}  // namespace nephele
