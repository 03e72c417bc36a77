// Frame preparation shared by the GPU compositor and the exact CPU model, and the exact
// CPU model itself.
#include "nephele/gardner.hpp"
#include "nephele/detail.hpp"

#include "nephele/gardner_model.hpp"
#include "prepared_clouds.hpp"
#include "nephele/opaque.hpp"
#include "light_cache.hpp"
#include "parallel.hpp"

#include <glm/gtc/matrix_access.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace nephele {

glm::vec2 chordLight(const CloudRadiance& grid, const Scene& scene, const Vec3& eye, const Vec3& d,
                     const glm::vec3& oUnit, const glm::vec3& dUnit, float tStart, float sigma) {
    glm::vec2 sum(0.0f);
    for (int k = 0; k < model::kChordSamples; ++k) {
        const float t = model::chordSampleDepth(oUnit, dUnit, tStart, sigma, model::chordShare(k));
        const RadianceSample r = sampleRadiance(grid, eye + double(t) * d);
        sum += model::chordWeight(k) *
               glm::vec2(model::lightScalars(r.sunFew, r.sunMany, r.skyTau, r.skyFlux, glm::vec3(d),
                                             glm::vec3(scene.sun.direction), float(scene.medium.hgG)));
    }
    return sum;
}

glm::vec3 ellipsoidSkyChroma(const CloudRadiance& grid, const Ellipsoid& e) {
    return model::skyChroma(glm::vec3(sampleRadiance(grid, e.center).skyTau));
}

namespace {

// Whether the sphere (centre, radius r) lies wholly outside the view's frustum, where
// projectEllipsoid culls every ellipsoid within it: beyond a side plane (each passes through the
// eye, so the eye is outside the sphere), in front of the near plane or beyond the far one.
// Conservative by a margin far above projectEllipsoid's own (1e-9 of the bounds).
bool sphereOutside(const View& view, const Vec3& centre, double r) {
    const Vec3 c(view.viewMatrix * glm::dvec4(centre, 1.0));
    const double d = -c.z, margin = 1e-6 * (r + glm::length(c));
    const Frustum& f = view.frustum;
    if (c.z - r > -view.camera.nearClip + margin || c.z + r < -view.camera.farClip - margin) return true;
    const double beyond = r + margin;
    return (f.left * d - c.x) / std::sqrt(1 + f.left * f.left) > beyond ||
           (c.x - f.right * d) / std::sqrt(1 + f.right * f.right) > beyond ||
           (f.bottom * d - c.y) / std::sqrt(1 + f.bottom * f.bottom) > beyond ||
           (c.y - f.top * d) / std::sqrt(1 + f.top * f.top) > beyond;
}

}  // namespace

CloudSphere cloudBoundingSphere(const Cloud& cloud) {
    CloudSphere out;
    if (cloud.ellipsoids.empty()) return out;
    Vec3 lo(1e300), hi(-1e300);
    for (const Ellipsoid& e : cloud.ellipsoids)
        lo = glm::min(lo, e.center - e.maxRadius()), hi = glm::max(hi, e.center + e.maxRadius());
    out.centre = 0.5 * (lo + hi);
    for (const Ellipsoid& e : cloud.ellipsoids)
        out.radius = std::max(out.radius, glm::length(e.center - out.centre) + e.maxRadius());
    return out;
}

