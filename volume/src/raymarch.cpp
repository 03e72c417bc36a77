// The GPU ray-marcher (see nephele/raymarch.hpp for the method).
#include "nephele/raymarch.hpp"

#include "cloud_light_textures.hpp"
#include "detail_texture.hpp"
#include "noise_texture.hpp"
#include "object_light_pass.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/ellipsoid_space.hpp"
#include "reduced_target.hpp"
#include "nephele/shader.hpp"

#include <glm/gtc/matrix_access.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>

namespace nephele {
using namespace gl;

namespace {

// Mirrors `struct RmEllipsoid` of shaders/raymarch_data.glsl (std430).
struct GpuEllipsoid {
    float eyeUnitSigma[4];
    float unit[3][4];
};
static_assert(sizeof(GpuEllipsoid) == 4 * 16);

// Mirrors `struct RmCloud`.
struct GpuCloud {
    float boxMin[4], boxMax[4];
    std::int32_t range[4];
};
static_assert(sizeof(GpuCloud) == 3 * 16);

void put(float* out, const Vec3& v, double w = 0) {
    out[0] = float(v.x), out[1] = float(v.y), out[2] = float(v.z), out[3] = float(w);
}


// raymarch_data.glsl's storage buffers' binding points, said here only (buildMarch gives them to
// the program; the light grids' boxes take CloudLightTextures::kBoxesBinding, 3).
constexpr GLuint kEllipsoidsBinding = 0, kCloudsBinding = 1, kTileFirstBinding = 5, kTileCloudsBinding = 6;
constexpr int kTile = 16;  // pixels; the shader's RM_TILE, given when raymarch.frag is built

// The clouds' boxes binned to screen tiles of kTile x kTile pixels (RM_TILE in
// shaders/raymarch_data.glsl): a pixel tests only the clouds of its tile, not all of them
// (with 6250 clouds at 1280x720 the per-pixel loop over every box was 90% of the frame).
// first[0] = the clouds every pixel tests (boxes that reach behind half the near plane, or
// past the binning's budget), listed first in `clouds`; tile t's are clouds[first[1 + t] ..
// first[2 + t]). A box's rectangle is its corners' projection, one pixel wider on each side,
// so a ray that meets the box always finds it in its tile's list.
struct TileBins {
    std::vector<std::int32_t> first, clouds;
    int tilesX = 0;
};

// The smallest angle between the unit direction s and the view's rays: 0 when s is in view,
// else its angular distance to the frustum's edges (great-circle arcs between its corners).
double angleToView(const View& view, const Vec3& s) {
    const double z = glm::dot(s, view.forward);
    if (z > 0 && std::abs(view.ndcX(glm::dot(s, view.right) / z)) <= 1 &&
        std::abs(view.ndcY(glm::dot(s, view.up) / z)) <= 1)
        return 0;
    const Vec3 c = view.rayCentre(), r = view.rightScaled(), u = view.upScaled();
    const Vec3 k[4] = {glm::normalize(c - r - u), glm::normalize(c + r - u), glm::normalize(c + r + u),
                       glm::normalize(c - r + u)};
    auto angle = [](const Vec3& a, const Vec3& b) { return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)); };
    double best = std::numbers::pi;
    for (int i = 0; i < 4; ++i) {
        const Vec3 &a = k[i], &b = k[(i + 1) % 4];
        best = std::min({best, angle(s, a), angle(s, b)});
        const Vec3 n = glm::normalize(glm::cross(a, b));
        const Vec3 p = s - glm::dot(s, n) * n;  // s projected onto the arc's great circle
        if (glm::length(p) < 1e-12) continue;
        const Vec3 q = glm::normalize(p);
        if (glm::dot(glm::cross(a, q), n) >= 0 && glm::dot(glm::cross(q, b), n) >= 0)
            best = std::min(best, angle(s, q));
    }
    return best;
}

