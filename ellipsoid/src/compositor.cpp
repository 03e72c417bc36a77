// The tiled GPU compositor (see nephele/ellipsoid.hpp for the pipeline): its settings, the
// frame's plan (projection, culling, tile sizes, packing or reuse, the GPU tile data, the light),
// and render(), which runs the tile pass (tile_pass.cpp) and the composite (composite_pass.cpp).
#include "compositor_impl.hpp"
#include "ellipsoid_hooks.hpp"
#include "noise_texture.hpp"

#include "nephele/detail.hpp"
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
            v.insert(v.end(), {float(scale * std::sin(theta) * std::cos(phi)),
                               float(scale * std::sin(theta) * std::sin(phi)), float(scale * std::cos(theta))});
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
    if (v < 1 || (v & (v - 1)) != 0)
        throw std::invalid_argument(std::string(what) + " must be a power of two, got " + std::to_string(v));
}

void checkSettings(const EllipsoidSettings& s) {
    checkPow2("minTile", s.minTile);
    checkPow2("maxTile", s.maxTile);
    if (s.minTile > s.maxTile) throw std::invalid_argument("minTile must not exceed maxTile");
    if (s.tessellation != 0 && (s.tessellation < 4 || s.tessellation > 256))
        throw std::invalid_argument("tessellation must be 0 (adaptive) or 4..256 slices");
    validate(s.light);
    if (s.atlasMegabytes < 1) throw std::invalid_argument("atlasMegabytes must be at least 1");
    if (s.order == CompositeOrder::PerPixel)
        throw std::invalid_argument(
            "order: the compositor composites whole tiles (PerEllipsoid) or weighted, not per pixel");
    if (!(s.weightExponent >= 0 && s.weightExponent <= 16)) throw std::invalid_argument("weightExponent must be 0..16");
    if (!(s.reuseErrorPixels > 0 && s.reuseErrorPixels <= 1e6))
        throw std::invalid_argument("reuseErrorPixels must be in (0, 1e6]");
    if (!(s.reuseBudget >= 0 && s.reuseBudget <= 1e6)) throw std::invalid_argument("reuseBudget must be in [0, 1e6]");
    if (!(s.cloudLodErrorPixels > 0 && s.cloudLodErrorPixels <= 1e6))
        throw std::invalid_argument("cloudLodErrorPixels must be in (0, 1e6]");
    if (!(s.cloudLodDistance >= 1 && s.cloudLodDistance <= 1e6))
        throw std::invalid_argument("cloudLodDistance must be in [1, 1e6]");
    if (s.cloudLodMaxPixels < 8 || s.cloudLodMaxPixels > 4096)
        throw std::invalid_argument("cloudLodMaxPixels must be in 8..4096");
    if (s.impostorMegabytes < 1) throw std::invalid_argument("impostorMegabytes must be at least 1");
    if (s.closeDownsample < 1 || s.closeDownsample > 4) throw std::invalid_argument("closeDownsample must be in 1..4");
}

}  // namespace

namespace {
// The storage buffers' binding points, said here only: programs get them from buildProgram, the
// buffers are bound to them in this file (tiles.glsl and tile_quad.vert give none).
constexpr GLuint kTilesBinding = 0, kOrderBinding = 2;

Program buildProgram(std::initializer_list<ShaderStage> stages, const std::string& defines = "") {
    Program p = Program::build(stages, defines);
    p.bindStorageBlock("Tiles", kTilesBinding);
    p.bindStorageBlock("Order", kOrderBinding);
    return p;
}

// 8-bit atlases store the light scalars as x / (1 + x) (cloud_light.glsl, encodeLight).
std::string atlasDefines(const EllipsoidSettings& s) {
    return s.precision == AtlasPrecision::Unorm8 ? "#define ATLAS_UNORM8 1\n" : "";
}
}  // namespace

