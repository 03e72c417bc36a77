// The compositor's private parts, shared by its passes: the per-frame plan, the GPU tile
// record and the renderer's state (nephele/ellipsoid.hpp is the public face). compositor.cpp
// plans a frame; tile_pass.cpp draws the tiles into the atlas; composite_pass.cpp composites them
// over the frame (back to front, weighted, or the paper's stencil fly-through).
#pragma once

#include "nephele/ellipsoid.hpp"

#include "nephele/gardner_model.hpp"
#include "prepared_clouds.hpp"
#include "nephele/frame_depth.hpp"
#include "object_light_pass.hpp"
#include "cloud_impostors.hpp"
#include "cloud_light_textures.hpp"
#include "detail_texture.hpp"
#include "light_cache.hpp"
#include "packer.hpp"
#include "tile_reuse.hpp"
#include "nephele/per_view.hpp"
#include "reduced_target.hpp"

#include <map>
#include <set>
#include <memory>
#include <string>
#include <vector>

namespace nephele {

using namespace gl;

// Mirrors `struct Tile` of shaders/tiles.glsl (std430: vec4 and mat4 only).
struct GpuTile {
    float centerSigma[4];
    float axes[3][4];
    float unit[3][4];
    float eyeUnitAc[4];
    float tileViewProj[16];
    float atlasRect[4];
    float screenRect[4];
    float params[4];
    float noiseOffset[4];
    float rayCentre[4];
    float rayX[4];
    float rayY[4];
    float skyChroma[4];
    float reproject[16];  // reused tiles (params.z = 1): tile clip (x, y, 0, 1) -> the frame's clip space
};
static_assert(sizeof(GpuTile) == 16 * 16 + 2 * 64);

inline void put(float* out, const Vec3& v, double w = 0) {
    out[0] = float(v.x), out[1] = float(v.y), out[2] = float(v.z), out[3] = float(w);
}

// An ellipsoid whose optical depth through its centre along its shortest axis passes this is
// lit by a skin thinner than its mesh's vertices are apart: real cumulus (dense_cumulus.json's
// ellipsoids, 28-80), not cumulus27 (3-10).
inline constexpr double kThickOpticalDepth = 16;
inline bool opticallyThick(const PreparedEllipsoid& e) {
    return 16.0 / 15.0 * e.sigma * std::min({e.shape.radii.x, e.shape.radii.y, e.shape.radii.z}) > kThickOpticalDepth;
}

inline int meshSlices(const EllipsoidSettings& s, int tileSize, bool thick = false) {
    if (s.tessellation > 0) return s.tessellation;
    // An optically thick ellipsoid's light turns from its lit to its dark side faster than 8
    // slices follow: twice the slices, at least 16 (dense cumulus at 160 px against the path
    // tracer, 64^3 grids: 15.8% at 8 slices, 11.9% at 16, 11.3% at 64 or lit per pixel).
    if (thick) return std::max(16, 2 * meshSlices(s, tileSize));
    // Vertex work is a large share of a frame on llvmpipe (the light volume is read per vertex):
    // 8 slices up to 64 px tiles (was 32) took 1024 ellipsoids at 1280x720 from 2.1-2.25x to
    // 1.9-2.0x the floor, 3-4 dB further from gardner-exact (48 against 52 dB on cumulus27 at
    // 800 px), no visible change, and no pop at the tile jumps (FailureCaseGLTest). 6 slices
    // for small tiles was faster still but popped at the 32 -> 64 px jump.
    return tileSize <= 64 ? 8 : tileSize <= 256 ? 16 : 32;
}

// Tiles of one pass are drawn in groups, one instanced draw each: by program (cut by the
// near plane: + 1000; a mesh tile lit per pixel, drawn as a polygon tile: 2000) and, for
// meshes, mesh level (slices).
inline int drawGroup(const EllipsoidSettings& s, const PreparedEllipsoid& e, int tileSize, bool perPixelLight) {
    // A tile of the close LOD, smaller than its ellipsoid on screen, keeps the mesh of its size
    // on screen: the vertices its light needs there.
    const double screen = std::max(e.projection.pixelWidth, e.projection.pixelHeight);
    if (e.contentTexels < screen) tileSize = std::max(tileSize, int(std::min(screen, 4096.0)));
    if (e.projection.crossesNear)
        return 1000 + (s.geometry == TileGeometry::Mesh ? meshSlices(s, tileSize, opticallyThick(e)) : 0);
    if (s.geometry == TileGeometry::Polygon) return 0;
    return perPixelLight ? 2000 : meshSlices(s, tileSize, opticallyThick(e));
}

struct FramePlan {
    PreparedClouds prepared;
    PackResult packed;
    std::vector<TilePlacement> placements;  // by pass, then mesh level
    std::vector<GpuTile> gpu;               // parallel to placements
    std::vector<int> order;                 // GPU tile indices, back to front
    std::vector<char> perPixelLight;        // per prepared ellipsoid: mesh tiles lit per pixel (near the sun)
    std::vector<TilePlacement> reused;      // reuse: tiles composited from an earlier frame (after placements in gpu)
    std::vector<glm::mat4> reproject;       // per reused tile (tile_reuse.hpp)
    std::vector<glm::vec4> reusedRect;      // per reused tile: its quad's NDC bounds
    bool reuse = false;                     // placements share their layers with reused tiles: clear tile by tile
    // The cloud LOD (EllipsoidSettings::cloudLod): the frame's impostors, back to front; the
    // fresh ones' tiles are order[impostorFirst[k], + impostorCount[k]) (after the frame's own).
    std::vector<ImpostorDraw> impostors;
    std::vector<int> impostorFirst, impostorCount;  // per impostor (fresh ones only: count > 0)
    CloudImpostors* impostorAtlas = nullptr;
    // The composite over the frame, back to front: runs of tiles in `order` and impostors.
    struct Run {
        int first = 0, count = 0, impostor = -1;
    };
    std::vector<Run> runs;
    int atlasW = 0, atlasH = 0;
    EllipsoidStats stats;
};

struct EllipsoidRenderer::Impl {
    FramePlan plan(const EllipsoidSettings& s, const Scene& scene, const View& view, bool reuse, bool lod = true);
    // The constructor's parts (compositor.cpp).
    void buildPrograms(const EllipsoidSettings& s);
    // The tile programs, which read the detail: for the variant `detailVariant` (DetailTexture::defines).
    void buildTilePrograms(const EllipsoidSettings& s);
    DetailTexture::Variant detailVariant = DetailTexture::Variant::Off;
    void makeTextures(const EllipsoidSettings& s);