TileBins binClouds(const std::vector<std::pair<Vec3, Vec3>>& boxes, const View& view) {
    const int w = view.camera.width, h = view.camera.height;
    const int tilesX = (w + kTile - 1) / kTile, tilesY = (h + kTile - 1) / kTile;
    struct Rect {
        int x0, y0, x1, y1;  // tiles, inclusive; x0 > x1: off screen
    };
    const Rect everywhere{-1, 0, -1, 0};
    std::vector<Rect> rects(boxes.size());
    std::size_t items = 0;
    const std::size_t budget = std::size_t(1) << 25;  // 128 MB of indices
    for (std::size_t c = 0; c < boxes.size(); ++c) {
        const auto& [lo, hi] = boxes[c];  // camera-relative
        double sx0 = INFINITY, sx1 = -INFINITY, sy0 = INFINITY, sy1 = -INFINITY;
        bool behind = false;
        for (int k = 0; k < 8; ++k) {
            const Vec3 p((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z);
            const double z = glm::dot(p, view.forward);
            if (!(z > 0.5 * view.camera.nearClip)) {
                behind = true;
                break;
            }
            const double sx = view.ndcX(glm::dot(p, view.right) / z), sy = view.ndcY(glm::dot(p, view.up) / z);
            sx0 = std::min(sx0, sx), sx1 = std::max(sx1, sx), sy0 = std::min(sy0, sy), sy1 = std::max(sy1, sy);
        }
        if (behind) {
            rects[c] = everywhere;
            continue;
        }
        auto tile = [&](double s, int pixels, int tiles, int margin) {  // NDC -> tile, clamped
            const double px = std::floor((std::clamp(s, -4.0, 4.0) * 0.5 + 0.5) * pixels) + margin;
            return std::clamp(int(px) / kTile, -1, tiles);
        };
        Rect r{tile(sx0, w, tilesX, -1), tile(sy0, h, tilesY, -1), tile(sx1, w, tilesX, 1), tile(sy1, h, tilesY, 1)};
        r.x0 = std::max(r.x0, 0), r.y0 = std::max(r.y0, 0), r.x1 = std::min(r.x1, tilesX - 1),
        r.y1 = std::min(r.y1, tilesY - 1);
        if (r.x0 > r.x1 || r.y0 > r.y1) {
            rects[c] = {1, 0, 0, 0};  // off screen: no pixel tests it
            continue;
        }
        const std::size_t area = std::size_t(r.x1 - r.x0 + 1) * std::size_t(r.y1 - r.y0 + 1);
        rects[c] = items + area > budget ? everywhere : r;
        if (rects[c].x0 >= 0) items += area;
    }
    TileBins bins;
    bins.tilesX = tilesX;
    bins.first.assign(std::size_t(tilesX) * tilesY + 2, 0);
    for (std::size_t c = 0; c < rects.size(); ++c)
        if (rects[c].x0 < 0) bins.clouds.push_back(std::int32_t(c));
    bins.first[0] = std::int32_t(bins.clouds.size());
    for (const Rect& r : rects)  // counts per tile
        for (int y = r.y0; r.x0 >= 0 && y <= r.y1; ++y)
            for (int x = r.x0; x <= r.x1; ++x) ++bins.first[std::size_t(2 + y * tilesX + x)];
    bins.first[1] = bins.first[0];
    for (std::size_t t = 2; t < bins.first.size(); ++t) bins.first[t] += bins.first[t - 1];
    bins.clouds.resize(std::size_t(bins.first.back()));
    std::vector<std::int32_t> fill(bins.first.begin() + 1, bins.first.end() - 1);
    for (std::size_t c = 0; c < rects.size(); ++c)
        for (int y = rects[c].y0; rects[c].x0 >= 0 && y <= rects[c].y1; ++y)
            for (int x = rects[c].x0; x <= rects[c].x1; ++x)
                bins.clouds[std::size_t(fill[std::size_t(y * tilesX + x)]++)] = std::int32_t(c);
    return bins;
}

}  // namespace

struct RaymarchRenderer::Impl {
    Program march;
    DetailTexture::Variant detailVariant = DetailTexture::Variant::Off;  // the one `march` reads
    void buildMarch();
    VertexArray empty;
    // The fBm volume, made on the first frame with medium.noise > 0: for the light march on
    // the CPU and as a 3D texture for the GPU, the same texels.
    NoiseVolume noiseCpu;
    Texture noise;
    int noiseOctaves = 0;
    CloudRadianceCache lightCache;     // the clouds' radiance grids
    CloudLightTextures lightTextures;  // ... on the GPU
    ObjectLightPass objectLight;       // object_light "all"
    DetailTexture detail;              // medium.detail's texture
    Buffer ellipsoids, clouds, tileFirst, tileClouds;
    std::size_t ellipsoidCapacity = 0, cloudCapacity = 0, tileFirstCapacity = 0, tileCloudCapacity = 0;
    FrameDepth depth;                        // copy of the frame's depth (objects inside clouds)
    std::unique_ptr<ReducedTarget> reduced;  // RaymarchSettings::downsample > 1: what the march draws into

