// View maths shared by the GPU passes and the CPU references, so both see the same rays.
//
// A View is any perspective frustum, off-axis included (a display channel of a wider
// view), with the depth convention of the frame it is drawn into and the place of its
// viewport in that frame. makeView(Camera) is the scene format's symmetric camera; a host
// with its own matrices uses makeView(ViewDesc) (nephele/host_view.hpp).
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

#include <glm/glm.hpp>

NEPHELE_API_BEGIN
namespace nephele {

// How a frame's depth buffer maps eye depth. Window depth d in [0, 1] (glDepthRange(0, 1)).
struct DepthConvention {
    bool reversedZ = false;  // the near plane at depth 1, the far plane at 0 (tested with GL_GREATER)
    bool zeroToOne = false;  // clip-space depth in [0, 1], glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
                             // else OpenGL's [-1, 1]
    bool operator==(const DepthConvention&) const = default;
};

// An off-axis frustum as the tangents of its edges at unit distance along the view axis:
// the symmetric camera of vertical field of view f and aspect a is
// {-a tan(f/2), a tan(f/2), -tan(f/2), tan(f/2)}. left < right, bottom < top.
struct Frustum {
    double left = -1, right = 1, bottom = -1, top = 1;
    bool operator==(const Frustum&) const = default;
};

struct View {
    Camera camera;  // eye, direction and up; near and far (m; far capped at kMaxFar); width and height =
                    // the viewport's size in pixels; fovYDeg = 2 atan of half the frustum's height
    Vec3 eye{0.0};
    Vec3 forward{0, 1, 0}, right{1, 0, 0}, up{0, 0, 1};  // orthonormal, right-handed
    Frustum frustum;                                     // tangents of the edges
    double tanHalfY = 0, tanHalfX = 0;                   // half the frustum's height / width at unit distance
    glm::dmat4 viewMatrix{1.0};                          // world -> eye, OpenGL convention (looks down -z)
    glm::dmat4 projectionMatrix{1.0};                    // eye -> clip, this frustum in `depth`'s convention
    DepthConvention depth;                               // of the frame the view is drawn into
    glm::ivec2 origin{0};                                // the viewport's lower-left corner in the frame (pixels)

    // Unit world direction through image point (px, py), in pixels from the top-left
    // corner of the viewport; the centre of pixel (i, j) is (i + 0.5, j + 0.5).
    Vec3 rayDirection(double px, double py) const;
    // The ray through normalised device coordinates (x, y), not normalised, its component
    // along `forward` 1: rayCentre() + x rightScaled() + y upScaled() (what shaders evaluate).
    Vec3 rayCentre() const;
    Vec3 rightScaled() const { return right * tanHalfX; }
    Vec3 upScaled() const { return up * tanHalfY; }
    // NDC x (y) of the eye-space point whose horizontal (vertical) tangent x/-z is `tangent`.
    double ndcX(double tangent) const;
    double ndcY(double tangent) const;
    // Window depth d -> eye depth z (m, along -z of eye space) as 1 / z = x d + y, and z the
    // depth of "no surface" (the far plane: 1, or 0 with reversedZ): what shaders read a copy
    // of the frame's depth with (shaders/view_frame.glsl).
    glm::dvec3 depthParameters() const;
    // Window depth of the far plane (what a cleared depth buffer holds): 1, or 0 with reversedZ.
    double farDepth() const { return depth.reversedZ ? 0.0 : 1.0; }
    // projectionMatrix times the view's rotation alone: world directions, or points given
    // relative to the eye, to clip space.
    glm::dmat4 rotationViewProjection() const;
};

// Far planes beyond this (an infinite reversed-Z projection's included) count as this far (m).
inline constexpr double kMaxFar = 1e7;

// The scene camera's symmetric frustum. Throws std::invalid_argument if the camera's
// direction is zero or parallel to up.
View makeView(const Camera& camera);
// The camera's eye, turned by yawDeg (about the camera's up, positive to the right) and then
// pitchDeg (about the turned right axis, positive up) — a display channel's rotation —, with
// `frustum` instead of fov_y (the camera's width and height stay the image size). Throws
// std::invalid_argument for a degenerate camera or frustum.
View makeView(const Camera& camera, const Frustum& frustum, double yawDeg = 0, double pitchDeg = 0);
// The symmetric frustum of a vertical field of view (degrees) and an aspect ratio.
Frustum symmetricFrustum(double fovYDeg, double aspect);

}  // namespace nephele
NEPHELE_API_END
