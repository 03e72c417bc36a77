// The clouds' radiance grids (model/internal/light_cache.hpp) on the GPU, for the compositor and the
// ray-marcher (shaders/cloud_light_grid.glsl reads them): four RGBA16F 3D textures with one
// slot per grid, a fifth (R16F, kSunRefinement times the texels per axis, its slots in the same
// places scaled so) of the sun's transmittance, and a storage buffer of the grids' boxes
// relative to the eye. A grid keeps its
// slot while it is in use, so a cloud that moves costs only its box: nothing is re-created or
// uploaded while the clouds only drift. The textures grow (doubling their slots) when more
// grids are in use than they hold.
#pragma once

#include "nephele/api.hpp"
#include "nephele/gl.hpp"
#include "light_cache.hpp"
#include "nephele/shader.hpp"

#include <map>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

class CloudLightTextures {
public:
    static constexpr GLuint kBoxesBinding = 3;  // shader storage binding of cloudLightBoxes (set by bind())
    static constexpr GLuint kFirstUnit = 6;     // texture units of the four grids: 6, 7, 8, 9
    static constexpr GLuint kSunUnit = 10;      // and of the sun's transmittance

    // Makes the grids of `placed` (one per scene cloud) resident, uploading
    // only grids that are new. Returns how many grids were uploaded. Throws GlError when the
    // slots would exceed GL_MAX_3D_TEXTURE_SIZE.
    int update(const std::vector<PlacedRadiance>& placed);
    // Writes the boxes of `placed` (as given to update()) relative to `eye`: once per view.
    void setBoxes(const std::vector<PlacedRadiance>& placed, const Vec3& eye);
    // Binds the buffer and the textures (with a linear, clamp-to-edge sampler) and sets the
    // sampling uniforms and the boxes' block binding of `program` (which includes
    // cloud_light_grid.glsl).
    void bind(const Program& program) const;

    // Bytes of GPU memory the grids' slots hold (all five textures), for the tests.
    std::size_t textureBytes() const;

private:
    // A slot of size_^3 texels holds one grid of up to size_ voxels per side, or (size_ / b)^3
    // grids of up to b, b a power of two (8^3 grids of small clouds share a slot of 32^3).
    struct Slot {
        int block = 0;            // the side of its grids' places; 0: free
        std::vector<bool> taken;  // per place
    };
    struct Place {
        int slot = 0, index = 0, block = 0;
    };
    void grow(int slots);
    int blockFor(int gridSize) const;
    bool place(const CloudRadiance& grid, Place& out);
    void release(const Place& p);
    glm::ivec3 origin(const Place& p) const;
    void upload(const CloudRadiance& grid, const Place& p);

    gl::Texture textures_[4];
    gl::Texture sunTexture_;
    gl::Sampler sampler_;
    gl::Buffer boxes_;
    std::size_t boxesCapacity_ = 0;
    int size_ = 0;         // texels per side of a slot
    glm::ivec3 slots_{0};  // slots along x, y, z
    std::vector<Slot> slotUse_;
    std::map<const CloudRadiance*, Place> resident_;          // grid -> where it is
    std::vector<std::shared_ptr<const CloudRadiance>> keep_;  // the grids in use (their places stay theirs)
};

}  // namespace nephele
NEPHELE_API_END