    void ensureNoise(const RaymarchSettings& s);
    // render()'s phases, in its order.
    void updateLight(const RaymarchSettings& s, const Scene& scene, const View& view, GLuint framebuffer,
                     bool litObjects, RaymarchStats& stats);
    std::vector<std::pair<Vec3, Vec3>> uploadClouds(const Scene& scene, const View& view);
    void setFrameUniforms(const View& view, int d, const DepthSource& marchDepth, int tilesX);
    void setMediumUniforms(const RaymarchSettings& s, const Scene& scene, const View& view, double kappa);
    void drawMarch(const View& view, const HostFrame& frame, const DepthSource& depth, const DepthSource& marchDepth,
                   const View& marchView, int d, double kappa);
};

void validate(const RaymarchSettings& s) {
    if (!(s.step > 0) || !std::isfinite(s.step)) throw std::invalid_argument("raymarch step must be > 0 m");
    if (!(s.lodDistance >= 0) || !std::isfinite(s.lodDistance))
        throw std::invalid_argument("raymarch lodDistance must be >= 0 m (0 = fixed step)");
    validate(s.light);
    if (s.octaves < 1 || s.octaves > 8) throw std::invalid_argument("raymarch octaves must be 1..8");
    if (s.maxSteps < 1 || s.maxSteps > 65536) throw std::invalid_argument("raymarch maxSteps must be 1..65536");
    if (s.downsample < 1 || s.downsample > 4) throw std::invalid_argument("raymarch downsample must be 1..4");
}

RaymarchRenderer::RaymarchRenderer(const RaymarchSettings& s) : settings_(s), impl_(std::make_unique<Impl>()) {
    validate(s);
    Impl& m = *impl_;
    m.buildMarch();
    m.empty = VertexArray::create();
    if (s.downsample > 1) m.reduced = std::make_unique<ReducedTarget>();
    checkAlways("creating the ray-marcher");
}

RaymarchRenderer::~RaymarchRenderer() = default;

void RaymarchRenderer::Impl::ensureNoise(const RaymarchSettings& s) {
    if (noise && noiseOctaves == s.octaves) return;
    const NoiseSettings ns = raymarchNoiseSettings(s);
    noiseCpu = makeNoiseVolume(ns);
    noise = noiseTexture(noiseCpu);
    noiseOctaves = s.octaves;
    check("uploading the raymarch noise volume");
}

// The march program, for one variant of the detail (DetailTexture::defines).
void RaymarchRenderer::Impl::buildMarch() {
    march = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "raymarch.frag"}},
                           "#define RM_TILE " + std::to_string(kTile) + "\n" + DetailTexture::defines(detailVariant));
    march.bindStorageBlock("RmEllipsoids", kEllipsoidsBinding);
    march.bindStorageBlock("RmClouds", kCloudsBinding);
    march.bindStorageBlock("RmTileFirst", kTileFirstBinding);
    march.bindStorageBlock("RmTileClouds", kTileCloudsBinding);
}

