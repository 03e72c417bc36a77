// Per-ellipsoid projection (Elinas & Stuerzlinger 2000, section 3.3): each cloud ellipsoid is
// rendered perspective-correct into its own tile. Its eye-space bounding box, clipped to the
// near/far slab, is projected on the near plane; the bounds of that projection are a rectangle,
// which gives an off-axis (skewed) frustum and a viewport. When the ellipsoid lies wholly beyond
// the near plane the rectangle is also cut to the exact bounds of its silhouette (tangent planes
// through the eye), which the box can overestimate many times for flat or thin ellipsoids.
//
// Conventions: eye space is OpenGL's (View::viewMatrix; the eye looks down -z, x right, y up),
// lengths in metres. Screen positions are NDC of View::projectionMatrix: x right, y UP, the
// view is [-1,1]^2 (pixel y, in contrast, grows downwards: py = (1 - y_ndc) / 2 * height).
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/ellipsoid_space.hpp"  // ellipsoidToUnit (the model's, nephele_model)
#include "nephele/scene.hpp"

#include <glm/glm.hpp>

NEPHELE_API_BEGIN
namespace nephele {

struct ScreenRect {
    double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};  // NDC, x0 < x1, y0 < y1, inside [-1,1]^2

struct EllipsoidProjection {
    bool visible = false;  // false: culled (entirely behind the near plane, beyond the far plane, or outside the view)
    bool eyeInside = false;    // the eye is inside the ellipsoid (q(eye) < 1)
    bool crossesNear = false;  // the near plane z = -near cuts it where the view sees (a view ray starts inside it;
                               // eyeInside, or conservatively when it comes within reach of the near rectangle)
    ScreenRect rect;           // its rectangle on the near plane, in NDC, clipped to the view; [-1,1]^2 if eyeInside
    double pixelWidth = 0, pixelHeight = 0;  // rect size in pixels of the camera image (fractional)
    glm::dmat4 projection{1.0};  // off-axis perspective (glm::frustum) whose frustum is exactly `rect` with the
                                 // camera's near/far: eye space -> tile clip space; rect corners map to NDC (+-1, +-1)
    double distance = 0;         // m, |center - eye|, the back-to-front sort key
    glm::dvec3 boxMin{0.0}, boxMax{0.0};  // m, exact eye-space axis-aligned bounding box of the ellipsoid (unclipped)
};

// The tile of `e` seen from `view`. Only `visible` projections have a meaningful rect,
// pixel size and projection; eyeInside, crossesNear, distance and the box are always set.
EllipsoidProjection projectEllipsoid(const Ellipsoid& e, const View& view);

}  // namespace nephele
NEPHELE_API_END
