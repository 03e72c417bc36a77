// Per-ellipsoid projection (ellipsoid/include/nephele/projection.hpp): the tile rectangle must
// contain the ellipsoid's exact screen silhouette, the tile projection must be the screen
// projection restricted to the rect, and culling must only drop what cannot be seen.
#include "nephele/projection.hpp"

#include "nephele/camera.hpp"
#include "prepared_clouds.hpp"

#include "test_build.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

using namespace nephele;

namespace {

constexpr double kTol = 1e-9;  // NDC values are O(1); 1e-9 is relative to the view's half-size

struct Rng {
    std::mt19937_64 g;
    explicit Rng(unsigned seed) : g(seed) {}
    double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(g); }
    double logUni(double a, double b) { return std::exp(uni(std::log(a), std::log(b))); }
    Vec3 unit() {
        std::normal_distribution<double> nd;
        Vec3 v;
        do v = Vec3(nd(g), nd(g), nd(g));
        while (glm::length(v) < 1e-6);
        return glm::normalize(v);
    }
};

View randomView(Rng& rng) {
    Camera c;
    c.position = Vec3(rng.uni(-2000, 2000), rng.uni(-2000, 2000), rng.uni(-500, 3000));
    c.direction = rng.unit();
    do c.up = rng.unit();
    while (glm::length(glm::cross(c.direction, c.up)) < 0.1);
    c.fovYDeg = rng.uni(20, 120);
    const double aspect = rng.uni(0.5, 2.5);
    c.height = int(rng.uni(100, 1000));
    c.width = std::max(1, int(std::lround(c.height * aspect)));
    c.nearClip = rng.logUni(0.1, 10);
    c.farClip = c.nearClip * rng.logUni(10, 3e4);  // sometimes short, so ellipsoids cross the far plane
    return makeView(c);
}

Ellipsoid randomEllipsoid(Rng& rng) {
    Ellipsoid e;
    e.radii = Vec3(rng.logUni(1, 500), rng.logUni(1, 500), rng.logUni(1, 500));
    e.rotationDeg = Vec3(rng.uni(-180, 180), rng.uni(-180, 180), rng.uni(-180, 180));
    return e;
}

// World points of an ellipsoid: at(u) for u in the unit ball (R and diag(r) multiplied once).
struct Body {
    Vec3 center;
    glm::dmat3 axes;  // R diag(r)
    explicit Body(const Ellipsoid& e)
        : center(e.center),
          axes(rotationFromDegrees(e.rotationDeg) * glm::dmat3(e.radii.x, 0, 0, 0, e.radii.y, 0, 0, 0, e.radii.z)) {}
    Vec3 at(const Vec3& u) const { return center + axes * u; }
};
Vec3 ellipsoidPoint(const Ellipsoid& e, const Vec3& u) { return Body(e).at(u); }

// Places e's centre relative to the view; `mode` picks the kind of case.
void placeEllipsoid(Ellipsoid& e, const View& v, Rng& rng, int mode) {
    const double rMax = e.maxRadius();
    const double rMin = std::min({e.radii.x, e.radii.y, e.radii.z});
    const double n = v.camera.nearClip;
    switch (mode) {
        case 0: {  // in front, anywhere in (and a little beyond) the view
            const double d = rng.uni(n + 0.2 * rMin, 6 * rMax + 2 * n);
            e.center = v.eye + d * v.forward + rng.uni(-1.3, 1.3) * d * v.tanHalfX * v.right +
                       rng.uni(-1.3, 1.3) * d * v.tanHalfY * v.up;
            break;
        }
        case 1:  // the eye inside: eye = c + A u with |u| < 1
            e.center = v.eye - (ellipsoidPoint(e, rng.unit() * rng.uni(0.0, 0.98)) - e.center);
            break;
        case 2: {  // around the near plane, the eye (usually) outside
            const double d = rng.uni(-rMax, rMax) + n;
            e.center = v.eye + d * v.forward + rng.uni(-1, 1) * rMax * v.right + rng.uni(-1, 1) * rMax * v.up;
            break;
        }
        case 3:  // anywhere, including behind the eye and beyond the far plane
            e.center = v.eye + rng.unit() * rng.logUni(1, 4 * v.camera.farClip + 1000);
            break;
        default: {  // in the view, its box ending just beyond the near plane (ill-conditioned silhouettes)
            placeEllipsoid(e, v, rng, 0);
            const double boxFront = projectEllipsoid(e, v).boxMax.z;  // eye-space z of the box's front face
            e.center += (boxFront + n * (1 + rng.logUni(1e-9, 1e-2))) * v.forward;
            break;
        }
    }
}