RaymarchStats RaymarchRenderer::render(const Scene& scene, const View& view, GLuint framebuffer, bool opaqueDepth) {
    Impl& m = *impl_;
    const RaymarchSettings& s = settings_;
    RaymarchStats stats;
    const auto start = std::chrono::steady_clock::now();
    stats.clouds = int(scene.clouds.size());
    for (const Cloud& c : scene.clouds) stats.ellipsoids += int(c.ellipsoids.size());
    // object_light "all": the objects are drawn again lit by the clouds (and the sky: also
    // without clouds) before the clouds are marched over them.
    const bool litObjects = scene.objectLight == ObjectLight::All && !scene.objects.empty() && opaqueDepth;
    if (stats.ellipsoids == 0 && !litObjects) return stats;
    const Medium& medium = scene.medium;
    const double kappa = std::max(medium.noise, 0.0);

    HostStateScope scope;  // before the uploads
    if (DetailTexture::variant(medium.detail) != m.detailVariant) {
        m.detailVariant = DetailTexture::variant(medium.detail);
        m.buildMarch();
    }
    if (kappa > 0) m.ensureNoise(s);
    m.updateLight(s, scene, view, framebuffer, litObjects, stats);
    if (stats.ellipsoids == 0) return stats;

    const std::vector<std::pair<Vec3, Vec3>> boxes = m.uploadClouds(scene, view);  // camera-relative
    if (boxes.empty()) return stats;
    // The pixels the rays go through: the frame's, or 1/d of them per side (ReducedTarget's size);
    // a ray per pixel wherever the view comes within the sun's phase peak (model::withinSunPeak),
    // where a back-lit cloud's rim is thinner than a block (back-lit cumulus27 at 2x2: 19.8%
    // against the path tracer, 16.9% per pixel).
    const bool sunPeak = model::withinSunPeak(std::cos(angleToView(view, scene.sun.direction)), medium.hgG);
    const int d = sunPeak ? 1 : s.downsample;
    stats.downsample = d;
    View marchView = view;
    marchView.camera.width = (view.camera.width + d - 1) / d,
    marchView.camera.height = (view.camera.height + d - 1) / d;
    const TileBins bins = binClouds(boxes, marchView);
    uploadDynamic(m.tileFirst, m.tileFirstCapacity, bins.first.data(), bins.first.size() * sizeof(std::int32_t));
    uploadDynamic(m.tileClouds, m.tileCloudCapacity, bins.clouds.data(), bins.clouds.size() * sizeof(std::int32_t));

    HostFrame frame;
    frame.framebuffer = framebuffer;
    frame.hasDepth = opaqueDepth;
    const DepthSource depth = m.depth.source(frame, view);
    // Reduced: the frame's depth reduced per block (to its farthest) is what the rays end at.
    DepthSource marchDepth = depth;
    if (d > 1) {
        m.reduced->begin(depth, view, d);
        if (depth.texture != 0) marchDepth = m.reduced->depth();
    }

    m.setFrameUniforms(view, d, marchDepth, bins.tilesX);
    stats.planMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    m.setMediumUniforms(s, scene, view, kappa);
    m.drawMarch(view, frame, depth, marchDepth, marchView, d, kappa);
    return stats;
}

// The clouds' light: grids of clouds that only moved are kept (light_cache.hpp); with
// `litObjects`, the objects drawn again lit by them.
void RaymarchRenderer::Impl::updateLight(const RaymarchSettings& s, const Scene& scene, const View& view,
                                         GLuint framebuffer, bool litObjects, RaymarchStats& stats) {
    RadianceUpdateStats lightStats;
    const std::vector<PlacedRadiance> light = lightCache.update(scene, s.light, &view.eye, &lightStats);
    stats.lightGridsComputed = lightStats.computed;
    stats.lightStandIns = lightStats.standIns;
    lightTextures.update(light);
    lightTextures.setBoxes(light, view.eye);
    if (litObjects) {
        HostFrame lit;
        lit.framebuffer = framebuffer;
        lit.hasDepth = true;
        objectLight.draw(scene, view, lit, lightTextures, light);
    }
}

// This frame's data, camera-relative (float precision stays at the eye), uploaded: the
// ellipsoids with matter, the clouds holding them. Returns each cloud's box (empty: none).
std::vector<std::pair<Vec3, Vec3>> RaymarchRenderer::Impl::uploadClouds(const Scene& scene, const View& view) {
    const Medium& medium = scene.medium;
    std::vector<GpuEllipsoid> ells;
    std::vector<GpuCloud> gpuClouds;
    std::vector<std::pair<Vec3, Vec3>> boxes;  // parallel to gpuClouds, camera-relative
    for (int c = 0; c < int(scene.clouds.size()); ++c) {
        const Cloud& cloud = scene.clouds[c];
        Vec3 lo, hi;
        if (!raymarchCloudBox(cloud, lo, hi)) continue;
        GpuCloud g{};
        put(g.boxMin, lo - view.eye);
        put(g.boxMax, hi - view.eye);
        g.range[0] = int(ells.size());
        g.range[2] = c;
        for (const Ellipsoid& e : cloud.ellipsoids) {
            if (e.density <= 0) continue;  // no matter: never a candidate
            const glm::dmat3 unit = ellipsoidToUnit(e);
            GpuEllipsoid ge{};
            put(ge.eyeUnitSigma, unit * (view.eye - e.center), medium.extinction * e.density);
            for (int r = 0; r < 3; ++r) put(ge.unit[r], glm::row(unit, r));
            ells.push_back(ge);
        }
        g.range[1] = int(ells.size()) - g.range[0];
        if (g.range[1] == 0) continue;
        gpuClouds.push_back(g);
        boxes.emplace_back(lo - view.eye, hi - view.eye);
    }
    if (gpuClouds.empty()) return boxes;
    uploadDynamic(ellipsoids, ellipsoidCapacity, ells.data(), ells.size() * sizeof(GpuEllipsoid));
    uploadDynamic(clouds, cloudCapacity, gpuClouds.data(), gpuClouds.size() * sizeof(GpuCloud));
    return boxes;
}