    Program tileClear;  // reuse: a fresh tile's rectangle cleared in a layer that keeps other tiles
    Program tile, tileCut, tileRay, tileRayCut, colourMatrix, composite, compositeFraction, screenDepth, floor;
    Program compositeWeighted, compositeWeightedFraction, resolve;  // CompositeOrder::Weighted and Moments
    Program compositeMoments, compositeMomentsFraction;             // CompositeOrder::Moments: its first pass
    Program impostor, impostorFraction;                             // cloudLod: an impostor over the frame
    std::unique_ptr<ReducedTarget> reduced;  // cloudLod: close tiles at 1 / closeDownsample (made with the renderer)
    PerViewCache<CloudImpostors, glm::ivec4> impostors;  // cloudLod: per view size and place
    VertexArray empty;
    std::map<int, IndexedMesh> meshes;  // by slices
    Texture falloff, noise;
    Sampler linearClamp;
    CloudRadianceCache lightCache;      // the clouds' radiance grids
    CloudLightTextures lightTextures;   // ... on the GPU
    DetailTexture detail;               // medium.detail's texture
    std::vector<PlacedRadiance> light;  // updateLights(): the scene clouds' grids, one each
    Buffer tiles, order;
    std::size_t tilesCapacity = 0, orderCapacity = 0;
    std::vector<TileDebug> lastTiles;  // the last plan's tiles (debug views)

    // object_light "all": the scene's objects drawn again over their own depth, lit by the sun
    // through the clouds, the sky and the clouds' grids (object_pass.cpp).
    ObjectLightPass objectLight;
    void drawLitObjects(const Scene& scene, const View& view, const HostFrame& frame);

