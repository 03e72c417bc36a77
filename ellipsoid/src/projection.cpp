#include "nephele/projection.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace nephele {

namespace {

// The ellipsoid in eye space: {c + A u : |u| <= 1} with A = V R diag(r), and S = A A^T, so that
// it is (x - c)^T S^-1 (x - c) <= 1. Its exact AABB has half-extent h_i = max over |u| <= 1 of
// (A u)_i = |row i of A| = sqrt(S_ii).
struct EyeSpace {
    Vec3 c;
    glm::dmat3 s;
    Vec3 h;
};

EyeSpace eyeSpace(const Ellipsoid& e, const View& view) {
    EyeSpace q;
    q.c = Vec3(view.viewMatrix * glm::dvec4(e.center, 1.0));
    const glm::dmat3 radii(e.radii.x, 0, 0, 0, e.radii.y, 0, 0, 0, e.radii.z);
    const glm::dmat3 a = glm::dmat3(view.viewMatrix) * rotationFromDegrees(e.rotationDeg) * radii;
    q.s = a * glm::transpose(a);
    q.h = Vec3(std::sqrt(q.s[0][0]), std::sqrt(q.s[1][1]), std::sqrt(q.s[2][2]));
    return q;
}

// The section by the near plane, the ellipse of points with z = -n (when the ellipsoid straddles
// it): its centre and half-extent per axis x, y (the ellipsoid's x, y conditioned on z, as for a
// Gaussian of covariance S).
struct NearSection {
    double mid[2] = {0, 0}, half[2] = {0, 0};
};

NearSection nearSection(const EyeSpace& q, double n) {
    NearSection sec;
    const double szz = q.s[2][2], dz = -n - q.c.z;
    const double shrink = std::max(0.0, 1.0 - dz * dz / szz);
    for (int i = 0; i < 2; ++i) {
        sec.mid[i] = q.c[i] + q.s[2][i] / szz * dz;
        sec.half[i] = std::sqrt(std::max(0.0, (q.s[i][i] - q.s[2][i] * q.s[2][i] / szz) * shrink));
    }
    return sec;
}

// Whether the near plane's cut of an ellipsoid that straddles it (the eye outside) matters: its
// section meets the view's near rectangle, or (conservatively) the ellipsoid comes within the
// near rectangle's corner distance of the eye, where it could poke into the frustum between the
// eye and the near plane. `u`: the eye in the ellipsoid's unit space; (cx, cy): the frustum's centre.
bool cutInView(const NearSection& sec, const View& view, double n, double cx, double cy, const Vec3& u,
               const Vec3& radii) {
    bool meets = true;
    for (int i = 0; i < 2; ++i) {
        const double m = sec.mid[i], half = sec.half[i];
        const double centre = i ? cy : cx, tanHalf = i ? view.tanHalfY : view.tanHalfX;
        const double lo = n * (centre - tanHalf), hi = n * (centre + tanHalf);  // the near rectangle, m
        const double slack = 1e-9 * (std::abs(m) + half + n);
        meets = meets && m - half <= hi + slack && m + half >= lo - slack;
    }
    const double reach =
        n * std::sqrt(1 + std::pow(std::abs(cx) + view.tanHalfX, 2) + std::pow(std::abs(cy) + view.tanHalfY, 2));
    const double rMin = std::min({radii.x, radii.y, radii.z});
    const bool close = (std::sqrt(glm::dot(u, u)) - 1.0) * rMin <= 1.01 * reach;  // a lower bound of its distance
    return meets || close;
}

// The NDC bounds of the box clipped to the depths -f <= z <= -n. On that slab depth d = -z > 0,
// so x / d is monotonic in x and in d: its bounds over the clipped box are at the box's corners.
ScreenRect clippedBoxBounds(const EllipsoidProjection& p, const View& view, double n, double f, double cx, double cy) {
    const double dNear = -std::min(p.boxMax.z, -n), dFar = -std::max(p.boxMin.z, -f);
    ScreenRect r{1e300, 1e300, -1e300, -1e300};
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
    return r;
}

// Across the near plane, the eye outside: the bounds of x_i / -z over the part beyond it, a
// convex body on which x_i / -z is linear-fractional, so each bound is where a plane through the
// eye, x_i = t (-z), supports it: either tangent to the ellipsoid at a point beyond the near
// plane, or at the section z = -n (its x_i range there / n). Exact where the box's corners at
// the near plane reached far outside the view. `r` is narrowed to them.
void clipToCutSilhouette(ScreenRect& r, const EyeSpace& q, const NearSection& sec, const View& view, double n,
                         double cx, double cy) {
    const Vec3& c = q.c;
    const glm::dmat3& s = q.s;
    const double szz = s[2][2];
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
    auto take = [&](int i, double t) {
        lo[i] = std::min(lo[i], t);
        hi[i] = std::max(hi[i], t);
    };
    for (int i = 0; i < 2; ++i) {
        take(i, (sec.mid[i] - sec.half[i]) / n);
        take(i, (sec.mid[i] + sec.half[i]) / n);
        // Tangent planes through the eye with normal nrm = e_i + t e_z: (nrm.c)^2 = nrm^T S nrm.
        const double qa = c.z * c.z - szz, qb = c[i] * c.z - s[2][i], qc = c[i] * c[i] - s[i][i];
        const double disc = qb * qb - qa * qc;
        if (disc < 0) continue;
        const double root = std::sqrt(disc);
        // qa = 0: the ellipsoid touches the eye's plane z = 0, one root is at infinity.
        const bool linear = std::abs(qa) <= 1e-12 * (c.z * c.z + szz);
        const double t0 = linear ? -qc / (2 * qb) : (-qb - root) / qa, t1 = linear ? t0 : (-qb + root) / qa;
        for (const double t : {t0, t1}) {
            if (!std::isfinite(t)) continue;
            Vec3 nrm(0.0);
            nrm[i] = 1, nrm.z = t;
            const Vec3 sn = s * nrm;
            const double qn = glm::dot(nrm, sn);
            if (!(qn > 0)) continue;
            const Vec3 touch = c - (glm::dot(nrm, c) > 0 ? 1.0 : -1.0) * sn / std::sqrt(qn);
            if (touch.z <= -n) take(i, t);
        }
    }
    for (int i = 0; i < 2; ++i) {
        const double centre = i ? cy : cx, tanHalf = i ? view.tanHalfY : view.tanHalfX;
        const double a = (lo[i] - centre) / tanHalf, b = (hi[i] - centre) / tanHalf;
        const double margin = 1e-9 * (1 + std::max(std::abs(a), std::abs(b)));
        if (i == 0) r.x0 = std::max(r.x0, a - margin), r.x1 = std::min(r.x1, b + margin);
        else r.y0 = std::max(r.y0, a - margin), r.y1 = std::min(r.y1, b + margin);
    }
}

// Wholly in front of the near plane (so at z < 0): the exact silhouette bounds are cheap and can
// be much tighter than the box's (flat or needle-like ellipsoids seen edge-on). The planes
// through the eye x_i = t (-z), normal n = e_i + t e_z, touch the ellipsoid where
// (n.c)^2 = n^T S n: qa t^2 + 2 qb t + qc = 0, whose roots are the min and max of x_i / -z over
// the ellipsoid. qa = cz^2 - hz^2 > 0 here; the discriminant is expanded so that the c_i^2 c_z^2
// terms cancel exactly. Rounding grows as the ellipsoid nears the plane z = 0
// (kappa = (|cz| + hz) / -(cz + hz) >= 1), so each bound is widened by a matching margin, far
// below a pixel. `r` is narrowed to them.
void clipToSilhouette(ScreenRect& r, const EyeSpace& q, const View& view, double cx, double cy) {
    const Vec3& c = q.c;
    const glm::dmat3& s = q.s;
    const Vec3& h = q.h;
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

}  // namespace

EllipsoidProjection projectEllipsoid(const Ellipsoid& e, const View& view) {
    EllipsoidProjection p;
    const double n = view.camera.nearClip, f = view.camera.farClip;  // m, planes z = -n, z = -f
    p.distance = glm::length(e.center - view.eye);
    const Vec3 u = ellipsoidToUnit(e) * (view.eye - e.center);
    p.eyeInside = glm::dot(u, u) < 1.0;

    const EyeSpace q = eyeSpace(e, view);
    p.boxMin = q.c - q.h;
    p.boxMax = q.c + q.h;
    // The box's z-range is the ellipsoid's own (h.z is its exact support), so the plane z = -n
    // cuts the ellipsoid iff the box straddles it. The cut matters only where a view ray starts
    // inside the ellipsoid (cutInView). An ellipsoid beside the eye whose cut lies outside the
    // view is a tile like any other: taking every box across the near plane as cut would light
    // it per pixel, never reuse it, and give it the box's rectangle.
    const double cx = 0.5 * (view.frustum.left + view.frustum.right),
                 cy = 0.5 * (view.frustum.bottom + view.frustum.top);
    const bool straddles = p.boxMin.z <= -n && p.boxMax.z >= -n;
    const NearSection sec = straddles ? nearSection(q, n) : NearSection{};
    if (p.eyeInside) p.crossesNear = true;
    else if (straddles) p.crossesNear = cutInView(sec, view, n, cx, cy, u, e.radii);

    // Cull on depth: the box lies entirely in front of the near plane (towards/behind the eye)
    // or entirely beyond the far plane. This holds even if the eye is inside: an ellipsoid that
    // ends before the near plane contributes nothing to the image.
    if (p.boxMin.z > -n || p.boxMax.z < -f) return p;

    // NDC of an eye-space tangent x / -z: (tangent - c) / tanHalf per axis, c the frustum's centre
    // (cx, cy above; 0 for a symmetric frustum: an off-axis channel of a wider view has its own).
    ScreenRect r{-1, -1, 1, 1};
    if (!p.eyeInside) {
        r = clippedBoxBounds(p, view, n, f, cx, cy);
        if (straddles) clipToCutSilhouette(r, q, sec, view, n, cx, cy);
        else clipToSilhouette(r, q, view, cx, cy);
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
