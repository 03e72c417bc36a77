#include "nephele/projection.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace nephele {

glm::dmat3 ellipsoidToUnit(const Ellipsoid& e) {
    const glm::dmat3 invRadii(1.0 / e.radii.x, 0, 0, 0, 1.0 / e.radii.y, 0, 0, 0, 1.0 / e.radii.z);
    return invRadii * glm::transpose(rotationFromDegrees(e.rotationDeg));
}

EllipsoidProjection projectEllipsoid(const Ellipsoid& e, const View& view) {
    EllipsoidProjection p;
    const double n = view.camera.nearClip, f = view.camera.farClip;  // m, planes z = -n, z = -f
    p.distance = glm::length(e.center - view.eye);
    const Vec3 u = ellipsoidToUnit(e) * (view.eye - e.center);
    p.eyeInside = glm::dot(u, u) < 1.0;

    // Eye space: the ellipsoid is {c + A u : |u| <= 1} with A = V R diag(r). Its exact AABB has
    // half-extent h_i = max over |u| <= 1 of (A u)_i = |row i of A| = sqrt(S_ii), S = A A^T.
    const Vec3 c(view.viewMatrix * glm::dvec4(e.center, 1.0));
    const glm::dmat3 radii(e.radii.x, 0, 0, 0, e.radii.y, 0, 0, 0, e.radii.z);
    const glm::dmat3 a = glm::dmat3(view.viewMatrix) * rotationFromDegrees(e.rotationDeg) * radii;
    const glm::dmat3 s = a * glm::transpose(a);  // S = A A^T: the ellipsoid is (x - c)^T S^-1 (x - c) <= 1
    const Vec3 h(std::sqrt(s[0][0]), std::sqrt(s[1][1]), std::sqrt(s[2][2]));
    p.boxMin = c - h;
    p.boxMax = c + h;
    p.crossesNear = p.eyeInside || (p.boxMin.z <= -n && p.boxMax.z >= -n);

    // Cull on depth: the box lies entirely in front of the near plane (towards/behind the eye)
    // or entirely beyond the far plane. This holds even if the eye is inside: an ellipsoid that
    // ends before the near plane contributes nothing to the image.
    if (p.boxMin.z > -n || p.boxMax.z < -f) return p;

    // NDC of an eye-space tangent x / -z: (tangent - c) / tanHalf per axis, c the frustum's centre
    // (0 for a symmetric frustum: an off-axis channel of a wider view has its own).
    const double cx = 0.5 * (view.frustum.left + view.frustum.right), cy = 0.5 * (view.frustum.bottom + view.frustum.top);
    ScreenRect r{-1, -1, 1, 1};
    if (!p.eyeInside) {
        // Clip the box to the depths -f <= z <= -n. On that slab depth d = -z > 0, so x / d is
        // monotonic in x and in d: its bounds over the clipped box are at the box's corners.
        const double dNear = -std::min(p.boxMax.z, -n), dFar = -std::max(p.boxMin.z, -f);
        r = {1e300, 1e300, -1e300, -1e300};
        for (const double d : {dNear, dFar}) {
            for (const double x : {p.boxMin.x, p.boxMax.x}) {
                r.x0 = std::min(r.x0, (x - cx * d) / (d * view.tanHalfX));
                r.x1 = std::max(r.x1, (x - cx * d) / (d * view.tanHalfX));
            }
            for (const double y : {p.boxMin.y, p.boxMax.y}) {
                r.y0 = std::min(r.y0, (y - cy * d) / (d * view.tanHalfY));
                r.y1 = std::max(r.y1, (y - cy * d) / (d * view.tanHalfY));
            }
        }
        if (!p.crossesNear) {
            // Wholly in front of the near plane (so at z < 0): the exact silhouette bounds are cheap
            // and can be much tighter than the box's (flat or needle-like ellipsoids seen edge-on).
            // The planes through the eye x_i = t (-z), normal n = e_i + t e_z, touch the ellipsoid
            // where (n.c)^2 = n^T S n: qa t^2 + 2 qb t + qc = 0, whose roots are the min and max of
            // x_i / -z over the ellipsoid. qa = cz^2 - hz^2 > 0 here; the discriminant is expanded
            // so that the c_i^2 c_z^2 terms cancel exactly. Rounding grows as the ellipsoid nears the
            // plane z = 0 (kappa = (|cz| + hz) / -(cz + hz) >= 1), so each bound is widened by a
            // matching margin, far below a pixel.
            const double kappa = (h.z - c.z) / -(c.z + h.z);
            double lo[2], hi[2];
            for (int i = 0; i < 2; ++i) {
                const double qa = (c.z - h.z) * (c.z + h.z), qb = c[i] * c.z - s[2][i];
                const double disc = s[i][i] * c.z * c.z - 2 * s[2][i] * c[i] * c.z + s[2][2] * c[i] * c[i] -
                                    (s[i][i] * s[2][2] - s[2][i] * s[2][i]);
                const double root = std::sqrt(std::max(disc, 0.0)), tanHalf = i ? view.tanHalfY : view.tanHalfX;
                const double centre = i ? cy : cx;
                lo[i] = ((-qb - root) / qa - centre) / tanHalf;
                hi[i] = ((-qb + root) / qa - centre) / tanHalf;
                const double margin = 1e-13 * kappa * (1 + std::max(std::abs(lo[i]), std::abs(hi[i])));
                lo[i] -= margin;
                hi[i] += margin;
            }
            r = {std::max(r.x0, lo[0]), std::max(r.y0, lo[1]), std::min(r.x1, hi[0]), std::min(r.y1, hi[1])};
        }
        r = {std::max(r.x0, -1.0), std::max(r.y0, -1.0), std::min(r.x1, 1.0), std::min(r.y1, 1.0)};
        if (!(r.x0 < r.x1 && r.y0 < r.y1)) return p;  // outside the view
    }

    p.visible = true;
    p.rect = r;
    p.pixelWidth = 0.5 * (r.x1 - r.x0) * view.camera.width;
    p.pixelHeight = 0.5 * (r.y1 - r.y0) * view.camera.height;
    // The near-plane window of the rect, in eye-space metres (NDC x on the near plane is
    // (x / n - cx) / tanHalfX).
    const double sx = n * view.tanHalfX, sy = n * view.tanHalfY;
    p.projection = glm::frustum(r.x0 * sx + n * cx, r.x1 * sx + n * cx, r.y0 * sy + n * cy, r.y1 * sy + n * cy, n, f);
    return p;
}

}  // namespace nephele
