// The tiled GPU compositor (see nephele/ellipsoid.hpp for the pipeline): its settings, the
// frame's plan (projection, culling, tile sizes, packing or reuse, the GPU tile data, the light),
// and render(), which runs the tile pass (tile_pass.cpp) and the composite (composite_pass.cpp).
#include "compositor_impl.hpp"
#include "ellipsoid_hooks.hpp"

#include "nephele/gl_state.hpp"

#include <glm/gtc/matrix_access.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <numbers>

namespace nephele {

constexpr int kMinAtlasLayers = 8;  // an atlas is made with room for this many passes (see plan())

namespace {

// A unit sphere scaled to circumscribe itself: its faces lie outside the unit sphere, so
// its back faces cover the exact silhouette. Counter-clockwise seen from outside.
IndexedMesh makeSphere(int slices) {
    const int stacks = std::max(2, slices / 2);
    const double scale = 1.0 / (std::cos(std::numbers::pi / slices) * std::cos(std::numbers::pi / (2 * stacks)));
    std::vector<float> v;
    std::vector<unsigned> idx;
    for (int i = 0; i <= stacks; ++i) {
        const double theta = std::numbers::pi * i / stacks;
        for (int j = 0; j <= slices; ++j) {
            const double phi = 2 * std::numbers::pi * j / slices;
            v.insert(v.end(), {float(scale * std::sin(theta) * std::cos(phi)), float(scale * std::sin(theta) * std::sin(phi)),
                               float(scale * std::cos(theta))});
        }
    }
    for (int i = 0; i < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            const unsigned a = unsigned(i * (slices + 1) + j), b = a + unsigned(slices + 1);
            idx.insert(idx.end(), {a, b, a + 1, a + 1, b, b + 1});
        }
    return makeIndexedMesh(v, idx, 1);
}

int floorPow2(int v) {
    int p = 1;
    while (p * 2 <= v) p *= 2;
    return p;
}

void checkPow2(const char* what, int v) {
    if (v < 1 || (v & (v - 1)) != 0) throw std::invalid_argument(std::string(what) + " must be a power of two, got " + std::to_string(v));
}

}  // namespace

EllipsoidRenderer::EllipsoidRenderer(const EllipsoidSettings& s) : settings_(s), impl_(std::make_unique<Impl>()) {
    checkPow2("minTile", s.minTile);
    checkPow2("maxTile", s.maxTile);
    if (s.minTile > s.maxTile) throw std::invalid_argument("minTile must not exceed maxTile");
    if (s.tessellation != 0 && (s.tessellation < 4 || s.tessellation > 256))
        throw std::invalid_argument("tessellation must be 0 (adaptive) or 4..256 slices");
    validate(s.light);
    if (s.atlasMegabytes < 1) throw std::invalid_argument("atlasMegabytes must be at least 1");
    if (s.order == CompositeOrder::PerPixel)
        throw std::invalid_argument("order: the compositor composites whole tiles (PerEllipsoid) or weighted, not per pixel");
    if (!(s.weightExponent >= 0 && s.weightExponent <= 16)) throw std::invalid_argument("weightExponent must be 0..16");
    if (!(s.reuseErrorPixels > 0 && s.reuseErrorPixels <= 1e6)) throw std::invalid_argument("reuseErrorPixels must be in (0, 1e6]");
    if (!(s.reuseBudget >= 0 && s.reuseBudget <= 1e6)) throw std::invalid_argument("reuseBudget must be in [0, 1e6]");
    if (!(s.cloudLodErrorPixels > 0 && s.cloudLodErrorPixels <= 1e6))
        throw std::invalid_argument("cloudLodErrorPixels must be in (0, 1e6]");
    if (!(s.cloudLodDistance >= 1 && s.cloudLodDistance <= 1e6)) throw std::invalid_argument("cloudLodDistance must be in [1, 1e6]");
    if (s.cloudLodMaxPixels < 8 || s.cloudLodMaxPixels > 4096) throw std::invalid_argument("cloudLodMaxPixels must be in 8..4096");
    if (s.impostorMegabytes < 1) throw std::invalid_argument("impostorMegabytes must be at least 1");
    if (s.closeDownsample < 1 || s.closeDownsample > 4) throw std::invalid_argument("closeDownsample must be in 1..4");
    Impl& m = *impl_;
    // 8-bit atlases store the light scalars as x / (1 + x) (cloud_light.glsl, encodeLight).
    const std::string unorm8 = s.precision == AtlasPrecision::Unorm8 ? "#define ATLAS_UNORM8 1\n" : "";
    // Only the programs these settings use (llvmpipe compiles each in tens of milliseconds).
    if (s.geometry == TileGeometry::Mesh) {
        const std::string falloffTexture = std::string(s.falloffTexture ? "#define FALLOFF_TEXTURE 1\n" : "") + unorm8;
        m.tile = Program::build({{GL_VERTEX_SHADER, "ellipsoid_tile.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile.frag"}},
                                falloffTexture);
        m.tileCut = Program::build({{GL_VERTEX_SHADER, "ellipsoid_tile.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile.frag"}},
                                   falloffTexture + "#define CUT 1\n");
        m.rayDefines = unorm8;
    } else {
        m.tileRay = Program::build({{GL_VERTEX_SHADER, "ellipsoid_tile_ray.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile_ray.frag"}},
                                   unorm8);
        m.tileRayCut = Program::build({{GL_VERTEX_SHADER, "ellipsoid_tile_ray.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile_ray.frag"}},
                                      unorm8 + "#define CUT 1\n");
    }
    m.colourMatrix = Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "colour_matrix.frag"}});
    const std::string fused = (s.colourMatrixPass ? "" : "#define FUSED 1\n") + unorm8;
    m.composite = Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}}, fused);
    if (s.order == CompositeOrder::Weighted || s.order == CompositeOrder::Moments) {
        const std::string weighted = fused + "#define WEIGHTED 1\n";
        const std::string second = weighted + (s.order == CompositeOrder::Moments ? "#define MOMENTS 1\n" : "");
        m.compositeWeighted = Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}}, second);
        m.compositeWeightedFraction = Program::build(
            {{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}}, second + "#define FRACTION 1\n");
        if (s.order == CompositeOrder::Moments) {
            m.compositeMoments = Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}},
                                                weighted + "#define MOMENTS_PASS 1\n");
            m.compositeMomentsFraction =
                Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}},
                               weighted + "#define MOMENTS_PASS 1\n#define FRACTION 1\n");
        }
        m.resolve = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "composite_resolve.frag"}});
    } else {
        m.compositeFraction = Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}},
                                             fused + "#define FRACTION 1\n");
    }
    m.screenDepth = Program::build({{GL_VERTEX_SHADER, "ellipsoid_screen.vert"}, {GL_FRAGMENT_SHADER, "depth_only.frag"}});
    if (cloudLodApplies(s)) {  // only then are impostors drawn
        m.impostor = Program::build({{GL_VERTEX_SHADER, "impostor.vert"}, {GL_FRAGMENT_SHADER, "impostor.frag"}});
        m.impostorFraction = Program::build({{GL_VERTEX_SHADER, "impostor.vert"}, {GL_FRAGMENT_SHADER, "impostor.frag"}},
                                            "#define FRACTION 1\n");
    }
    if (cloudLodApplies(s) && s.closeDownsample > 1) {  // built now, as tileClear below
        m.reduced = std::make_unique<ReducedTarget>();
        m.reduced->program(0, true), m.reduced->program(0, false);
    }
    if (s.reuse)  // built now: a first reuse frame that compiled it stalled
        m.tileClear = Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "tile_clear.frag"}});
    m.empty = VertexArray::create();
    HostStateScope scope;  // the uploads below see a tightly packed pixel store whatever the host set

    // The projective radial falloff texture (the paper's figure 4), F(b) = (1 - b^2)^(5/2).
    constexpr int kFalloff = 256;
    std::vector<float> f(kFalloff * kFalloff);
    for (int y = 0; y < kFalloff; ++y)
        for (int x = 0; x < kFalloff; ++x) {
            const double u = (x + 0.5) / kFalloff * 2 - 1, v = (y + 0.5) / kFalloff * 2 - 1;
            f[y * kFalloff + x] = model::radialProfile(float(u * u + v * v));
        }
    m.falloff = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(m.falloff.id(), 1, GL_R32F, kFalloff, kFalloff);
    glTextureSubImage2D(m.falloff.id(), 0, 0, 0, kFalloff, kFalloff, GL_RED, GL_FLOAT, f.data());
    glTextureParameteri(m.falloff.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(m.falloff.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(m.falloff.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(m.falloff.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);

    const NoiseVolume nv = makeNoiseVolume(s.noise.size, s.noise.cells, s.noise.octaves, s.noise.seed);
    m.noise = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(m.noise.id(), 1, GL_R32F, nv.size, nv.size, nv.size);
    glTextureSubImage3D(m.noise.id(), 0, 0, 0, 0, nv.size, nv.size, nv.size, GL_RED, GL_FLOAT, nv.texels.data());
    glTextureParameteri(m.noise.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(m.noise.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) glTextureParameteri(m.noise.id(), w, GL_REPEAT);

    m.linearClamp = linearSampler(GL_CLAMP_TO_EDGE);
    checkAlways("creating the ellipsoid compositor");
}

EllipsoidRenderer::~EllipsoidRenderer() = default;

namespace {
// Mesh tiles light per vertex (the paper's Gouraud light). Looking within the sun's phase
// peak (model::withinSunPeak), the vertices miss the thin bright rim of a back-lit cloud: there
// the tile is drawn as a polygon tile, the model per pixel. Back-lit cumulus27, the sun's light
// alone: 25% off per vertex, 10% per pixel, as the ray-marcher. Per-pixel tiles cost more, so
// only the peak's angle is taken, not more.
bool nearTheSun(const PreparedEllipsoid& e, const View& view, const Scene& scene) {
    const Vec3 toCentre = e.shape.center - view.eye;
    const double distance = glm::length(toCentre);
    const double radius = e.shape.maxRadius();
    if (distance <= radius) return true;  // around the eye: some of it is near the sun
    const double angle = std::acos(std::clamp(glm::dot(toCentre / distance, scene.sun.direction), -1.0, 1.0));
    const double nearest = std::max(0.0, angle - std::asin(radius / distance));
    return model::withinSunPeak(std::cos(nearest), scene.medium.hgG);
}

}  // namespace

// The clouds' radiance grids for `scene` (light_cache.hpp), made now or on the worker
// (`background`, a stand-in meanwhile); clouds that only moved (wind, near-LOD cells) keep
// theirs. Grids already on the GPU are not uploaded again, so a windy frame uploads nothing.
void EllipsoidRenderer::Impl::updateLights(const EllipsoidSettings& s, const Scene& scene, const Vec3* eye,
                                           bool background, bool takeFinished) {
    RadianceGridSettings g = s.light;
    g.background = g.background || background;
    RadianceUpdateStats stats;
    light = lightCache.update(scene, g, eye, &stats, takeFinished);
    if (takeFinished) lightStats = stats;  // the host's update, not a channel's draw
    lightsComputed += stats.computed;
    lightUploads += lightTextures.update(light);
}

// Everything before the first draw: projection, culling, tile sizes, packing, the GPU
// tile data, the light volumes and the atlas. `plan.stats.visible == 0`: nothing to draw.
FramePlan EllipsoidRenderer::Impl::plan(const EllipsoidSettings& s, const Scene& scene, const View& view, bool reuse,
                                        bool lod) {
    Impl& m = *this;
    FramePlan out;
    out.reuse = reuse;
    EllipsoidStats& stats = out.stats;
    for (const Cloud& c : scene.clouds) stats.ellipsoids += int(c.ellipsoids.size());
    out.prepared = prepareClouds(scene, view, s.noise);
    const PreparedClouds& prepared = out.prepared;
    // The close LOD: no tile finer than its ellipsoid's image (closeTileTexels). The detail's image
    // holds features of a few pixels at every distance (its octaves fade by projected size), so
    // with it a tile keeps the texels its ellipsoid covers on screen.
    if (lod && cloudLodApplies(s) && !scene.medium.detail.on()) {
        const double noiseTexel = scene.medium.noise > 0 ? prepared.noisePeriod / s.noise.size
                                                         : std::numeric_limits<double>::infinity();
        for (PreparedEllipsoid& e : out.prepared.ellipsoids) e.contentTexels = closeTileTexels(e.shape.maxRadius(), noiseTexel);
    }
    stats.visible = int(prepared.ellipsoids.size());
    if (prepared.ellipsoids.empty()) return out;

    const int frameW = view.camera.width, frameH = view.camera.height;
    const int atlasW = s.atlasWidth > 0 ? s.atlasWidth : frameW;
    const int atlasH = s.atlasHeight > 0 ? s.atlasHeight : frameH;
    const int maxTile = std::min(s.maxTile, floorPow2(std::min(atlasW, atlasH)));
    const int minTile = std::min(s.minTile, maxTile);
    // Without reuse one atlas per size; with it one per view size and place (a channel's tiles).
    Atlas& atlas = m.atlases.get(reuse ? glm::ivec4(atlasW, atlasH, view.origin.x, view.origin.y) : glm::ivec4(atlasW, atlasH, -1, -1));
    m.atlas = &atlas;

    // The clouds' light: grids of clouds that only moved are kept (light_cache.hpp).
    // Driven by a host's updateLights(), the grids change only there: every channel of a frame
    // draws with the same ones.
    m.updateLights(s, scene, &view.eye, m.lightsDriven, !m.lightsDriven);
    const std::vector<PlacedRadiance>& light = m.light;

    // ---- The cloud LOD: far clouds as impostors; only the tiles of those made this frame and
    // of the clouds drawn as tiles go on.
    std::vector<int> impostorOf;  // per scene cloud: its index in out.impostors, else -1
    std::vector<char> keepTiles;  // per scene cloud: an impostor kept from before (its tiles stay in the atlas)
    if (lod && cloudLodApplies(s)) {
        ImpostorSettings is;
        is.distance = s.cloudLodDistance, is.maxPixels = s.cloudLodMaxPixels;
        is.atlasSize = std::max(256, int(std::bit_ceil(unsigned(s.cloudLodMaxPixels + 2))));
        is.layers = std::max(1, int(s.impostorMegabytes * 1048576.0 / (double(is.atlasSize) * is.atlasSize * 8)));
        is.errorPixels = s.cloudLodErrorPixels, is.budget = s.reuseBudget;
        CloudImpostors& ci = m.impostors.get({frameW, frameH, view.origin.x, view.origin.y});
        ImpostorPlan ip = ci.plan(is, scene, view, out.prepared, light);
        out.impostorAtlas = &ci;
        out.impostors = std::move(ip.draws);
        impostorOf.assign(scene.clouds.size(), -1);
        keepTiles.assign(scene.clouds.size(), 0);
        for (int k = 0; k < int(out.impostors.size()); ++k) {
            impostorOf[std::size_t(out.impostors[k].cloud)] = k;
            keepTiles[std::size_t(out.impostors[k].cloud)] = !out.impostors[k].fresh;
        }
        std::erase_if(out.prepared.ellipsoids, [&](const PreparedEllipsoid& e) {
            const int k = impostorOf[std::size_t(e.cloud)];
            return k >= 0 && !out.impostors[std::size_t(k)].fresh;
        });
        stats.impostors = int(out.impostors.size());
        stats.impostorsRendered = ip.rendered;
    }
    // The composite's runs: tiles of the clouds drawn as tiles (order[0, frameTiles), back to
    // front) and impostors, merged back to front.
    auto makeRuns = [&](int frameTiles) {
        std::size_t next = 0;
        int k = 0;
        for (const PreparedEllipsoid& e : out.prepared.ellipsoids) {
            if (!impostorOf.empty() && impostorOf[std::size_t(e.cloud)] >= 0) continue;
            for (; next < out.impostors.size() && out.impostors[next].distance > e.projection.distance; ++next)
                out.runs.push_back({0, 0, int(next)});
            if (out.runs.empty() || out.runs.back().impostor >= 0) out.runs.push_back({k, 0, -1});
            ++out.runs.back().count, ++k;
        }
        for (; next < out.impostors.size(); ++next) out.runs.push_back({0, 0, int(next)});
        if (k != frameTiles) throw std::logic_error("ellipsoid compositor: the composite's runs miss tiles");
    };
    if (out.prepared.ellipsoids.empty()) {  // every visible cloud an impostor kept from before
        m.lastTiles.clear();
        makeRuns(0);
        return out;
    }

    // ---- Tiles: sizes, packing, per-pass order.
    // Each pass keeps an atlas layer until the composite: past the memory budget, the
    // largest tiles are halved (and the packing redone) so that memory stays bounded.
    const double layerBytes = double(atlasW) * atlasH * (s.precision == AtlasPrecision::Float16 ? 8 : 4);
    const int maxPasses = std::max(1, int(s.atlasMegabytes * 1048576.0 / layerBytes));
    GLint maxLayers = 0;
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &maxLayers);
    std::vector<TilePlacement>& placements = out.placements;
    if (!reuse) {
        for (int limit = maxTile;; limit /= 2) {
            std::vector<TileRequest> requests;
            for (int i = 0; i < int(prepared.ellipsoids.size()); ++i) {
                requests.push_back({i, tileSizeFor(tileExtent(prepared.ellipsoids[i]), minTile, limit)});
            }
            out.packed = packTiles(requests, atlasW, atlasH);
            stats.maxTile = limit;
            if (out.packed.passes <= maxPasses || limit <= minTile) break;
        }
        placements = out.packed.placements;
    } else {
        ReuseSettings rs;
        rs.atlasWidth = atlasW, rs.atlasHeight = atlasH, rs.frameWidth = frameW, rs.frameHeight = frameH;
        rs.minTile = minTile, rs.maxTile = maxTile, rs.budgetLayers = maxPasses, rs.layers = atlas.layers;
        rs.maxLayers = std::max(1, std::min(int(maxLayers), std::max(4 * maxPasses, 64)));
        rs.errorPixels = s.reuseErrorPixels, rs.budget = s.reuseBudget;
        ReusePlan rp = atlas.reuse.plan(rs, scene, view, prepared, light, keepTiles);
        placements = std::move(rp.fresh);
        out.reused = std::move(rp.reused);
        out.reproject = std::move(rp.reproject);
        out.reusedRect = std::move(rp.screenRect);
        out.packed.passes = rp.layers;
        out.packed.utilisation = {rp.utilisation};
        stats.maxTile = rp.maxTile;
        stats.tilesMust = rp.must;
        stats.atlasRepacked = rp.reset;
    }
    const PackResult& packed = out.packed;
    if (packed.passes > maxLayers)
        throw GlError("ellipsoid atlas: " + std::to_string(prepared.ellipsoids.size()) + " visible ellipsoids need " +
                      std::to_string(packed.passes) + " passes of " + std::to_string(atlasW) + "x" + std::to_string(atlasH) +
                      " even with " + std::to_string(minTile) + " px tiles, more than GL's " + std::to_string(maxLayers) +
                      " atlas layers; give a larger atlas (--atlas) or smaller tiles (--min-tile)");
    stats.passes = packed.passes;
    stats.utilisation = packed.meanUtilisation();
    // Mesh tiles near the sun are lit per pixel (nearTheSun).
    out.perPixelLight.assign(prepared.ellipsoids.size(), 0);
    if (s.geometry == TileGeometry::Mesh) {
        for (std::size_t i = 0; i < prepared.ellipsoids.size(); ++i)
            out.perPixelLight[i] = nearTheSun(prepared.ellipsoids[i], view, scene) ? 1 : 0;
        if (!m.tileRay && std::any_of(out.perPixelLight.begin(), out.perPixelLight.end(), [](char c) { return c != 0; }))
            m.tileRay = Program::build(
                {{GL_VERTEX_SHADER, "ellipsoid_tile_ray.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile_ray.frag"}}, m.rayDefines);
    }
    // Within a pass tiles never overlap, so any order will do: group them by program
    // (cut by the near plane or not, lit per pixel or not) and mesh level, one instanced draw
    // per group.
    auto group = [&](const TilePlacement& p) {
        return drawGroup(s, prepared.ellipsoids[p.id], p.size, out.perPixelLight[p.id] != 0);
    };
    std::stable_sort(placements.begin(), placements.end(), [&](const TilePlacement& a, const TilePlacement& b) {
        return a.pass != b.pass ? a.pass < b.pass : group(a) < group(b);
    });

    const glm::dmat4 viewRotation = glm::lookAt(Vec3(0.0), view.forward, view.up);
    std::vector<GpuTile>& gpu = out.gpu;
    gpu.resize(placements.size() + out.reused.size());
    m.lastTiles.clear();
    std::vector<int> slot(prepared.ellipsoids.size());  // prepared index -> GPU tile index
    // The tiles rendered this frame, then those composited from an earlier frame's image.
    for (std::size_t k = 0; k < gpu.size(); ++k) {
        const bool fresh = k < placements.size();
        const TilePlacement& tp = fresh ? placements[k] : out.reused[k - placements.size()];
        const PreparedEllipsoid& e = prepared.ellipsoids[tp.id];
        const EllipsoidProjection& p = e.projection;
        GpuTile& t = gpu[k];
        put(t.centerSigma, e.shape.center - view.eye, e.sigma);
        for (int c = 0; c < 3; ++c) put(t.axes[c], e.axes[c]);
        for (int r = 0; r < 3; ++r) put(t.unit[r], glm::row(e.unit, r));
        put(t.eyeUnitAc, e.unit * (view.eye - e.shape.center), e.ac);
        const glm::dmat4 tileViewProj = p.projection * viewRotation;
        const glm::mat4 tvp(tileViewProj);
        std::memcpy(t.tileViewProj, glm::value_ptr(tvp), sizeof t.tileViewProj);
        // The ray through tile clip (x, y): its point on the near plane, affine in x and y.
        const glm::dmat4 inv = glm::inverse(tileViewProj);
        auto nearPoint = [&](double x, double y) {
            const glm::dvec4 h = inv * glm::dvec4(x, y, -1.0, 1.0);
            return Vec3(h) / h.w;
        };
        const Vec3 rc = nearPoint(0, 0);
        put(t.rayCentre, rc);
        const Vec3 rx = nearPoint(1, 0) - rc, ry = nearPoint(0, 1) - rc;
        put(t.rayX, rx);
        put(t.rayY, ry);
        if (fresh && reuse) atlas.reuse.rendered(tp.id, rc, rx, ry);
        t.atlasRect[0] = float(tp.x), t.atlasRect[1] = float(tp.y), t.atlasRect[2] = float(tp.size), t.atlasRect[3] = float(tp.pass);
        if (fresh) {
            t.screenRect[0] = float(p.rect.x0), t.screenRect[1] = float(p.rect.y0);
            t.screenRect[2] = float(p.rect.x1), t.screenRect[3] = float(p.rect.y1);
        } else {
            const std::size_t r = k - placements.size();
            for (int c = 0; c < 4; ++c) t.screenRect[c] = out.reusedRect[r][c];
            std::memcpy(t.reproject, glm::value_ptr(out.reproject[r]), sizeof t.reproject);
        }
        put(t.params, Vec3(p.crossesNear ? 1.0 : 0.0, double(e.cloud), fresh ? 0.0 : 1.0));
        put(t.noiseOffset, e.noiseOffset);
        put(t.skyChroma, Vec3(model::skyChroma(glm::vec3(light[e.cloud].sample(e.shape.center).skyTau))));
        slot[tp.id] = int(k);
        m.lastTiles.push_back({{t.screenRect[0], t.screenRect[1], t.screenRect[2], t.screenRect[3]}, tp.x, tp.y, tp.size, tp.pass});
        stats.tilePixels += std::int64_t(tp.size) * tp.size;
        stats.screenPixels += std::int64_t(std::lround(p.pixelWidth * p.pixelHeight));
        if (fresh) ++stats.tilesRendered, stats.tilePixelsRendered += std::int64_t(tp.size) * tp.size;
        else ++stats.tilesReused;
    }
    // prepared.ellipsoids is back to front: that is the composite order. With impostors, the
    // tiles composited over the frame first, then each fresh impostor's.
    std::vector<int>& order = out.order;
    if (impostorOf.empty()) {
        order = slot;
        makeRuns(int(order.size()));
    } else {
        for (std::size_t i = 0; i < prepared.ellipsoids.size(); ++i)
            if (impostorOf[std::size_t(prepared.ellipsoids[i].cloud)] < 0) order.push_back(slot[i]);
        const int frameTiles = int(order.size());
        out.impostorFirst.assign(out.impostors.size(), 0);
        out.impostorCount.assign(out.impostors.size(), 0);
        for (std::size_t k = 0; k < out.impostors.size(); ++k) {
            if (!out.impostors[k].fresh) continue;
            out.impostorFirst[k] = int(order.size());
            for (std::size_t i = 0; i < prepared.ellipsoids.size(); ++i)
                if (prepared.ellipsoids[i].cloud == out.impostors[k].cloud) order.push_back(slot[i]);
            out.impostorCount[k] = int(order.size()) - out.impostorFirst[k];
        }
        makeRuns(frameTiles);
    }

    // ---- Resources.
    uploadDynamic(m.tiles, m.tilesCapacity, gpu.data(), gpu.size() * sizeof(GpuTile));
    uploadDynamic(m.order, m.orderCapacity, order.data(), order.size() * sizeof(int));
    m.lightTextures.setBoxes(m.light, view.eye);

    atlas.width = atlasW;
    atlas.height = atlasH;
    if (atlas.layers < packed.passes) {
        const GLenum termsFormat = s.precision == AtlasPrecision::Float16 ? GL_RGBA16F : GL_RGBA8;
        // A power of two of layers, 8 at least (within the memory budget): remaking it costs a
        // frame about 200 ms at 1280x720 on llvmpipe (bench --weather: 3 -> 5 -> 8 layers as
        // near clouds came into view stalled two frames), so it is made with room to grow.
        // With reuse, twice that: its tiles stay within the layers it has until a repack.
        const int room = int(std::bit_ceil(unsigned(packed.passes))) * (reuse ? 2 : 1);
        const int layers = std::max(packed.passes, std::min(maxPasses, std::max(kMinAtlasLayers, room)));
        Texture terms = Texture::create(GL_TEXTURE_2D_ARRAY);
        out.stats.atlasGrown = true;
        checkTextureSize("the ellipsoid atlas", atlasW, atlasH, 0, layers);
        glTextureStorage3D(terms.id(), 1, termsFormat, atlasW, atlasH, layers);
        checkAllocation("the ellipsoid atlas (" + std::to_string(atlasW) + "x" + std::to_string(atlasH) + ", " +
                            std::to_string(layers) + " layers)",
                        std::uint64_t(atlasW) * std::uint64_t(atlasH) * std::uint64_t(layers) *
                            (termsFormat == GL_RGBA16F ? 8 : 4));
        // (With reuse the atlas grows only when it was packed anew: no tile's image is lost.)
        if (reuse && !out.reused.empty()) throw std::logic_error("ellipsoid atlas: grown while tiles are reused");
        atlas.terms = std::move(terms);
        atlas.layers = layers;
        atlas.fbos.clear();
        for (int l = 0; l < atlas.layers; ++l) {
            Framebuffer fbo = Framebuffer::create();
            glNamedFramebufferTextureLayer(fbo.id(), GL_COLOR_ATTACHMENT0, atlas.terms.id(), 0, l);
            checkFramebuffer(fbo.id(), "the ellipsoid atlas");
            atlas.fbos.push_back(std::move(fbo));
        }
    }
    out.atlasW = atlasW;
    out.atlasH = atlasH;
    return out;
}

int EllipsoidRenderer::updateLights(const Scene& scene, const Vec3* eye) {
    HostStateScope scope;  // the uploads
    impl_->lightsDriven = true;
    impl_->updateLights(settings_, scene, eye, true);
    return std::exchange(impl_->lightsComputed, 0);
}

void EllipsoidRenderer::waitForLights(const Scene& scene) {
    impl_->lightCache.waitIdle();
    HostStateScope scope;
    impl_->updateLights(settings_, scene, nullptr, true);
}

int EllipsoidRenderer::pendingLights() const { return impl_->lightCache.pending(); }

RadianceUpdateStats EllipsoidRenderer::lightStats() const { return impl_->lightStats; }

EllipsoidStats EllipsoidRenderer::render(const Scene& scene, const View& view, GLuint framebuffer, bool opaqueDepth) {
    HostFrame frame;
    frame.framebuffer = framebuffer;
    frame.hasDepth = opaqueDepth;
    return render(scene, view, frame);
}

EllipsoidStats EllipsoidRenderer::render(const Scene& scene, const View& view, const HostFrame& frame) {
    Impl& m = *impl_;
    const EllipsoidSettings& s = settings_;
    HostStateScope scope;  // before the plan: it uploads
    PartTimer timer(s.timings);
    const auto start = std::chrono::steady_clock::now();
    const FramePlan plan = m.plan(s, scene, view, s.reuse);
    EllipsoidStats stats = plan.stats;
    stats.planMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    stats.lightVolumes = std::exchange(m.lightsComputed, 0);
    stats.lightUploads = std::exchange(m.lightUploads, 0);
    stats.lightPending = m.lightStats.pending;
    stats.lightStandIns = m.lightStats.standIns;
    // Objects lit by the clouds are drawn before the clouds over them. They need the frame's
    // depth (the objects' own, drawn by OpaquePass) to be drawn again in place.
    if (scene.objectLight == ObjectLight::All && !scene.objects.empty() && frame.hasDepth) {
        // The plan stopped before the light: the clouds out of view still shade and light them.
        if (stats.visible == 0) m.updateLights(s, scene, &view.eye, m.lightsDriven, !m.lightsDriven);
        m.drawLitObjects(scene, view, frame);
    }
    if (plan.order.empty() && plan.impostors.empty()) {
        m.lastTiles.clear();
        stats.tilesMs = timer.lap();
        return stats;
    }
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.tiles.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, m.order.id());
    m.drawTiles(s, plan, scene, view, stats);
    stats.tilesMs = timer.lap();
    m.compositeTiles(s, plan, scene, view, frame, stats);
    stats.compositeMs = timer.lap();
    return stats;
}

const IndexedMesh& EllipsoidRenderer::Impl::mesh(int slices) {
    auto it = meshes.find(slices);
    if (it == meshes.end()) it = meshes.emplace(slices, makeSphere(slices)).first;
    return it->second;
}

const std::vector<TileDebug>& EllipsoidRenderer::lastTiles() const { return impl_->lastTiles; }
GLuint EllipsoidRenderer::atlasTexture() const { return impl_->atlas ? impl_->atlas->terms.id() : 0; }
glm::ivec3 EllipsoidRenderer::atlasSize() const {
    const Impl::Atlas* a = impl_->atlas;
    return a ? glm::ivec3(a->width, a->height, a->layers) : glm::ivec3(0);
}

EllipsoidStats EllipsoidBenchHooks::renderFloor(EllipsoidRenderer& r, const Scene& scene, const View& view,
                                                GLuint framebuffer) {
    EllipsoidRenderer::Impl& m = *r.impl_;
    HostStateScope scope;
    const FramePlan plan = m.plan(r.settings_, scene, view, false, false);
    EllipsoidStats stats = plan.stats;
    if (plan.order.empty()) return stats;
    if (!m.floor) m.floor = Program::build({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "floor.frag"}});
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.tiles.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, m.order.id());
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
    glBindVertexArray(m.empty.id());
    glUseProgram(m.floor.id());
    const Program& f = m.floor;
    f.set("atlasSize", glm::vec2(plan.atlasW, plan.atlasH));
    f.set("atlasTerms", 3);
    f.set("useOrder", 0);
    glBindTextureUnit(3, m.atlas->terms.id());
    glBindSampler(3, m.linearClamp.id());
    for (int pass = 0, first = 0; pass < plan.packed.passes; ++pass) {
        int count = 0;
        while (first + count < int(plan.placements.size()) && plan.placements[first + count].pass == pass) ++count;
        glBindFramebuffer(GL_FRAMEBUFFER, m.atlas->fbos[pass].id());
        glViewport(0, 0, plan.atlasW, plan.atlasH);
        const float zero[4] = {0, 0, 0, 0};
        glClearNamedFramebufferfv(m.atlas->fbos[pass].id(), GL_COLOR, 0, zero);
        f.set("onScreen", 0);
        f.set("instanceBase", first);
        glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, count);
        bindFrame(HostFrame{framebuffer}, view);
        f.set("onScreen", 1);
        glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, count);
        stats.drawCalls += 2;
        first += count;
    }
    check("floor passes");
    return stats;
}

}  // namespace nephele
