// Objects lit by the clouds (object_light "all", data/scene-format.md; docs/light.md, "Objects
// lit by the clouds"), for every method that has the clouds' grids on the GPU (the compositor
// and the ray-marcher): the scene's objects, already drawn by OpaquePass with their depth, drawn
// again in place with object.frag's CLOUD_LIGHT variant, and its CPU twin lightAt() (what a
// host lights its own aircraft by).
#pragma once

#include "nephele/api.hpp"
#include "nephele/cloud_radiance.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/opaque.hpp"
#include "cloud_light_textures.hpp"
#include "light_cache.hpp"

#include <memory>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

class ObjectLightPass {
public:
    ObjectLightPass();
    ~ObjectLightPass();
    // Draws the objects of `scene` over the frame's depth (the objects' own, drawn by
    // OpaquePass), lit by the sun through the clouds, the open sky and the grids `light`, which
    // `textures` holds with their boxes set for view.eye. Builds its programs at the first call;
    // needs a current context; leaves the GL state as it found it.
    void draw(const Scene& scene, const View& view, const HostFrame& frame, const CloudLightTextures& textures,
              const std::vector<PlacedRadiance>& light);
    // What draw() lights a surface at world `point` of unit `normal` by, from the CPU copies of
    // the same grids (sampleRadiance reads them as the GPU does). CPU only.
    static SurfaceLight lightAt(const Scene& scene, const std::vector<PlacedRadiance>& light, const Vec3& point,
                                const Vec3& normal);

private:
    struct Programs;
    std::unique_ptr<Programs> programs_;
};

}  // namespace nephele
NEPHELE_API_END