Vec3 eyeSpace(const View& v, const Vec3& w) { return Vec3(v.viewMatrix * glm::dvec4(w, 1.0)); }

// Screen NDC (x, y, z) of a world point through the camera's own matrices; w in `wOut`.
Vec3 screenNdc(const View& v, const Vec3& w, double* wOut = nullptr) {
    const glm::dvec4 clip = v.projectionMatrix * v.viewMatrix * glm::dvec4(w, 1.0);
    if (wOut) *wOut = clip.w;
    return Vec3(clip) / clip.w;
}

// Is the world point inside the view frustum (between near and far, within the fov)?
bool inFrustum(const View& v, const Vec3& w, Vec3* ndc) {
    const double z = eyeSpace(v, w).z;
    if (z > -v.camera.nearClip || z < -v.camera.farClip) return false;
    *ndc = screenNdc(v, w);
    return std::abs(ndc->x) <= 1 && std::abs(ndc->y) <= 1;
}

// Exact bounds of the ellipsoid's screen silhouette, valid when it lies wholly at z < 0, in long
// double from the same double inputs. The planes through the eye x = t * (-z) (normal (1, 0, t))
// are tangent where (n . c)^2 = n^T S n with S = A A^T, a quadratic in t; its roots are the
// min/max of x / -z.
ScreenRect exactSilhouette(const Ellipsoid& e, const View& v) {
    using L = long double;
    const glm::dmat3 rot = rotationFromDegrees(e.rotationDeg);
    L a[3][3], s[3][3], c[3];  // a = V R diag(r) (row, column), c = eye-space centre
    for (int i = 0; i < 3; ++i) {
        c[i] = v.viewMatrix[3][i];
        for (int k = 0; k < 3; ++k) c[i] += L(v.viewMatrix[k][i]) * e.center[k];
        for (int j = 0; j < 3; ++j) {
            a[i][j] = 0;
            for (int k = 0; k < 3; ++k) a[i][j] += L(v.viewMatrix[k][i]) * rot[j][k];
            a[i][j] *= e.radii[j];
        }
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) s[i][j] = a[i][0] * a[j][0] + a[i][1] * a[j][1] + a[i][2] * a[j][2];
    auto roots = [&](int i, double tanHalf, double& lo, double& hi) {
        const L qa = c[2] * c[2] - s[2][2], qb = 2 * (c[i] * c[2] - s[i][2]), qc = c[i] * c[i] - s[i][i];
        const L q = std::sqrt(std::max(L(0), qb * qb - 4 * qa * qc));
        lo = double((-qb - q) / (2 * qa) / tanHalf);
        hi = double((-qb + q) / (2 * qa) / tanHalf);
    };
    ScreenRect out;
    roots(0, v.tanHalfX, out.x0, out.x1);
    roots(1, v.tanHalfY, out.y0, out.y1);
    return out;
}

bool rectContains(const ScreenRect& r, double x, double y, double tol = kTol) {
    return x >= r.x0 - tol && x <= r.x1 + tol && y >= r.y0 - tol && y <= r.y1 + tol;
}

std::string describe(int k, const Ellipsoid& e, const View& v, const EllipsoidProjection& p) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "case %d: c=(%g,%g,%g) r=(%g,%g,%g) rot=(%g,%g,%g) | eye=(%g,%g,%g) fov=%g %dx%d near=%g far=%g"
                  " | visible=%d inside=%d crossesNear=%d rect=[%g,%g]x[%g,%g]",
                  k, e.center.x, e.center.y, e.center.z, e.radii.x, e.radii.y, e.radii.z, e.rotationDeg.x,
                  e.rotationDeg.y, e.rotationDeg.z, v.eye.x, v.eye.y, v.eye.z, v.camera.fovYDeg, v.camera.width,
                  v.camera.height, v.camera.nearClip, v.camera.farClip, p.visible, p.eyeInside, p.crossesNear,
                  p.rect.x0, p.rect.x1, p.rect.y0, p.rect.y1);
    return buf;
}

View simpleView(double fovY = 60, int w = 640, int h = 480, double n = 0.5, double f = 10000) {
    Camera c;
    c.position = Vec3(10, -20, 300);
    c.direction = glm::normalize(Vec3(0.3, 1, 0.1));
    c.fovYDeg = fovY;
    c.width = w;
    c.height = h;
    c.nearClip = n;
    c.farClip = f;
    return makeView(c);
}

