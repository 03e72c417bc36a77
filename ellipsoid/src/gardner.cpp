// Frame preparation shared by the GPU compositor and the exact CPU model, and the exact
// CPU model itself.
#include "nephele/gardner.hpp"

#include "nephele/gardner_model.hpp"
#include "nephele/opaque.hpp"
#include "nephele/parallel.hpp"

#include "sun_depth.hpp"

#include <glm/gtc/matrix_access.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace nephele {

namespace {

// Optical depth / extinction from `from` towards the sun (to infinity) through a cloud.
double depthToSun(const Cloud& cloud, const Vec3& from, const Vec3& sunDir) {
    double sum = 0;
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const glm::dmat3 m = ellipsoidToUnit(e);
        const glm::vec3 o(m * (from - e.center)), d(m * sunDir);
        sum += e.density * model::segmentDepth(o, d, 0.0f, 1e30f);
    }
    return sum;
}

// What the light volume holds for an optical depth (/ extinction) towards the sun: see cloudSunLight.
double sunLightFromDepth(const Medium& m, double depth) {
    const double reflectance = model::diffuseReflectance(float(m.albedo), float(m.hgG));
    return reflectance / std::max(m.albedo, 1e-6) * std::exp(-reducedExtinction(m) * depth);
}

CloudLight makeLight(const Scene& scene, const Cloud& cloud, int size) {
    CloudLight light;
    light.size = size;
    Vec3 lo(INFINITY), hi(-INFINITY);
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const glm::dmat3 a = rotationFromDegrees(e.rotationDeg) * glm::dmat3(e.radii.x, 0, 0, 0, e.radii.y, 0, 0, 0, e.radii.z);
        const Vec3 half(glm::length(glm::row(a, 0)), glm::length(glm::row(a, 1)), glm::length(glm::row(a, 2)));
        lo = glm::min(lo, e.center - half);
        hi = glm::max(hi, e.center + half);
    }
    if (cloud.ellipsoids.empty()) lo = hi = Vec3(0.0);
    light.boxMin = lo;
    light.boxExtent = glm::max(hi - lo, Vec3(1e-3));
    light.transmittance.assign(std::size_t(size) * size * size, 1.0f);
    const detail::SunDepthIndex index(cloud, scene.sun.direction);  // the same sums, only over what each ray meets
    parallelFor(size, [&](int z) {
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                const Vec3 p = light.boxMin + (Vec3(x, y, z) + 0.5) / double(size) * light.boxExtent;
                light.transmittance[(std::size_t(z) * size + y) * size + x] = float(sunLightFromDepth(scene.medium, index.depth(p)));
            }
    });
    return light;
}

}  // namespace

double reducedExtinction(const Medium& m) { return m.extinction * (1.0 - m.albedo * m.hgG); }

double sunTransmittance(const Scene& scene, const Cloud& cloud, const Vec3& point) {
    return std::exp(-reducedExtinction(scene.medium) * depthToSun(cloud, point, scene.sun.direction));
}

double cloudSunLight(const Scene& scene, const Cloud& cloud, const Vec3& point) {
    return sunLightFromDepth(scene.medium, depthToSun(cloud, point, scene.sun.direction));
}

Vec3 environmentMean(const Sky& sky) {
    // Over the upper hemisphere the format's sky is horizon + (zenith - horizon) d.z, whose
    // mean over solid angle is (zenith + horizon) / 2 (the mean of d.z is 1/2); below, ground.
    return 0.5 * (0.5 * (sky.zenith + sky.horizon)) + 0.5 * sky.ground;
}

Vec3 cloudAmbient(const Sky& sky) { return environmentMean(sky); }