PreparedClouds prepareClouds(const Scene& scene, const View& view, const NoiseSettings& noise) {
    PreparedClouds out;
    out.noisePeriod = scene.medium.noiseScale * noise.cells;
    out.spheres.reserve(scene.clouds.size());
    for (int c = 0; c < int(scene.clouds.size()); ++c) {
        const Cloud& cloud = scene.clouds[c];
        // A cloud wholly outside the view is culled as a whole: projecting every ellipsoid of a
        // field of clouds, most of them behind or beside the eye, would be most of a frame's
        // planning.
        const CloudSphere& sphere = out.spheres.emplace_back(cloudBoundingSphere(cloud));
        if (!cloud.ellipsoids.empty()) {
            if (sphereOutside(view, sphere.centre, sphere.radius)) {
                out.culled += int(cloud.ellipsoids.size());
                continue;
            }
        }
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
                const double rMax = e.maxRadius();
                p.ac = model::opacityOf(float(p.sigma * model::kChordScale * rMax));
            } else {
                const Vec3 dc = glm::normalize(e.center - view.eye);
                p.ac = model::opacityOf(float(p.sigma * model::kChordScale / glm::length(p.unit * dc)));
            }
            p.noiseOffset = ellipsoidNoiseOffset(cloud.noiseId ? std::size_t(cloud.noiseId) : std::size_t(c),
                                                 std::size_t(i), noise.seed);
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
        const double rMax = p.shape.maxRadius();
        nearest = std::min(nearest, p.projection.distance - rMax);
    }
    return std::max({nearest, view.camera.nearClip, double(model::kWeightNearDepth)});
}

glm::vec2 momentDepthRange(const PreparedClouds& prepared, const View& view) {
    const double tNear = weightReferenceDepth(prepared, view);
    double farthest = 0;
    for (const PreparedEllipsoid& p : prepared.ellipsoids)
        farthest = std::max(farthest, p.projection.distance + p.shape.maxRadius());
    return {float(tNear), float(std::max(farthest, 2 * tNear))};
}

namespace {

// The distance along a camera ray to the near plane and to the first opaque surface or the far plane.
struct RayRange {
    double tNear, tEnd;
};

RayRange rayRange(const Scene& scene, const View& view, const Vec3& d) {
    const double c = glm::dot(d, view.forward);
    RayRange r{view.camera.nearClip / c, view.camera.farClip / c};
    if (auto hit = intersectObjects(scene, view.eye, d, r.tNear, r.tEnd)) r.tEnd = hit->distance;
    return r;
}

}  // namespace

const std::vector<CloudRadiance>& ExactLight::grids(const Scene& scene, const RadianceGridSettings& settings) {
    keys_.resize(scene.clouds.size());
    grids_.resize(scene.clouds.size());
    for (std::size_t i = 0; i < scene.clouds.size(); ++i) {
        const Cloud& cloud = scene.clouds[i];
        const Key key{radianceGridKey(scene, cloud, settings),
                      cloud.ellipsoids.empty() ? Vec3(0.0) : cloud.ellipsoids.front().center};
        if (grids_[i].size > 0 && keys_[i] == key) continue;
        grids_[i] = computeCloudRadiance(scene, cloud, settings);
        keys_[i] = key;
    }
    return grids_;
}