TEST(ProjectionTest, NdcFormulaMatchesProjectionMatrixAndPixelConvention) {
    Rng rng(1);
    for (int k = 0; k < 200; ++k) {
        const View v = randomView(rng);
        const double px = rng.uni(0, v.camera.width), py = rng.uni(0, v.camera.height);
        const Vec3 w = v.eye + rng.uni(v.camera.nearClip, v.camera.farClip) * v.rayDirection(px, py);
        const Vec3 pe = eyeSpace(v, w), ndc = screenNdc(v, w);
        EXPECT_NEAR(ndc.x, pe.x / (-pe.z * v.tanHalfX), kTol);
        EXPECT_NEAR(ndc.y, pe.y / (-pe.z * v.tanHalfY), kTol);
        EXPECT_NEAR(ndc.x, 2 * px / v.camera.width - 1, kTol);   // pixel x grows right
        EXPECT_NEAR(ndc.y, 1 - 2 * py / v.camera.height, kTol);  // pixel y grows down, NDC y up
    }
}

TEST(ProjectionTest, RectContainsSilhouetteOfRandomEllipsoids) {
    Rng rng(2);
    // Per case: kSamples on the surface + kSamples inside (a quarter under the sanitizers, which
    // check the same code on fewer points).
    constexpr int kCases = 2000, kSamples = test::kSanitized ? 500 : 2000;
    int visibleCases[5] = {}, casesWithSamples[5] = {}, crossingWithSamples = 0, besideWithSamples = 0;
    long samplesChecked = 0;
    for (int k = 0; k < kCases; ++k) {
        const View v = randomView(rng);
        Ellipsoid e = randomEllipsoid(rng);
        const int mode = k % 5;
        placeEllipsoid(e, v, rng, mode);
        const EllipsoidProjection p = projectEllipsoid(e, v);
        if (mode == 1) {
            ASSERT_TRUE(p.eyeInside) << describe(k, e, v, p);
        }
        visibleCases[mode] += p.visible;
        ASSERT_NEAR(p.distance, glm::length(e.center - v.eye), 1e-9 * p.distance);
        if (p.visible) {
            ASSERT_TRUE(p.rect.x0 < p.rect.x1 && p.rect.y0 < p.rect.y1) << describe(k, e, v, p);
            ASSERT_TRUE(p.rect.x0 >= -1 && p.rect.x1 <= 1 && p.rect.y0 >= -1 && p.rect.y1 <= 1) << describe(k, e, v, p);
        }
        int inside = 0;
        const Body body(e);
        for (int i = 0; i < 2 * kSamples; ++i) {
            const double scale = i < kSamples ? 1.0 : std::cbrt(rng.uni(0, 1));  // surface, then uniform in the volume
            const Vec3 w = body.at(rng.unit() * scale);
            // The exact eye-space box contains every point of the ellipsoid.
            const Vec3 pe = eyeSpace(v, w), slack = 1e-9 * (glm::abs(p.boxMin) + glm::abs(p.boxMax) + 1.0);
            ASSERT_TRUE(glm::all(glm::greaterThanEqual(pe, p.boxMin - slack)) &&
                        glm::all(glm::lessThanEqual(pe, p.boxMax + slack)))
                << describe(k, e, v, p);
            Vec3 ndc;
            if (!inFrustum(v, w, &ndc)) continue;
            ++inside;
            ASSERT_TRUE(p.visible) << describe(k, e, v, p) << " sample ndc " << ndc.x << "," << ndc.y;
            ASSERT_TRUE(rectContains(p.rect, ndc.x, ndc.y))
                << describe(k, e, v, p) << " sample ndc " << ndc.x << "," << ndc.y;
        }
        samplesChecked += inside;
        casesWithSamples[mode] += inside > 0;
        // Across the near plane with the eye outside: cut where the view sees (rays start inside
        // it) or beside the eye, its cut outside the view (the exact bounds of the part beyond).
        const bool straddles = p.boxMin.z <= -v.camera.nearClip && p.boxMax.z >= -v.camera.nearClip;
        crossingWithSamples += inside > 0 && p.crossesNear && !p.eyeInside;
        besideWithSamples += inside > 0 && straddles && !p.crossesNear;
    }
    // The suite is not vacuous: every kind of case happened, with samples in the view.
    for (int m = 0; m < 5; ++m) {
        EXPECT_GT(visibleCases[m], 50) << "mode " << m;
        EXPECT_GT(casesWithSamples[m], 50) << "mode " << m;
    }
    EXPECT_GT(crossingWithSamples, 50);
    EXPECT_GT(besideWithSamples, 50);
    EXPECT_GT(samplesChecked, 50 * kSamples);
    EXPECT_LT(visibleCases[3], kCases / 5);  // random placements are often culled
}

