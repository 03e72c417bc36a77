// The clouds' radiance grids (nephele/light_cache.hpp) on the GPU, for the compositor and the
// ray-marcher (shaders/cloud_light_grid.glsl reads them): three RGBA16F 3D textures with one
// slot per grid, and a storage buffer of the grids' boxes relative to the eye. A grid keeps its
// slot while it is in use, so a cloud that moves costs only its box: nothing is re-created or
// uploaded while the clouds only drift. The textures grow (doubling their slots) when more
// grids are in use than they hold.
#pragma once

#include "nephele/gl.hpp"
#include "nephele/light_cache.hpp"
#include "nephele/shader.hpp"

#include <map>
#include <vector>

namespace nephele {

class CloudLightTextures {
public:
    static constexpr GLuint kBoxesBinding = 3;  // shader storage binding of cloudLightBoxes
    static constexpr GLuint kFirstUnit = 6;     // texture units of the three grids: 6, 7, 8

    // Makes the grids of `placed` (one per scene cloud, all of one size) resident, uploading
    // only grids that are new. Returns how many grids were uploaded. Throws GlError when the
    // slots would exceed GL_MAX_3D_TEXTURE_SIZE.
    int update(const std::vector<PlacedRadiance>& placed);
    // Writes the boxes of `placed` (as given to update()) relative to `eye`: once per view.
    void setBoxes(const std::vector<PlacedRadiance>& placed, const Vec3& eye);
    // Binds the buffer and the textures (with a linear, clamp-to-edge sampler) and sets the
    // sampling uniforms of `program` (which includes cloud_light_grid.glsl).
    void bind(const Program& program) const;

private:
    void grow(int slots);
    void upload(const CloudRadiance& grid, int slot);

    gl::Texture textures_[3];
    gl::Sampler sampler_;
    gl::Buffer boxes_;
    std::size_t boxesCapacity_ = 0;
    int size_ = 0;                       // voxels per side of a slot
    glm::ivec3 slots_{0};                // slots along x, y, z
    std::map<const CloudRadiance*, int> resident_;  // grid -> slot
    std::vector<std::shared_ptr<const CloudRadiance>> keep_;  // the grids in use (their slots stay theirs)
};

}  // namespace nephele