namespace {

// One ellipsoid's contribution to a pixel: its opacity and colour, and the depth it is sorted
// (PerPixel) or weighed (Weighted, Moments) by.
struct PixelLayer {
    float depth, alpha;
    glm::vec3 color;
};

// What every pixel of renderGardnerExact reads.
struct ExactFrame {
    const Scene& scene;
    const View& view;
    const NoiseVolume& noiseVolume;
    CompositeOrder order;
    float weightExponent;
    const PreparedClouds& prepared;
    const std::vector<CloudRadiance>& grids;
    std::vector<glm::vec3> chroma;  // per prepared ellipsoid
    model::DetailParams detail;
    float amp;
    glm::vec3 sunIrradiance;
    float weightReference;
    glm::vec2 momentRange;
};

// Prepared ellipsoid pi along the ray of direction d: false when it covers nothing there.
bool chordLayer(const ExactFrame& f, std::size_t pi, const Vec3& d, const RayRange& range, PixelLayer& out) {
    const View& view = f.view;
    const model::DetailParams& detail = f.detail;
    const PreparedEllipsoid& p = f.prepared.ellipsoids[pi];
    const glm::vec3 o(p.unit * (view.eye - p.shape.center)), du(p.unit * d);
    // Cut by the near plane: only the matter beyond it is seen (as on the GPU).
    const float tStart = p.projection.crossesNear ? float(range.tNear) : 0.0f;
    float depth = model::segmentDepth(o, du, tStart, 1e30f);
    if (depth <= 0) return false;
    const float len = glm::length(du);
    const glm::vec3 dn = du / len;
    const float tc = -glm::dot(o, dn);
    const float h = std::sqrt(std::max(0.0f, 1.0f - glm::dot(o + tc * dn, o + tc * dn)));
    const float tOut = (tc + h) / len;
    const float tShade = model::shadeDepth(o, du, tStart);
    const Vec3 shadePoint = view.eye + double(tShade) * d;
    const Vec3 uvw = shadePoint / f.prepared.noisePeriod + p.noiseOffset;
    const float n = f.noiseVolume.sample(glm::vec3(uvw));
    const float tIn = std::max((tc - h) / len, tStart);
    // The detail: the chord's depth of the eroded profile, followed piece by piece.
    const auto eroded = [&](float tMax) {
        const int pieces = exactPieces(detail, std::min(tMax, tOut) - tIn, tIn);
        return model::erodedSegmentDepth(detailVolume(), detail, o, du, glm::vec3(d), tStart, tMax, pieces);
    };
    if (detail.erosion > 0 && (depth = eroded(1e30f)) <= 0) return false;
    const float a = model::opacityOf(float(p.sigma) * depth);
    const glm::vec2 terms = model::gardnerTerms(float(p.ac), a, f.amp, n);
    float alpha = std::clamp(model::gardnerAlpha(terms.x, terms.y), 0.0f, 1.0f);
    // An opaque object inside the cloud: only the matter in front of it covers it.
    if (range.tEnd < tOut) {
        const float front =
            detail.erosion > 0 ? eroded(float(range.tEnd)) : model::segmentDepth(o, du, tStart, float(range.tEnd));
        alpha = model::opacityInFront(alpha, front, depth);
    }
    if (alpha <= 0) return false;
    // The light of the chord (per pixel here; the compositor's meshes evaluate it per vertex).
    const CloudRadiance& grid = f.grids[p.cloud];
    // With the detail, the light follows the eroded chord (erodedGrowth, detail.glsl), as the tiles'.
    const float grow =
        detail.erosion > 0 ? model::erodedGrowth(detailVolume(), detail, o, du, glm::vec3(d), tStart) : 1.0f;
    const glm::vec2 light = chordLight(grid, f.scene, view.eye, d, o * grow, du * grow, tStart, float(p.sigma));
    out.color =
        model::sourceFromScalars(glm::vec3(light, 0.0f), f.sunIrradiance, f.chroma[pi], float(f.scene.medium.albedo));
    out.alpha = alpha;
    out.depth = 0;
    if (f.order == CompositeOrder::PerPixel) {
        out.depth = tShade;
    } else if (f.order == CompositeOrder::Weighted || f.order == CompositeOrder::Moments) {  // weighed later
        const float matter = model::matterDepth(o, du, tStart);
        out.depth =
            f.order == CompositeOrder::Moments ? model::momentDepth(matter, f.momentRange.x, f.momentRange.y) : matter;
    }
    return true;
}

// A pixel's layers over (color, alphaSum): PerPixel sorted and composited back to front;
// Weighted or Moments weighed as the GPU's composite. (PerEllipsoid composites on the way and
// keeps no layers.)
void compositeLayers(const ExactFrame& f, std::vector<PixelLayer>& layers, Vec3& color, double& alphaSum) {
    const CompositeOrder order = f.order;
    Vec3 weightedColor(0.0);  // Weighted, Moments: sum of w alpha c, sum of w alpha, prod of (1 - alpha)
    double weightSum = 0, transmittance = 1;
    if (order == CompositeOrder::PerPixel) {
        std::sort(layers.begin(), layers.end(),
                  [](const PixelLayer& a, const PixelLayer& b) { return a.depth > b.depth; });
        for (const PixelLayer& l : layers) {
            color = Vec3(l.color) * double(l.alpha) + color * (1.0 - l.alpha);
            alphaSum = l.alpha + alphaSum * (1.0 - l.alpha);
        }
    } else if (!layers.empty()) {
        // Weighted or Moments, as the GPU's composite: w alpha in float, the sums in wide
        // floats. Moments: the moments summed in float first (the GPU's first pass), then
        // each contribution weighed by the transmittance in front of it.
        float b[5] = {0, 0, 0, 0, 0};
        if (order == CompositeOrder::Moments)
            for (const PixelLayer& l : layers) {
                const float a = model::absorbanceOf(l.alpha);
                b[0] += a, b[1] += a * l.depth, b[2] += a * l.depth * l.depth;
                b[3] += a * l.depth * l.depth * l.depth, b[4] += a * l.depth * l.depth * l.depth * l.depth;
            }
        for (const PixelLayer& l : layers) {
            const float w =
                order == CompositeOrder::Moments
                    ? model::momentWeight(b[0], b[1] / b[0], b[2] / b[0], b[3] / b[0], b[4] / b[0], l.depth, l.alpha)
                    : model::compositeWeight(l.depth, f.weightReference, f.weightExponent);
            const float wa = w * l.alpha;
            weightedColor += Vec3(l.color) * double(wa);
            weightSum += wa;
            transmittance *= 1.0 - l.alpha;
        }
    }
    if (weightSum > 0) {
        const double a = 1.0 - transmittance;
        color = weightedColor / weightSum * a + color * transmittance;
        alphaSum = a;
    }
}

// Pixel (x, y): the opaque scene's radiance, then the ellipsoids over it in `f.order`.
void exactPixel(const ExactFrame& f, int x, int y, std::vector<PixelLayer>& layers, Image& image) {
    const View& view = f.view;
    const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
    const RayRange range = rayRange(f.scene, view, d);
    Vec3 color = opaqueRadiance(f.scene, view, d);
    double alphaSum = 0;
    layers.clear();
    for (std::size_t pi = 0; pi < f.prepared.ellipsoids.size(); ++pi) {
        PixelLayer l{};
        if (!chordLayer(f, pi, d, range, l)) continue;
        if (f.order == CompositeOrder::PerPixel || f.order == CompositeOrder::Weighted ||
            f.order == CompositeOrder::Moments) {
            layers.push_back(l);  // composited after
            continue;
        }
        color = Vec3(l.color) * double(l.alpha) + color * (1.0 - l.alpha);
        alphaSum = l.alpha + alphaSum * (1.0 - l.alpha);
    }
    compositeLayers(f, layers, color, alphaSum);
    for (int k = 0; k < 3; ++k) image.at(x, y, k) = float(color[k]);
    image.at(x, y, 3) = float(alphaSum);
}

}  // namespace