TEST(ProjectionTest, RectContainsExactSilhouetteAndBoxIsTightAabb) {
    Rng rng(3);
    int checked = 0;
    double worstMiss = 0, worstExcess = 0;                  // NDC: silhouette outside rect / rect beyond the silhouette
    constexpr int kCases = test::kSanitized ? 1000 : 4000;  // the sanitizers check the same code on fewer
    for (int k = 0; k < kCases; ++k) {
        const View v = randomView(rng);
        Ellipsoid e = randomEllipsoid(rng);
        placeEllipsoid(e, v, rng, k % 2 ? 0 : 4);
        const EllipsoidProjection p = projectEllipsoid(e, v);
        // The AABB is exact: its faces touch the ellipsoid (checked by sampling the surface).
        Vec3 lo(1e300), hi(-1e300);
        const Body body(e);
        for (int i = 0; i < 5000; ++i) {
            const Vec3 pe = eyeSpace(v, body.at(rng.unit()));
            lo = glm::min(lo, pe);
            hi = glm::max(hi, pe);
        }
        const Vec3 ext = p.boxMax - p.boxMin;
        for (int i = 0; i < 3; ++i) {
            EXPECT_NEAR(lo[i], p.boxMin[i], 0.01 * ext[i]) << describe(k, e, v, p);
            EXPECT_NEAR(hi[i], p.boxMax[i], 0.01 * ext[i]) << describe(k, e, v, p);
        }
        // Wholly between the near and far planes: the exact silhouette bounds, clipped to the view, lie in rect.
        if (p.boxMax.z > -v.camera.nearClip || p.boxMin.z < -v.camera.farClip) continue;
        const ScreenRect s = exactSilhouette(e, v);
        const ScreenRect sc{std::max(s.x0, -1.0), std::max(s.y0, -1.0), std::min(s.x1, 1.0), std::min(s.y1, 1.0)};
        if (!(sc.x0 < sc.x1 && sc.y0 < sc.y1)) continue;  // the silhouette's bounds miss the view
        ++checked;
        ASSERT_TRUE(p.visible) << describe(k, e, v, p);
        EXPECT_TRUE(rectContains(p.rect, sc.x0, sc.y0) && rectContains(p.rect, sc.x1, sc.y1))
            << describe(k, e, v, p) << " silhouette [" << s.x0 << "," << s.x1 << "]x[" << s.y0 << "," << s.y1 << "]";
        worstMiss = std::max({worstMiss, p.rect.x0 - sc.x0, p.rect.y0 - sc.y0, sc.x1 - p.rect.x1, sc.y1 - p.rect.y1});
        worstExcess =
            std::max({worstExcess, sc.x0 - p.rect.x0, sc.y0 - p.rect.y0, p.rect.x1 - sc.x1, p.rect.y1 - sc.y1});
    }
    EXPECT_GT(checked, kCases / 4);
    std::printf("exact silhouette vs rect (%d cases), NDC: worst miss %.3g, worst excess %.3g\n", checked, worstMiss,
                worstExcess);
    // Measured 5.3e-6 NDC of excess (near-plane cases, whose rect is conservative); the
    // widened rect (tests/sabotage/11-rect-wider.sabotage) 0.04. 2e-5 is 4x the
    // measured, still a hundredth of a pixel at 1000 px.
    EXPECT_LT(worstExcess, 2e-5);
}