    int lightUploads = 0;            // grids uploaded since the last render (stats)
    int lightsComputed = 0;          // grids made since the last render (stats)
    RadianceUpdateStats lightStats;  // the last update's
    bool lightsDriven = false;       // a host calls updateLights(): render() never waits for a grid
    void updateLights(const EllipsoidSettings& s, const Scene& scene, const Vec3* eye, bool background,
                      bool takeFinished = true);

    // The atlas: one layer per pass; one per atlas size (the frame's by default), kept; with
    // reuse one per view size and place (each display channel keeps its own tiles).
    struct Atlas {
        Texture terms;  // rgba: T2 (1 - g), sun light, sky light (each times the noise modulation), eq. (2)
        int width = 0, height = 0, layers = 0;
        std::vector<Framebuffer> fbos;
        TileReuse reuse;  // EllipsoidSettings::reuse: the tiles that live in it
    };
    PerViewCache<Atlas, glm::ivec4> atlases;
    Atlas* atlas = nullptr;  // plan()'s

    // plan()'s phases after the projection (compositor.cpp), in the order it runs them.
    struct AtlasLayout {
        int frameW = 0, frameH = 0, atlasW = 0, atlasH = 0, minTile = 0, maxTile = 0;
        int maxPasses = 0;    // atlas layers within the memory budget (placeTiles)
        GLint maxLayers = 0;  // GL's limit (placeTiles)
    };
    void planImpostors(const EllipsoidSettings& s, const Scene& scene, const View& view, FramePlan& out,
                       std::vector<int>& impostorOf, std::vector<char>& keepTiles);
    void placeTiles(const EllipsoidSettings& s, const Scene& scene, const View& view, Atlas& atlas,
                    const std::vector<char>& keepTiles, AtlasLayout& a, FramePlan& out);
    void groupTiles(const EllipsoidSettings& s, const Scene& scene, const View& view, FramePlan& out);
    std::vector<int> writeGpuTiles(const View& view, Atlas& atlas, FramePlan& out);
    void uploadPlan(const EllipsoidSettings& s, const View& view, Atlas& atlas, const AtlasLayout& a, FramePlan& out);

    PerViewCache<FrameDepth> depths;  // copies of the frame's depth (fraction mode), by view size
    // The weighted composite's frame-sized target: sum(w a c), sum(w a) and prod(1 - a).
    struct WeightedTarget {
        Texture accum, reveal;
        Framebuffer fbo;
        Texture sums, zero;  // CompositeOrder::Moments: the first pass's A (z, z^2, z^3, z^4) and A
        Framebuffer moments;
    };
    PerViewCache<WeightedTarget> weightedTargets;

    // A frame-sized RGBA32F + R32F pair as the two colour attachments of one framebuffer.
    static void makeFloatTargets(Texture& rgba, Texture& r, Framebuffer& fbo, int w, int h, const std::string& what) {
        rgba = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(rgba.id(), 1, GL_RGBA32F, w, h);
        checkAllocation(what + "'s RGBA32F target", std::uint64_t(w) * std::uint64_t(h) * 16);
        r = Texture::create(GL_TEXTURE_2D);
        glTextureStorage2D(r.id(), 1, GL_R32F, w, h);
        checkAllocation(what + "'s R32F target", std::uint64_t(w) * std::uint64_t(h) * 4);
        fbo = Framebuffer::create();
        glNamedFramebufferTexture(fbo.id(), GL_COLOR_ATTACHMENT0, rgba.id(), 0);
        glNamedFramebufferTexture(fbo.id(), GL_COLOR_ATTACHMENT1, r.id(), 0);
        const GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
        glNamedFramebufferDrawBuffers(fbo.id(), 2, buffers);
        checkFramebuffer(fbo.id(), what + "'s target");
    }
    WeightedTarget& weightedTarget(int w, int h) {
        WeightedTarget& t = weightedTargets.get({w, h});
        // 32-bit floats: the weights span (tRef / t)^k over the whole depth range (half floats
        // would underflow beyond a few km), and the product of many (1 - a) keeps its precision.
        if (!t.fbo) makeFloatTargets(t.accum, t.reveal, t.fbo, w, h, "the weighted composite");
        return t;
    }
    // The moment composite's first target (32-bit floats: the paper's bias is for them).
    WeightedTarget& momentTarget(int w, int h) {
        WeightedTarget& t = weightedTarget(w, h);
        if (!t.moments) makeFloatTargets(t.sums, t.zero, t.moments, w, h, "the moment composite");
        return t;
    }