Image renderGardnerExact(const Scene& scene, const View& view, const NoiseVolume& noiseVolume,
                         const NoiseSettings& noiseSettings, CompositeOrder order, float weightExponent,
                         const RadianceGridSettings& lightSettings, ExactLight* kept) {
    const PreparedClouds prepared = prepareClouds(scene, view, noiseSettings);
    ExactLight once;
    ExactFrame f{scene,
                 view,
                 noiseVolume,
                 order,
                 weightExponent,
                 prepared,
                 (kept ? *kept : once).grids(scene, lightSettings),
                 {},
                 {},
                 float(scene.medium.noise),
                 glm::vec3(scene.sun.color * scene.sun.intensity),
                 0,
                 {}};
    for (const PreparedEllipsoid& p : prepared.ellipsoids)
        f.chroma.push_back(ellipsoidSkyChroma(f.grids[p.cloud], p.shape));
    f.detail = scene.medium.detail.on() ? detailParams(scene.medium.detail, view.eye) : model::DetailParams{};
    f.weightReference = float(weightReferenceDepth(prepared, view));
    f.momentRange = momentDepthRange(prepared, view);
    Image image(view.camera.width, view.camera.height, 4);
    parallelFor(image.height, [&](int y) {
        std::vector<PixelLayer> layers;  // PerPixel, Weighted, Moments: this pixel's contributions, composited after
        for (int x = 0; x < image.width; ++x) exactPixel(f, x, y, layers, image);
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