TEST(ProjectionTest, RectIsTightForEllipsoidsWellInFront) {
    Rng rng(4);
    double worst = 0, worstExcess = 0;  // area ratio; NDC of the rect beyond the exact silhouette
    int checked = 0;
    for (int k = 0; k < 2000; ++k) {
        const View v = randomView(rng);
        Ellipsoid e = randomEllipsoid(rng);
        const double rMax = e.maxRadius();
        // At least 5 bounding radii away, centre in the middle half of the view, within near/far.
        const double d = rng.uni(5, 20) * rMax + v.camera.nearClip;
        e.center = v.eye + d * v.forward + rng.uni(-0.5, 0.5) * d * v.tanHalfX * v.right +
                   rng.uni(-0.5, 0.5) * d * v.tanHalfY * v.up;
        if (d + rMax > v.camera.farClip) continue;
        const EllipsoidProjection p = projectEllipsoid(e, v);
        const ScreenRect s = exactSilhouette(e, v);
        if (s.x0 < -1 || s.x1 > 1 || s.y0 < -1 || s.y1 > 1) continue;  // keep unclipped cases only
        ASSERT_TRUE(p.visible && !p.crossesNear && !p.eyeInside) << describe(k, e, v, p);
        ++checked;
        const double area = (p.rect.x1 - p.rect.x0) * (p.rect.y1 - p.rect.y0);
        EXPECT_GE(area / ((s.x1 - s.x0) * (s.y1 - s.y0)), 1 - 1e-9) << describe(k, e, v, p);
        const double excess = std::max({s.x0 - p.rect.x0, s.y0 - p.rect.y0, p.rect.x1 - s.x1, p.rect.y1 - s.y1});
        // Measured 2.7e-13 NDC (the rounding margin the formula adds); broken (the rect 2% of its
        // width wider on each side, tests/sabotage/11-rect-wider.sabotage) 1.1e-4 to 2.2e-2 NDC.
        // 1e-4 NDC is a twentieth of a pixel at 1000 px: any widening that costs fill shows.
        EXPECT_LT(excess, 1e-4) << describe(k, e, v, p);
        worstExcess = std::max(worstExcess, excess);
        // Against the bounds of sampled surface points (independent of the tangent-plane formula).
        ScreenRect b{1e300, 1e300, -1e300, -1e300};
        const Body body(e);
        for (int i = 0; i < 4000; ++i) {
            const Vec3 ndc = screenNdc(v, body.at(rng.unit()));
            b = {std::min(b.x0, ndc.x), std::min(b.y0, ndc.y), std::max(b.x1, ndc.x), std::max(b.y1, ndc.y)};
        }
        const double ratio = area / ((b.x1 - b.x0) * (b.y1 - b.y0));
        // Measured 1.0042 at worst (the 4000 sampled points fall a little inside the exact
        // bounds); broken (2% wider on each side in x) 1.04. The old bound, 2.0,
        // passed a rect 41% too wide per side.
        EXPECT_LE(ratio, 1.02) << describe(k, e, v, p);
        worst = std::max(worst, ratio);
    }
    EXPECT_GT(checked, 500);
    RecordProperty("worst_area_ratio", std::to_string(worst));
    std::printf(
        "worst rect / sampled silhouette-bounds area ratio: %.4f, worst rect beyond the exact silhouette %.3g NDC (%d "
        "cases)\n",
        worst, worstExcess, checked);
}

TEST(ProjectionTest, TileProjectionMapsRectToUnitSquare) {
    Rng rng(5);
    int checked = 0;
    for (int k = 0; k < 1000; ++k) {
        const View v = randomView(rng);
        Ellipsoid e = randomEllipsoid(rng);
        placeEllipsoid(e, v, rng, k % 3);
        const EllipsoidProjection p = projectEllipsoid(e, v);
        if (!p.visible) continue;
        ++checked;
        const ScreenRect& r = p.rect;
        const double n = v.camera.nearClip, f = v.camera.farClip;
        // Rect corners on the near and on the far plane go to the tile's (+-1, +-1); depth is the screen's.
        for (const double d : {n, f})
            for (const int cx : {0, 1})
                for (const int cy : {0, 1}) {
                    const double xn = cx ? r.x1 : r.x0, yn = cy ? r.y1 : r.y0;
                    const glm::dvec4 pe(xn * d * v.tanHalfX, yn * d * v.tanHalfY, -d, 1.0);
                    const glm::dvec4 tile = p.projection * pe, screen = v.projectionMatrix * pe;
                    EXPECT_NEAR(tile.x / tile.w, cx ? 1 : -1, 1e-9);
                    EXPECT_NEAR(tile.y / tile.w, cy ? 1 : -1, 1e-9);
                    EXPECT_NEAR(tile.z / tile.w, screen.z / screen.w, 1e-9);
                    EXPECT_NEAR(screen.x / screen.w, xn, 1e-9);
                    EXPECT_NEAR(screen.y / screen.w, yn, 1e-9);
                }
        // Any world point in front of the eye: tile NDC = screen NDC mapped affinely from rect to [-1,1]^2.
        for (int i = 0; i < 200; ++i) {
            const Vec3 w = ellipsoidPoint(e, rng.unit() * std::cbrt(rng.uni(0, 1)));
            double sw = 0;
            const Vec3 s = screenNdc(v, w, &sw);
            if (sw <= 1e-6 * n) continue;
            const glm::dvec4 tc = p.projection * v.viewMatrix * glm::dvec4(w, 1.0);
            const Vec3 t = Vec3(tc) / tc.w;
            const double ex = (2 * s.x - (r.x0 + r.x1)) / (r.x1 - r.x0), ey = (2 * s.y - (r.y0 + r.y1)) / (r.y1 - r.y0);
            EXPECT_NEAR(tc.w, sw, 1e-12 * (1 + std::abs(sw)));
            EXPECT_NEAR(t.x, ex, 1e-9 * (1 + std::abs(ex)));
            EXPECT_NEAR(t.y, ey, 1e-9 * (1 + std::abs(ey)));
            EXPECT_NEAR(t.z, s.z, 1e-9 * (1 + std::abs(s.z)));
        }
    }
    EXPECT_GT(checked, 300);
}