PreparedClouds prepareClouds(const Scene& scene, const View& view, const NoiseSettings& noise) {
    PreparedClouds out;
    out.noisePeriod = scene.medium.noiseScale * noise.cells;
    for (int c = 0; c < int(scene.clouds.size()); ++c) {
        const Cloud& cloud = scene.clouds[c];
        for (int i = 0; i < int(cloud.ellipsoids.size()); ++i) {
            const Ellipsoid& e = cloud.ellipsoids[i];
            PreparedEllipsoid p;
            p.projection = projectEllipsoid(e, view);
            if (!p.projection.visible) {
                ++out.culled;
                continue;
            }
            p.cloud = c;
            p.index = i;
            p.shape = e;
            p.unit = ellipsoidToUnit(e);
            p.axes = glm::inverse(p.unit);
            p.sigma = scene.medium.extinction * e.density * std::clamp(cloud.weight, 0.0, 1.0);
            if (!(p.sigma > 0)) continue;  // no matter the eye can see (Ac would be 0)
            if (p.projection.crossesNear) {
                // Any ray's chord is at most the longest diameter: 16/15 * r_max bounds its depth.
                const double rMax = std::max({e.radii.x, e.radii.y, e.radii.z});
                p.ac = model::opacityOf(float(p.sigma * model::kChordScale * rMax));
            } else {
                const Vec3 dc = glm::normalize(e.center - view.eye);
                p.ac = model::opacityOf(float(p.sigma * model::kChordScale / glm::length(p.unit * dc)));
            }
            p.noiseOffset = ellipsoidNoiseOffset(cloud.noiseId ? std::size_t(cloud.noiseId) : std::size_t(c), std::size_t(i), noise.seed);
            out.ellipsoids.push_back(p);
        }
    }
    // Back to front; ties keep scene order, so the order is deterministic.
    std::stable_sort(out.ellipsoids.begin(), out.ellipsoids.end(),
                     [](const PreparedEllipsoid& a, const PreparedEllipsoid& b) {
                         return a.projection.distance > b.projection.distance;
                     });
    return out;
}

double weightReferenceDepth(const PreparedClouds& prepared, const View& view) {
    double nearest = INFINITY;
    for (const PreparedEllipsoid& p : prepared.ellipsoids) {
        const double rMax = std::max({p.shape.radii.x, p.shape.radii.y, p.shape.radii.z});
        nearest = std::min(nearest, p.projection.distance - rMax);
    }
    return std::max({nearest, view.camera.nearClip, double(model::kWeightNearDepth)});
}

std::vector<CloudLight> makeCloudLights(const Scene& scene, int size) {
    std::vector<CloudLight> lights;
    for (const Cloud& cloud : scene.clouds) lights.push_back(makeLight(scene, cloud, size));
    return lights;
}

namespace {

// The distance along a camera ray to the near plane and to the first opaque surface or the far plane.
struct RayRange { double tNear, tEnd; };

RayRange rayRange(const Scene& scene, const View& view, const Vec3& d) {
    const double c = glm::dot(d, view.forward);
    RayRange r{view.camera.nearClip / c, view.camera.farClip / c};
    if (auto hit = intersectObjects(scene, view.eye, d, r.tNear, r.tEnd)) r.tEnd = hit->distance;
    return r;
}

}  // namespace