// The march program's view, frame and binning uniforms (d: the reduction, 1 for full size).
void RaymarchRenderer::Impl::setFrameUniforms(const View& view, int d, const DepthSource& marchDepth, int tilesX) {
    const Program& p = march;
    p.set("forward", glm::vec3(view.forward));
    p.set("rayCentre", glm::vec3(view.rayCentre()));
    p.set("rightScaled", glm::vec3(view.rightScaled()));
    p.set("upScaled", glm::vec3(view.upScaled()));
    setViewFrameUniforms(p, view, d == 1, marchDepth);
    p.set("nearClip", float(view.camera.nearClip));
    p.set("farClip", float(view.camera.farClip));
    p.set("useDepth", marchDepth.texture != 0 ? 1 : 0);
    p.set("sceneDepth", 2);
    p.set("tilesX", tilesX);
}

// The march program's step, noise, light and medium uniforms.
void RaymarchRenderer::Impl::setMediumUniforms(const RaymarchSettings& s, const Scene& scene, const View& view,
                                               double kappa) {
    const Medium& medium = scene.medium;
    const Program& p = march;
    p.set("stepBase", float(s.step));
    p.set("invLod", s.lodDistance > 0 ? float(1.0 / s.lodDistance) : 0.0f);
    p.set("maxSteps", s.maxSteps);
    p.set("kappa", float(kappa));
    p.set("noiseVolume", 0);
    const double period = raymarchNoisePeriod(medium, raymarchNoiseSettings(s));
    p.set("eyeNoise", glm::vec3(glm::fract(view.eye / period)));
    p.set("invNoisePeriod", float(1.0 / period));
    lightTextures.bind(p);
    detail.bind(p, medium.detail, view.eye);
    p.set("sunDirection", glm::vec3(scene.sun.direction));
    p.set("sunIrradiance", glm::vec3(scene.sun.color * scene.sun.intensity));
    p.set("hgG", float(medium.hgG));
    p.set("albedo", float(medium.albedo));
}

// The march itself: one full-screen triangle over the frame (or the reduced target, then
// upsampled over the frame).
void RaymarchRenderer::Impl::drawMarch(const View& view, const HostFrame& frame, const DepthSource& depth,
                                       const DepthSource& marchDepth, const View& marchView, int d, double kappa) {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kEllipsoidsBinding, ellipsoids.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCloudsBinding, clouds.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kTileFirstBinding, tileFirst.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kTileCloudsBinding, tileClouds.id());
    glBindTextureUnit(0, kappa > 0 ? noise.id() : 0);
    glBindTextureUnit(2, marchDepth.texture);
    glBindSampler(0, 0);
    glBindSampler(2, 0);

    if (d > 1) reduced->resume(glm::ivec4(0, 0, marchView.camera.width, marchView.camera.height));  // the colour alone
    else bindFrame(frame, view);
    glDisable(GL_DEPTH_TEST);
    // The shader writes premultiplied (radiance, 1 - T): colour' = radiance + T colour,
    // alpha' = (1 - T) + T alpha.
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(march.id());
    glBindVertexArray(empty.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    if (d > 1) reduced->composite(frame, depth, view, 0);  // upsampled "over" the frame with its depth
    check("ray-marching the clouds");
}

}  // namespace nephele