TEST(ProjectionTest, CullsWhatCannotBeSeen) {
    const View v = simpleView(60, 640, 480, 5.0, 3000);
    Ellipsoid e;
    e.radii = Vec3(100, 60, 40);
    e.rotationDeg = Vec3(10, 20, 30);
    auto at = [&](double fwd, double rightOff, double upOff) {
        e.center = v.eye + fwd * v.forward + rightOff * v.right + upOff * v.up;
        return projectEllipsoid(e, v);
    };
    EXPECT_FALSE(at(-500, 0, 0).visible);  // behind the eye
    EXPECT_FALSE(at(-500, 0, 0).crossesNear);
    EXPECT_FALSE(at(1000, 5000, 0).visible);   // far right of the view
    EXPECT_FALSE(at(1000, 0, -4000).visible);  // far below the view
    EXPECT_FALSE(at(3500, 0, 0).visible);      // beyond the far plane
    EXPECT_TRUE(at(2950, 0, 0).visible);       // straddles the far plane
    EXPECT_TRUE(at(1000, 0, 0).visible);
    EXPECT_FALSE(at(1000, 0, 0).crossesNear);
    // Between the eye and the near plane, eye outside: nothing reaches the frustum.
    e.radii = Vec3(1, 1.5, 0.5);
    e.rotationDeg = Vec3(0.0);
    const EllipsoidProjection p = at(2.5, 0, 0);
    EXPECT_FALSE(p.visible);
    EXPECT_FALSE(p.eyeInside);
    EXPECT_FALSE(p.crossesNear);
}

// prepareClouds culls a cloud wholly outside the view as a whole (its bounding sphere): it must
// keep exactly the ellipsoids that projectEllipsoid keeps, one by one. Clouds of 1-40 random
// ellipsoids round random eyes (some inside a cloud, some clouds across the near or far plane or
// a side of the view, off-axis channel frusta): the same ellipsoids, the same culled count. The
// sphere test with the left plane's sign flipped, or the near plane's test, fails here.
TEST(ProjectionTest, CloudsCulledWholeKeepWhatEllipsoidsKeep) {
    Rng rng(7);
    int culledWhole = 0, kept = 0;
    for (int trial = 0; trial < 300; ++trial) {
        View v = randomView(rng);
        if (trial % 3 == 0) {
            const double l = rng.uni(-1.5, 0.5), b = rng.uni(-1.2, 0.4);
            v = makeView(v.camera, Frustum{l, l + rng.uni(0.2, 1.5), b, b + rng.uni(0.2, 1.2)}, rng.uni(-60, 60),
                         rng.uni(-20, 20));
        }
        Scene scene;
        scene.medium.extinction = 0.05;
        const int clouds = 1 + trial % 6;
        for (int c = 0; c < clouds; ++c) {
            Cloud cloud;
            const double spread = rng.logUni(5, 800);
            // Round the eye, at up to a few kilometres, or (a third of the clouds) about it.
            const Vec3 centre = c % 3 == 0 ? v.eye + rng.unit() * rng.uni(0, spread)
                                           : v.eye + rng.unit() * rng.logUni(10, v.camera.farClip * 1.5);
            const int n = 1 + int(rng.uni(0, 40));
            for (int k = 0; k < n; ++k) {
                Ellipsoid e = randomEllipsoid(rng);
                e.radii *= spread / 500;
                e.center = centre + rng.unit() * rng.uni(0, spread);
                cloud.ellipsoids.push_back(e);
            }
            scene.clouds.push_back(cloud);
        }
        std::set<std::pair<int, int>> expected;
        int expectedCulled = 0;
        for (int c = 0; c < int(scene.clouds.size()); ++c)
            for (int i = 0; i < int(scene.clouds[c].ellipsoids.size()); ++i) {
                if (projectEllipsoid(scene.clouds[c].ellipsoids[i], v).visible) expected.insert({c, i});
                else ++expectedCulled;
            }
        const PreparedClouds prepared = prepareClouds(scene, v, NoiseSettings{});
        std::set<std::pair<int, int>> got;
        for (const PreparedEllipsoid& p : prepared.ellipsoids) got.insert({p.cloud, p.index});
        ASSERT_EQ(got, expected) << "trial " << trial;
        EXPECT_EQ(prepared.culled, expectedCulled) << "trial " << trial;
        kept += int(expected.size());
        for (int c = 0; c < int(scene.clouds.size()); ++c) {
            bool any = false;
            for (const auto& [cc, i] : expected) any |= cc == c;
            culledWhole += any ? 0 : 1;
        }
    }
    // Both kinds occur: clouds wholly out of view, and ellipsoids kept.
    EXPECT_GT(culledWhole, 100);
    EXPECT_GT(kept, 1000);
}