void EllipsoidRenderer::Impl::buildTilePrograms(const EllipsoidSettings& s) {
    const std::string defines = atlasDefines(s) + DetailTexture::defines(detailVariant);
    if (s.geometry == TileGeometry::Mesh) {
        const std::string falloffTexture = std::string(s.falloffTexture ? "#define FALLOFF_TEXTURE 1\n" : "") + defines;
        tile = buildProgram({{GL_VERTEX_SHADER, "ellipsoid_tile.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile.frag"}},
                            falloffTexture);
        tileCut = buildProgram({{GL_VERTEX_SHADER, "ellipsoid_tile.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile.frag"}},
                               falloffTexture + "#define CUT 1\n");
    } else {
        tileRayCut = buildProgram(
            {{GL_VERTEX_SHADER, "ellipsoid_tile_ray.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile_ray.frag"}},
            defines + "#define CUT 1\n");
    }
    // Polygon tiles, and mesh tiles lit per pixel (near the sun).
    tileRay = buildProgram(
        {{GL_VERTEX_SHADER, "ellipsoid_tile_ray.vert"}, {GL_FRAGMENT_SHADER, "ellipsoid_tile_ray.frag"}}, defines);
    drawnTilePrograms.clear();
}

// The programs these settings use, and only those (llvmpipe compiles each in tens of milliseconds).
void EllipsoidRenderer::Impl::buildPrograms(const EllipsoidSettings& s) {
    buildTilePrograms(s);
    const std::string unorm8 = atlasDefines(s);
    colourMatrix = buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "colour_matrix.frag"}});
    const std::string fused = (s.colourMatrixPass ? "" : "#define FUSED 1\n") + unorm8;
    composite = buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}}, fused);
    if (s.order == CompositeOrder::Weighted || s.order == CompositeOrder::Moments) {
        const std::string weighted = fused + "#define WEIGHTED 1\n";
        const std::string second = weighted + (s.order == CompositeOrder::Moments ? "#define MOMENTS 1\n" : "");
        compositeWeighted =
            buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}}, second);
        compositeWeightedFraction =
            buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}},
                         second + "#define FRACTION 1\n");
        if (s.order == CompositeOrder::Moments) {
            compositeMoments =
                buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}},
                             weighted + "#define MOMENTS_PASS 1\n");
            compositeMomentsFraction =
                buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}},
                             weighted + "#define MOMENTS_PASS 1\n#define FRACTION 1\n");
        }
        resolve = buildProgram({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "composite_resolve.frag"}});
    } else {
        compositeFraction = buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "composite.frag"}},
                                         fused + "#define FRACTION 1\n");
    }
    screenDepth = buildProgram({{GL_VERTEX_SHADER, "ellipsoid_screen.vert"}, {GL_FRAGMENT_SHADER, "depth_only.frag"}});
    if (cloudLodApplies(s)) {  // only then are impostors drawn
        impostor = buildProgram({{GL_VERTEX_SHADER, "impostor.vert"}, {GL_FRAGMENT_SHADER, "impostor.frag"}});
        impostorFraction = buildProgram({{GL_VERTEX_SHADER, "impostor.vert"}, {GL_FRAGMENT_SHADER, "impostor.frag"}},
                                        "#define FRACTION 1\n");
    }
    if (cloudLodApplies(s) && s.closeDownsample > 1) {  // built now, as tileClear below
        reduced = std::make_unique<ReducedTarget>();
        reduced->program(0, true), reduced->program(0, false);
    }
    if (s.reuse)  // built now: a first reuse frame that compiled it stalled
        tileClear = buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "tile_clear.frag"}});
}

