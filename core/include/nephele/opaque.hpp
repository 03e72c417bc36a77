// The sky, the ground and the scene's opaque objects, exactly as the format defines them:
// sky radiance `horizon + (zenith - horizon) * max(d.z, 0)`, the ground colour for d.z < 0,
// and boxes and spheres with Lambert shading under the sun (radiance
// `albedo * sun.color * sun.intensity / pi * max(n.l, 0)`, no ambient term).
// A GPU pass and a CPU reference that evaluates the same formulas per ray.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/image.hpp"
#include "nephele/scene.hpp"
#include "nephele/shader.hpp"

#include <optional>

NEPHELE_API_BEGIN
namespace nephele {

// An off-screen frame: RGBA32F colour (rgb = linear radiance, a = cloud opacity) and a
// DEPTH24_STENCIL8 depth/stencil texture. Needs a current context.
class FrameTarget {
public:
    FrameTarget(int width, int height);
    int width() const { return width_; }
    int height() const { return height_; }
    GLuint framebuffer() const { return fbo_.id(); }
    GLuint colorTexture() const { return color_.id(); }
    GLuint depthStencilTexture() const { return depth_.id(); }
    // Read back as RGBA, top row first.
    Image readColor() const;

private:
    int width_, height_;
    gl::Texture color_, depth_;
    gl::Framebuffer fbo_;
};

// The scene's boxes and spheres, drawn by a pair of programs of object.vert and object.frag (the
// second with SPHERE defined): OpaquePass's, lit by the sun, and the compositor's, lit by the
// clouds too (object_light "all"). Needs a current context.
class ObjectMeshes {
public:
    ObjectMeshes();
    // Draws every object of `scene` into the bound frame with the depth test already set, each
    // program's per-view uniforms (viewProjection and the light's) set by the caller.
    void draw(const Scene& scene, const View& view, const Program& box, const Program& sphere) const;

private:
    gl::IndexedMesh box_;
};

class OpaquePass {
public:
    OpaquePass();  // builds shaders and meshes in the current context
    // Clears colour (alpha 0), depth and stencil of the view's viewport in `framebuffer` (at
    // view.origin, view.camera.width x height), draws the sky and the objects into it, in the
    // view's depth convention. Leaves the GL state as it found it.
    void draw(const Scene& scene, const View& view, GLuint framebuffer) const;

private:
    Program sky_, object_, sphereProgram_;
    gl::VertexArray empty_;
    ObjectMeshes objects_;
};

// ---- CPU reference: the same formulas, per ray, in double precision.
Vec3 skyRadiance(const Sky& sky, const Vec3& direction);
Vec3 lambertRadiance(const Sun& sun, const Vec3& albedo, const Vec3& normal);

struct SurfaceHit {
    double distance = 0;  // along the (unit) ray
    Vec3 normal{0.0};     // unit, facing the ray
    Vec3 albedo{0.0};
};
// The nearest object hit by the ray (origin, unit direction) within (tMin, tMax).
std::optional<SurfaceHit> intersectObjects(const Scene& scene, const Vec3& origin, const Vec3& direction, double tMin,
                                           double tMax);
// Radiance of the sky/ground/objects along a camera ray (clipped to the camera's near/far).
Vec3 opaqueRadiance(const Scene& scene, const View& view, const Vec3& direction);
// A full RGBA image (alpha 0) of the sky and objects, one ray per pixel centre.
Image renderOpaqueCpu(const Scene& scene, const View& view);

}  // namespace nephele
NEPHELE_API_END