TEST(ProjectionTest, EyeInsideGivesFullView) {
    Rng rng(6);
    for (int k = 0; k < 200; ++k) {
        const View v = randomView(rng);
        Ellipsoid e = randomEllipsoid(rng);
        e.radii = glm::max(e.radii, Vec3(2 * v.camera.nearClip));  // reaches past the near plane
        placeEllipsoid(e, v, rng, 1);
        const Vec3 s = ellipsoidToUnit(e) * (v.eye - e.center);
        if (glm::length(s) > 0.5) continue;  // keep the eye well inside so it surely reaches the near plane
        const EllipsoidProjection p = projectEllipsoid(e, v);
        ASSERT_TRUE(p.eyeInside && p.crossesNear && p.visible) << describe(k, e, v, p);
        EXPECT_EQ(p.rect.x0, -1);
        EXPECT_EQ(p.rect.y0, -1);
        EXPECT_EQ(p.rect.x1, 1);
        EXPECT_EQ(p.rect.y1, 1);
        EXPECT_DOUBLE_EQ(p.pixelWidth, v.camera.width);
        EXPECT_DOUBLE_EQ(p.pixelHeight, v.camera.height);
        // The full-view tile projection is the camera's.
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j)
                EXPECT_NEAR(p.projection[i][j], v.projectionMatrix[i][j],
                            1e-12 * (1 + std::abs(v.projectionMatrix[i][j])));
    }
    // Just inside vs just outside the surface.
    const View v = simpleView();
    Ellipsoid e;
    e.radii = Vec3(50, 30, 20);
    e.rotationDeg = Vec3(0, 0, 90);  // local x along world y
    e.center = v.eye - Vec3(0, 49.9, 0);
    EXPECT_TRUE(projectEllipsoid(e, v).eyeInside);
    e.center = v.eye - Vec3(0, 50.1, 0);
    EXPECT_FALSE(projectEllipsoid(e, v).eyeInside);
}

TEST(ProjectionTest, CrossingTheNearPlaneWithTheEyeOutside) {
    const View v = simpleView(60, 640, 480, 1.0, 10000);
    Ellipsoid e;
    e.radii = Vec3(5.0);
    e.center = v.eye + 5.5 * v.forward;  // 0.5 m in front of the eye: crosses z = -1
    const EllipsoidProjection p = projectEllipsoid(e, v);
    EXPECT_FALSE(p.eyeInside);
    EXPECT_TRUE(p.crossesNear);
    EXPECT_TRUE(p.visible);
    // Clipped at the near plane, the box's cross-section there is 10 m wide at 1 m: covers the whole view.
    EXPECT_EQ(p.rect.x0, -1);
    EXPECT_EQ(p.rect.x1, 1);

    // Beside the eye, reaching from behind it to in front: the near plane cuts it 20 m to the
    // right, outside the view (0.77 m half-width at 1 m). Not cut where the view sees, and its
    // rectangle is the view's right part from its nearest tangent plane through the eye, not
    // the whole view (the box's corners at the near plane gave that before 2026-12-03).
    Camera cam;  // looking along +y: x right, z up
    cam.position = Vec3(0, 0, 300);
    cam.direction = Vec3(0, 1, 0);
    cam.fovYDeg = 60, cam.width = 640, cam.height = 480, cam.nearClip = 1.0, cam.farClip = 10000;
    const View w = makeView(cam);
    Ellipsoid side;
    side.radii = Vec3(15.0, 80.0, 15.0);  // long along the view
    side.rotationDeg = Vec3(0.0);
    side.center = cam.position + Vec3(35, 0, 0);  // 20..50 m to the right, 80 m ahead and behind
    const EllipsoidProjection q = projectEllipsoid(side, w);
    ASSERT_TRUE(q.visible && !q.eyeInside);
    EXPECT_LE(q.boxMin.z, -1.0);
    EXPECT_GE(q.boxMax.z, -1.0);
    EXPECT_FALSE(q.crossesNear);
    // Its nearest tangent plane through the eye, x = t y: 35^2 = 15^2 + 80^2 t^2, t = 0.395;
    // the view's tan(half x fov) is 0.770 (60 degrees vertical at 4:3): NDC 0.513.
    EXPECT_NEAR(q.rect.x0, std::sqrt(1000.0 / 6400) / (std::tan(glm::radians(30.0)) * 4 / 3), 1e-6);
    EXPECT_EQ(q.rect.x1, 1);
    // Moved in until its cut by the near plane reaches the view (x from 0.3 m at y = 1): cut.
    side.center = cam.position + Vec3(15.3, 0, 0);
    EXPECT_TRUE(projectEllipsoid(side, w).crossesNear);
}