// The falloff texture and the noise volume (uploaded within the constructor's HostStateScope).
void EllipsoidRenderer::Impl::makeTextures(const EllipsoidSettings& s) {
    // The projective radial falloff texture (the paper's figure 4), F(b) = (1 - b^2)^(5/2).
    constexpr int kFalloff = 256;
    std::vector<float> f(kFalloff * kFalloff);
    for (int y = 0; y < kFalloff; ++y)
        for (int x = 0; x < kFalloff; ++x) {
            const double u = (x + 0.5) / kFalloff * 2 - 1, v = (y + 0.5) / kFalloff * 2 - 1;
            f[y * kFalloff + x] = model::radialProfile(float(u * u + v * v));
        }
    falloff = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(falloff.id(), 1, GL_R32F, kFalloff, kFalloff);
    glTextureSubImage2D(falloff.id(), 0, 0, 0, kFalloff, kFalloff, GL_RED, GL_FLOAT, f.data());
    glTextureParameteri(falloff.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(falloff.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(falloff.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(falloff.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);

    noise = noiseTexture(makeNoiseVolume(s.noise));
}

EllipsoidRenderer::EllipsoidRenderer(const EllipsoidSettings& s) : settings_(s), impl_(std::make_unique<Impl>()) {
    checkSettings(s);
    Impl& m = *impl_;
    m.buildPrograms(s);
    m.empty = VertexArray::create();
    HostStateScope scope;  // the uploads below see a tightly packed pixel store whatever the host set
    m.makeTextures(s);
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

namespace {

// plan()'s first phase: the visible ellipsoids, back to front, and the close LOD's texels.
// False when none is visible (nothing to draw).
bool prepareFrame(const EllipsoidSettings& s, const Scene& scene, const View& view, bool lod, FramePlan& out) {
    EllipsoidStats& stats = out.stats;
    for (const Cloud& c : scene.clouds) stats.ellipsoids += int(c.ellipsoids.size());
    out.prepared = prepareClouds(scene, view, s.noise);
    const PreparedClouds& prepared = out.prepared;
    // The close LOD: no tile finer than its ellipsoid's image (closeTileTexels), nor, with the
    // detail, than its finest octave drawn (detailTileTexels: the detail's octaves fade by their
    // angle, so a tile finer than that on a large screen holds nothing more).
    if (lod && cloudLodApplies(s)) {
        const double noiseTexel =
            scene.medium.noise > 0 ? prepared.noisePeriod / s.noise.size : std::numeric_limits<double>::infinity();
        const Medium::Detail& detail = scene.medium.detail;
        for (PreparedEllipsoid& e : out.prepared.ellipsoids) {
            const double rMax = e.shape.maxRadius();
            e.contentTexels = closeTileTexels(rMax, noiseTexel);
            if (detail.on()) {
                const double nearest = std::max(e.projection.distance - rMax, 0.0);
                e.contentTexels = std::max(e.contentTexels, detailTileTexels(rMax, nearest, detail.smallest));
            }
        }
    }
    stats.visible = int(prepared.ellipsoids.size());
    return !prepared.ellipsoids.empty();
}

// The composite's runs: tiles of the clouds drawn as tiles (order[0, frameTiles), back to
// front) and impostors, merged back to front. `impostorOf`: per scene cloud, its index in
// out.impostors, else -1 (empty without the cloud LOD).
void makeRuns(FramePlan& out, const std::vector<int>& impostorOf, int frameTiles) {
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
}

// The composite order (GPU tile indices; `slot`: prepared index -> GPU tile index) and its runs.
// prepared.ellipsoids is back to front: that is the composite order. With impostors, the
// tiles composited over the frame first, then each fresh impostor's.
void compositeOrder(FramePlan& out, const std::vector<int>& impostorOf, const std::vector<int>& slot) {
    const PreparedClouds& prepared = out.prepared;
    std::vector<int>& order = out.order;
    if (impostorOf.empty()) {
        order = slot;
        makeRuns(out, impostorOf, int(order.size()));
        return;
    }
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
    makeRuns(out, impostorOf, frameTiles);
}

// One tile's record for the GPU: the ellipsoid, camera-relative, and the ray through each of
// its tile's clip positions (rc + x rx + y ry, returned for the reuse bookkeeping).
GpuTile gpuTile(const PreparedEllipsoid& e, const View& view, const glm::dmat4& viewRotation, Vec3& rc, Vec3& rx,
                Vec3& ry) {
    const EllipsoidProjection& p = e.projection;
    GpuTile t{};  // reproject stays zero for fresh tiles
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
    rc = nearPoint(0, 0);
    put(t.rayCentre, rc);
    rx = nearPoint(1, 0) - rc, ry = nearPoint(0, 1) - rc;
    put(t.rayX, rx);
    put(t.rayY, ry);
    return t;
}

}  // namespace

// Everything before the first draw: projection, culling, tile sizes, packing, the GPU
// tile data, the light volumes and the atlas. `plan.stats.visible == 0`: nothing to draw.
FramePlan EllipsoidRenderer::Impl::plan(const EllipsoidSettings& s, const Scene& scene, const View& view, bool reuse,
                                        bool lod) {
    Impl& m = *this;
    FramePlan out;
    out.reuse = reuse;
    if (DetailTexture::variant(scene.medium.detail) != detailVariant) {
        detailVariant = DetailTexture::variant(scene.medium.detail);  // the tile programs read it alone
        buildTilePrograms(s);
    }
    if (!prepareFrame(s, scene, view, lod, out)) return out;

    AtlasLayout a;
    a.frameW = view.camera.width, a.frameH = view.camera.height;
    a.atlasW = s.atlasWidth > 0 ? s.atlasWidth : a.frameW;
    a.atlasH = s.atlasHeight > 0 ? s.atlasHeight : a.frameH;
    a.maxTile = std::min(s.maxTile, floorPow2(std::min(a.atlasW, a.atlasH)));
    a.minTile = std::min(s.minTile, a.maxTile);
    // Without reuse one atlas per size; with it one per view size and place (a channel's tiles).
    Atlas& atlas = m.atlases.get(reuse ? glm::ivec4(a.atlasW, a.atlasH, view.origin.x, view.origin.y)
                                       : glm::ivec4(a.atlasW, a.atlasH, -1, -1));
    m.atlas = &atlas;

    // The clouds' light: grids of clouds that only moved are kept (light_cache.hpp).
    // Driven by a host's updateLights(), the grids change only there: every channel of a frame
    // draws with the same ones.
    m.updateLights(s, scene, &view.eye, m.lightsDriven, !m.lightsDriven);

    std::vector<int> impostorOf;  // per scene cloud: its index in out.impostors, else -1
    std::vector<char> keepTiles;  // per scene cloud: an impostor kept from before (its tiles stay in the atlas)
    if (lod && cloudLodApplies(s)) planImpostors(s, scene, view, out, impostorOf, keepTiles);
    if (out.prepared.ellipsoids.empty()) {  // every visible cloud an impostor kept from before
        m.lastTiles.clear();
        makeRuns(out, impostorOf, 0);
        return out;
    }

    placeTiles(s, scene, view, atlas, keepTiles, a, out);
    groupTiles(s, scene, view, out);
    const std::vector<int> slot = writeGpuTiles(view, atlas, out);
    compositeOrder(out, impostorOf, slot);
    uploadPlan(s, view, atlas, a, out);
    return out;
}

// ---- The cloud LOD: far clouds as impostors; only the tiles of those made this frame and
// of the clouds drawn as tiles go on.
void EllipsoidRenderer::Impl::planImpostors(const EllipsoidSettings& s, const Scene& scene, const View& view,
                                            FramePlan& out, std::vector<int>& impostorOf,
                                            std::vector<char>& keepTiles) {
    EllipsoidStats& stats = out.stats;
    ImpostorSettings is;
    is.distance = s.cloudLodDistance, is.maxPixels = s.cloudLodMaxPixels;
    is.atlasSize = std::max(256, int(std::bit_ceil(unsigned(s.cloudLodMaxPixels + 2))));
    is.layers = std::max(1, int(s.impostorMegabytes * 1048576.0 / (double(is.atlasSize) * is.atlasSize * 8)));
    is.errorPixels = s.cloudLodErrorPixels, is.budget = s.reuseBudget;
    CloudImpostors& ci = impostors.get({view.camera.width, view.camera.height, view.origin.x, view.origin.y});
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

// ---- Tiles: sizes, and packing (or, with reuse, which tiles are rendered again and where).
// Each pass keeps an atlas layer until the composite: past the memory budget, the
// largest tiles are halved (and the packing redone) so that memory stays bounded.
void EllipsoidRenderer::Impl::placeTiles(const EllipsoidSettings& s, const Scene& scene, const View& view, Atlas& atlas,
                                         const std::vector<char>& keepTiles, AtlasLayout& a, FramePlan& out) {
    EllipsoidStats& stats = out.stats;
    const PreparedClouds& prepared = out.prepared;
    const double layerBytes = double(a.atlasW) * a.atlasH * (s.precision == AtlasPrecision::Float16 ? 8 : 4);
    a.maxPasses = std::max(1, int(s.atlasMegabytes * 1048576.0 / layerBytes));
    a.maxLayers = 0;
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &a.maxLayers);
    std::vector<TilePlacement>& placements = out.placements;
    if (!out.reuse) {
        for (int limit = a.maxTile;; limit /= 2) {
            std::vector<TileRequest> requests;
            for (int i = 0; i < int(prepared.ellipsoids.size()); ++i) {
                requests.push_back({i, tileSizeFor(tileExtent(prepared.ellipsoids[i]), a.minTile, limit)});
            }
            out.packed = packTiles(requests, a.atlasW, a.atlasH);
            stats.maxTile = limit;
            if (out.packed.passes <= a.maxPasses || limit <= a.minTile) break;
        }
        placements = out.packed.placements;
    } else {
        ReuseSettings rs;
        rs.atlasWidth = a.atlasW, rs.atlasHeight = a.atlasH, rs.frameWidth = a.frameW, rs.frameHeight = a.frameH;
        rs.minTile = a.minTile, rs.maxTile = a.maxTile, rs.budgetLayers = a.maxPasses, rs.layers = atlas.layers;
        rs.maxLayers = std::max(1, std::min(int(a.maxLayers), std::max(4 * a.maxPasses, 64)));
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
    if (packed.passes > a.maxLayers)
        throw GlError("ellipsoid atlas: " + std::to_string(prepared.ellipsoids.size()) + " visible ellipsoids need " +
                      std::to_string(packed.passes) + " passes of " + std::to_string(a.atlasW) + "x" +
                      std::to_string(a.atlasH) + " even with " + std::to_string(a.minTile) +
                      " px tiles, more than GL's " + std::to_string(a.maxLayers) +
                      " atlas layers; give a larger atlas (--atlas) or smaller tiles (--min-tile)");
    stats.passes = packed.passes;
    stats.utilisation = packed.meanUtilisation();
}

// Mesh tiles near the sun are lit per pixel (nearTheSun). Within a pass tiles never overlap,
// so any order will do: group them by program (cut by the near plane or not, lit per pixel or
// not) and mesh level, one instanced draw per group.
void EllipsoidRenderer::Impl::groupTiles(const EllipsoidSettings& s, const Scene& scene, const View& view,
                                         FramePlan& out) {
    const PreparedClouds& prepared = out.prepared;
    out.perPixelLight.assign(prepared.ellipsoids.size(), 0);
    if (s.geometry == TileGeometry::Mesh) {
        for (std::size_t i = 0; i < prepared.ellipsoids.size(); ++i)
            out.perPixelLight[i] = nearTheSun(prepared.ellipsoids[i], view, scene) ? 1 : 0;
    }
    auto group = [&](const TilePlacement& p) {
        return drawGroup(s, prepared.ellipsoids[p.id], p.size, out.perPixelLight[p.id] != 0);
    };
    std::stable_sort(out.placements.begin(), out.placements.end(), [&](const TilePlacement& a, const TilePlacement& b) {
        return a.pass != b.pass ? a.pass < b.pass : group(a) < group(b);
    });
}

// The GPU's tile records: the tiles rendered this frame, then those composited from an earlier
// frame's image; the debug list and the stats. Returns, per prepared ellipsoid, its GPU tile.
std::vector<int> EllipsoidRenderer::Impl::writeGpuTiles(const View& view, Atlas& atlas, FramePlan& out) {
    EllipsoidStats& stats = out.stats;
    const PreparedClouds& prepared = out.prepared;
    const std::vector<TilePlacement>& placements = out.placements;
    const glm::dmat4 viewRotation = glm::lookAt(Vec3(0.0), view.forward, view.up);
    std::vector<GpuTile>& gpu = out.gpu;
    gpu.resize(placements.size() + out.reused.size());
    lastTiles.clear();
    std::vector<int> slot(prepared.ellipsoids.size());  // prepared index -> GPU tile index
    for (std::size_t k = 0; k < gpu.size(); ++k) {
        const bool fresh = k < placements.size();
        const TilePlacement& tp = fresh ? placements[k] : out.reused[k - placements.size()];
        const PreparedEllipsoid& e = prepared.ellipsoids[tp.id];
        const EllipsoidProjection& p = e.projection;
        Vec3 rc, rx, ry;
        GpuTile& t = gpu[k] = gpuTile(e, view, viewRotation, rc, rx, ry);
        if (fresh && out.reuse) atlas.reuse.rendered(tp.id, rc, rx, ry);
        t.atlasRect[0] = float(tp.x), t.atlasRect[1] = float(tp.y), t.atlasRect[2] = float(tp.size),
        t.atlasRect[3] = float(tp.pass);
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
        lastTiles.push_back(
            {{t.screenRect[0], t.screenRect[1], t.screenRect[2], t.screenRect[3]}, tp.x, tp.y, tp.size, tp.pass});
        stats.tilePixels += std::int64_t(tp.size) * tp.size;
        stats.screenPixels += std::int64_t(std::lround(p.pixelWidth * p.pixelHeight));
        if (fresh) ++stats.tilesRendered, stats.tilePixelsRendered += std::int64_t(tp.size) * tp.size;
        else ++stats.tilesReused;
    }
    return slot;
}

// ---- Resources: the tiles and the order uploaded, the light's boxes, and the atlas grown to
// the passes' layers.
void EllipsoidRenderer::Impl::uploadPlan(const EllipsoidSettings& s, const View& view, Atlas& atlas,
                                         const AtlasLayout& a, FramePlan& out) {
    uploadDynamic(tiles, tilesCapacity, out.gpu.data(), out.gpu.size() * sizeof(GpuTile));
    uploadDynamic(order, orderCapacity, out.order.data(), out.order.size() * sizeof(int));
    lightTextures.setBoxes(light, view.eye);

    const PackResult& packed = out.packed;
    atlas.width = a.atlasW;
    atlas.height = a.atlasH;
    if (atlas.layers < packed.passes) {
        const GLenum termsFormat = s.precision == AtlasPrecision::Float16 ? GL_RGBA16F : GL_RGBA8;
        // A power of two of layers, 8 at least (within the memory budget): remaking the atlas
        // stalls a frame (near clouds coming into view grow it a few layers at a time), so it is
        // made with room to grow.
        // With reuse, twice that: its tiles stay within the layers it has until a repack.
        const int room = int(std::bit_ceil(unsigned(packed.passes))) * (out.reuse ? 2 : 1);
        const int layers = std::max(packed.passes, std::min(a.maxPasses, std::max(kMinAtlasLayers, room)));
        Texture terms = Texture::create(GL_TEXTURE_2D_ARRAY);
        out.stats.atlasGrown = true;
        checkTextureSize("the ellipsoid atlas", a.atlasW, a.atlasH, 0, layers);
        glTextureStorage3D(terms.id(), 1, termsFormat, a.atlasW, a.atlasH, layers);
        checkAllocation("the ellipsoid atlas (" + std::to_string(a.atlasW) + "x" + std::to_string(a.atlasH) + ", " +
                            std::to_string(layers) + " layers)",
                        std::uint64_t(a.atlasW) * std::uint64_t(a.atlasH) * std::uint64_t(layers) *
                            (termsFormat == GL_RGBA16F ? 8 : 4));
        // (With reuse the atlas grows only when it was packed anew: no tile's image is lost.)
        if (out.reuse && !out.reused.empty()) throw std::logic_error("ellipsoid atlas: grown while tiles are reused");
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
    out.atlasW = a.atlasW;
    out.atlasH = a.atlasH;
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
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kTilesBinding, m.tiles.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kOrderBinding, m.order.id());
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
    if (!m.floor) m.floor = buildProgram({{GL_VERTEX_SHADER, "tile_quad.vert"}, {GL_FRAGMENT_SHADER, "floor.frag"}});
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kTilesBinding, m.tiles.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kOrderBinding, m.order.id());
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