Image renderGardnerExact(const Scene& scene, const View& view, const NoiseVolume& noiseVolume,
                         const NoiseSettings& noiseSettings, CompositeOrder order, float weightExponent) {
    const PreparedClouds prepared = prepareClouds(scene, view, noiseSettings);
    const float amp = float(scene.medium.noise);
    const Vec3 sunRadiance = scene.sun.color * scene.sun.intensity / std::numbers::pi;
    // As the compositor's composite pass sets it (ellipsoid/src/compositor.cpp); see cloudAmbient.
    const Vec3 ambient = cloudAmbient(scene.sky);
    const float weightReference = float(weightReferenceDepth(prepared, view));
    // cloudSunLight of each cloud, indexed once: per hit it sums only what the sun ray meets.
    std::vector<detail::SunDepthIndex> sunDepth;
    sunDepth.reserve(scene.clouds.size());
    for (const Cloud& c : scene.clouds) sunDepth.emplace_back(c, scene.sun.direction);
    Image image(view.camera.width, view.camera.height, 4);
    struct Layer { float depth, alpha; glm::vec3 color; };
    parallelFor(image.height, [&](int y) {
        std::vector<Layer> layers;  // PerPixel: this pixel's contributions, sorted before compositing
        for (int x = 0; x < image.width; ++x) {
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            const RayRange range = rayRange(scene, view, d);
            Vec3 color = opaqueRadiance(scene, view, d);
            double alphaSum = 0;
            layers.clear();
            Vec3 weightedColor(0.0);  // Weighted: sum of w alpha c, sum of w alpha, prod of (1 - alpha)
            double weightSum = 0, transmittance = 1;
            for (const PreparedEllipsoid& p : prepared.ellipsoids) {
                const glm::vec3 o(p.unit * (view.eye - p.shape.center)), du(p.unit * d);
                // Cut by the near plane: only the matter beyond it is seen (as on the GPU).
                const float tStart = p.projection.crossesNear ? float(range.tNear) : 0.0f;
                const float depth = model::segmentDepth(o, du, tStart, 1e30f);
                if (depth <= 0) continue;
                const float len = glm::length(du);
                const glm::vec3 dn = du / len;
                const float tc = -glm::dot(o, dn);
                const float h = std::sqrt(std::max(0.0f, 1.0f - glm::dot(o + tc * dn, o + tc * dn)));
                const float tIn = (tc - h) / len, tOut = (tc + h) / len;
                const float tShade = model::shadeDepth(o, du, tStart);
                const Vec3 shadePoint = view.eye + double(tShade) * d;
                const Vec3 uvw = shadePoint / prepared.noisePeriod + p.noiseOffset;
                const float n = noiseVolume.sample(glm::vec3(uvw));
                const float a = model::opacityOf(float(p.sigma) * depth);
                const float g = model::termG(float(p.ac), amp, a / float(p.ac));
                float alpha = std::clamp(model::gardnerAlpha(model::termIOverD(float(p.ac), amp, n), g), 0.0f, 1.0f);
                // An opaque object inside the cloud: only the matter in front of it covers it.
                if (range.tEnd < tOut) {
                    const float front = model::segmentDepth(o, du, tStart, float(range.tEnd));
                    alpha = model::opacityInFront(alpha, front, depth);
                }
                if (alpha <= 0) continue;
                Vec3 normal = -d;
                if (tIn > tStart) normal = glm::normalize(glm::transpose(p.unit) * Vec3(o + tIn * len * dn));
                const float light = model::sunLight(float(sunLightFromDepth(scene.medium, sunDepth[p.cloud].depth(shadePoint))),
                                                    float(glm::dot(normal, scene.sun.direction)));
                const glm::vec3 c = model::cloudColor(glm::vec3(sunRadiance), light, glm::vec3(ambient),
                                                      float(scene.medium.albedo), model::noiseModulation(amp, n));
                if (order == CompositeOrder::PerPixel) {
                    layers.push_back({tShade, alpha, c});
                    continue;
                }
                if (order == CompositeOrder::Weighted) {
                    // As the GPU's weighted composite: w alpha in float, the sums in wide floats.
                    const float wa =
                        model::compositeWeight(model::matterDepth(o, du, tStart), weightReference, weightExponent) * alpha;
                    weightedColor += Vec3(c) * double(wa);
                    weightSum += wa;
                    transmittance *= 1.0 - alpha;
                    continue;
                }
                color = Vec3(c) * double(alpha) + color * (1.0 - alpha);
                alphaSum = alpha + alphaSum * (1.0 - alpha);
            }
            std::sort(layers.begin(), layers.end(), [](const Layer& a, const Layer& b) { return a.depth > b.depth; });
            for (const Layer& l : layers) {
                color = Vec3(l.color) * double(l.alpha) + color * (1.0 - l.alpha);
                alphaSum = l.alpha + alphaSum * (1.0 - l.alpha);
            }
            if (weightSum > 0) {
                const double a = 1.0 - transmittance;
                color = weightedColor / weightSum * a + color * transmittance;
                alphaSum = a;
            }
            for (int k = 0; k < 3; ++k) image.at(x, y, k) = float(color[k]);
            image.at(x, y, 3) = float(alphaSum);
        }
    });
    return image;
}

Image exactDensityOpacity(const Scene& scene, const View& view) {
    Image image(view.camera.width, view.camera.height, 1);
    parallelFor(image.height, [&](int y) {
        for (int x = 0; x < image.width; ++x) {
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            const RayRange range = rayRange(scene, view, d);
            double tau = 0;
            for (const Cloud& cloud : scene.clouds)
                for (const Ellipsoid& e : cloud.ellipsoids) {
                    const glm::dmat3 m = ellipsoidToUnit(e);
                    tau += scene.medium.extinction * e.density * std::clamp(cloud.weight, 0.0, 1.0) *
                           model::segmentDepth(glm::vec3(m * (view.eye - e.center)), glm::vec3(m * d),
                                               float(range.tNear), float(range.tEnd));
                }
            image.at(x, y, 0) = float(1.0 - std::exp(-tau));
        }
    });
    return image;
}

}  // namespace nephele