TEST(ProjectionTest, PixelSizeAndScreenOrientation) {
    Rng rng(7);
    for (int k = 0; k < 300; ++k) {
        const View v = randomView(rng);
        Ellipsoid e = randomEllipsoid(rng);
        placeEllipsoid(e, v, rng, 0);
        const EllipsoidProjection p = projectEllipsoid(e, v);
        if (!p.visible) continue;
        EXPECT_NEAR(p.pixelWidth, (p.rect.x1 - p.rect.x0) / 2 * v.camera.width, 1e-9 * v.camera.width);
        EXPECT_NEAR(p.pixelHeight, (p.rect.y1 - p.rect.y0) / 2 * v.camera.height, 1e-9 * v.camera.height);
        EXPECT_GT(p.pixelWidth, 0);
        EXPECT_LE(p.pixelWidth, v.camera.width + 1e-9);
        EXPECT_LE(p.pixelHeight, v.camera.height + 1e-9);
    }
    // A small sphere seen through the top-left pixel region lands at NDC x < 0, y > 0.
    const View v = simpleView(60, 800, 400);
    Ellipsoid e;
    e.radii = Vec3(2.0);
    e.center = v.eye + 1000.0 * v.rayDirection(100, 50);
    const EllipsoidProjection p = projectEllipsoid(e, v);
    ASSERT_TRUE(p.visible);
    const double cx = 2 * 100.0 / 800 - 1, cy = 1 - 2 * 50.0 / 400;
    EXPECT_TRUE(rectContains(p.rect, cx, cy, 0));
    EXPECT_LT(p.rect.x1, 0);
    EXPECT_GT(p.rect.y0, 0);
    const ScreenRect s = exactSilhouette(e, v);
    EXPECT_NEAR(p.pixelWidth, (s.x1 - s.x0) / 2 * 800, 1e-6);
    EXPECT_NEAR(p.pixelHeight, (s.y1 - s.y0) / 2 * 400, 1e-6);
    EXPECT_GT(p.pixelWidth, 800 * 2.0 / (1000 * v.tanHalfX));  // wider than on the axis: seen obliquely
}

TEST(ProjectionTest, EllipsoidToUnit) {
    Rng rng(8);
    for (int k = 0; k < 500; ++k) {
        Ellipsoid e = randomEllipsoid(rng);
        e.center = Vec3(rng.uni(-1e4, 1e4), rng.uni(-1e4, 1e4), rng.uni(0, 1e4));
        const glm::dmat3 m = ellipsoidToUnit(e);
        const Vec3 s = rng.unit();
        EXPECT_NEAR(glm::length(m * (ellipsoidPoint(e, s) - e.center)), 1.0, 1e-9);
        const Vec3 in = rng.unit() * rng.uni(0, 0.99);
        EXPECT_NEAR(glm::length(m * (ellipsoidPoint(e, in) - e.center)), glm::length(in), 1e-9);
        // The local axes map to the unit axes: a world offset of radius r along R's column i is e_i.
        const glm::dmat3 r = rotationFromDegrees(e.rotationDeg);
        for (int i = 0; i < 3; ++i) {
            const Vec3 u = m * (r[i] * e.radii[i]);
            EXPECT_NEAR(u[i], 1.0, 1e-12);
            EXPECT_NEAR(glm::length(u), 1.0, 1e-12);
        }
    }
}

}  // namespace
