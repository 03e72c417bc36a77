// CPU twin of shaders/sky.frag and shaders/object.frag, per ray: their formulas compiled here
// from the same source, shaders/opaque.glsl (in double), and the ray casts the rasteriser does.
#include "nephele/opaque.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace nephele {

namespace {
namespace glsl {
using vec3 = glm::dvec3;
using glm::dot;
using glm::max;
#define MODEL_FN inline
#include "nephele/opaque.glsl"  // the build's copy of shaders/opaque.glsl (core/CMakeLists.txt)
#undef MODEL_FN
}  // namespace glsl
}  // namespace

Vec3 skyRadiance(const Sky& sky, const Vec3& d) { return glsl::skyRadiance(sky.zenith, sky.horizon, sky.ground, d); }

Vec3 lambertRadiance(const Sun& sun, const Vec3& albedo, const Vec3& normal) {
    return glsl::lambertRadiance(albedo, sun.color * (sun.intensity / std::numbers::pi), normal, sun.direction);
}

namespace {

// Ray against a sphere: the nearest t in (tMin, tMax).
std::optional<double> hitSphere(const Vec3& c, double r, const Vec3& o, const Vec3& d, double tMin, double tMax) {
    const Vec3 oc = c - o;
    const double b = glm::dot(oc, d);
    const double h = b * b - glm::dot(oc, oc) + r * r;
    if (h < 0) return std::nullopt;
    const double s = std::sqrt(h);
    for (double t : {b - s, b + s})
        if (t > tMin && t < tMax) return t;
    return std::nullopt;
}

// Ray against an oriented box (slabs in the box frame): nearest t and the face normal.
std::optional<std::pair<double, Vec3>> hitBox(const Object& box, const Vec3& o, const Vec3& d, double tMin,
                                              double tMax) {
    const glm::dmat3 r = rotationFromDegrees(box.rotationDeg);
    const Vec3 lo = glm::transpose(r) * (o - box.center);
    const Vec3 ld = glm::transpose(r) * d;
    const Vec3 half = box.size * 0.5;
    double tNear = -INFINITY, tFar = INFINITY;
    int nearAxis = 0, farAxis = 0;
    for (int a = 0; a < 3; ++a) {
        if (std::fabs(ld[a]) < 1e-300) {
            if (std::fabs(lo[a]) > half[a]) return std::nullopt;
            continue;
        }
        double t0 = (-half[a] - lo[a]) / ld[a], t1 = (half[a] - lo[a]) / ld[a];
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > tNear) {
            tNear = t0;
            nearAxis = a;
        }
        if (t1 < tFar) {
            tFar = t1;
            farAxis = a;
        }
    }
    if (tNear > tFar) return std::nullopt;
    const double t = tNear > tMin ? tNear : tFar;
    const int axis = tNear > tMin ? nearAxis : farAxis;
    if (!(t > tMin && t < tMax)) return std::nullopt;
    Vec3 n(0.0);
    n[axis] = 1.0;
    n = r * n;
    if (glm::dot(n, d) > 0) n = -n;
    return std::make_pair(t, n);
}

}  // namespace

std::optional<SurfaceHit> intersectObjects(const Scene& scene, const Vec3& o, const Vec3& d, double tMin, double tMax) {
    std::optional<SurfaceHit> best;
    for (const Object& obj : scene.objects) {
        const double limit = best ? best->distance : tMax;
        if (obj.type == Object::Type::Sphere) {
            if (auto t = hitSphere(obj.center, obj.radius, o, d, tMin, limit)) {
                Vec3 n = (o + *t * d - obj.center) / obj.radius;
                if (glm::dot(n, d) > 0) n = -n;
                best = SurfaceHit{*t, n, obj.color};
            }
        } else if (auto hit = hitBox(obj, o, d, tMin, limit)) {
            best = SurfaceHit{hit->first, hit->second, obj.color};
        }
    }
    return best;
}

Vec3 opaqueRadiance(const Scene& scene, const View& view, const Vec3& d) {
    // The GPU clips at the near/far planes, which lie at distance near / cos(angle to forward).
    const double c = glm::dot(d, view.forward);
    if (auto hit = intersectObjects(scene, view.eye, d, view.camera.nearClip / c, view.camera.farClip / c))
        return lambertRadiance(scene.sun, hit->albedo, hit->normal);
    return skyRadiance(scene.sky, d);
}

Image renderOpaqueCpu(const Scene& scene, const View& view) {
    Image image(view.camera.width, view.camera.height, 4);
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const Vec3 rgb = opaqueRadiance(scene, view, view.rayDirection(x + 0.5, y + 0.5));
            for (int k = 0; k < 3; ++k) image.at(x, y, k) = float(rgb[k]);
        }
    return image;
}

}  // namespace nephele