    const IndexedMesh& mesh(int slices);  // the circumscribed sphere of `slices` (made once)

    // The passes of a frame, after plan(): the tiles into the atlas (tile_pass.cpp), then the
    // atlas over the frame (composite_pass.cpp). Each adds its draws to `stats`.
    void drawTiles(const EllipsoidSettings& s, const FramePlan& plan, const Scene& scene, const View& view,
                   EllipsoidStats& stats);
    // drawTiles()'s parts (tile_pass.cpp): the programs' uniforms, then per pass its layer
    // cleared, its tiles drawn, and the colour-matrix copy.
    void setTileUniforms(const EllipsoidSettings& s, const FramePlan& plan, const Scene& scene, const View& view);
    void clearTilePass(const FramePlan& plan, int pass, int first, int count, EllipsoidStats& stats);
    void drawTilePass(const EllipsoidSettings& s, const FramePlan& plan, int first, int count, EllipsoidStats& stats);
    void colourMatrixPass(int first, int count, EllipsoidStats& stats);
    void tileDrawState(const EllipsoidSettings& s);
    bool drawGroupInstances(const EllipsoidSettings& s, int key, int base, int instances);
    int warmTilePrograms(const EllipsoidSettings& s, const FramePlan& plan);
    // The tile programs built last that have been drawn with (EllipsoidStats::programsFirstDrawn);
    // empty until warmTilePrograms() has drawn them all.
    std::set<GLuint> drawnTilePrograms;
    void compositeTiles(const EllipsoidSettings& s, const FramePlan& plan, const Scene& scene, const View& view,
                        const HostFrame& frame, EllipsoidStats& stats);
    // compositeTiles() by order: "over" back to front, weighted (into its target, then resolved),
    // or the paper's stencil fly-through; `cp` is the composite program, its uniforms set.
    void overPass(const EllipsoidSettings& s, const FramePlan& plan, const View& view, const HostFrame& frame,
                  const Program& cp, const DepthSource& depth, EllipsoidStats& stats);
    void weightedPass(const EllipsoidSettings& s, const FramePlan& plan, const View& view, const HostFrame& frame,
                      const Program& cp, const Program* momentsPass, EllipsoidStats& stats);
    // cloudLod: the fresh impostors made from their tiles (cp: the composite without fraction).
    void makeImpostors(const EllipsoidSettings& s, const FramePlan& plan, const View& view, const Program& cp,
                       EllipsoidStats& stats);
    void drawImpostor(const FramePlan& plan, const View& view, const ImpostorDraw& d, bool fraction,
                      EllipsoidStats& stats);
    void stencilPass(const EllipsoidSettings& s, const FramePlan& plan, const View& view, const HostFrame& frame,
                     const Program& cp, EllipsoidStats& stats);
};

// The cloud LOD's close tiles composited at a reduced resolution (EllipsoidSettings::
// closeDownsample): order[first, + count), consecutive tiles each magnified at least `divisor`
// times on screen, and the rectangle of the view they cover (px: x0, y0, x1, y1).
struct CloseRun {
    int first = 0, count = 0;
    glm::ivec4 rect{0};
};
// Such runs (two tiles or more) among the tiles order[first, + count) of a view of width x height.
std::vector<CloseRun> closeRuns(const FramePlan& plan, int first, int count, int width, int height, int divisor);

// The colour matrix (section 3.5): red / D -> alpha, what the colour-matrix pass subtracts.
inline glm::mat4 colourMatrix() {
    glm::mat4 m(0.0f);
    m[0][3] = 1.0f / model::kTranslucence;  // column 0 (red) -> row 3 (alpha)
    return m;
}

}  // namespace nephele
