// The Elinas-Stuerzlinger near-cloud compositor (`--method ellipsoid`).
//
// Per frame: every visible ellipsoid is projected to a rectangle on the near plane and an
// off-axis frustum (nephele/projection.hpp); its tile size is the rectangle's pixel size
// rounded up to a power of two in [minTile, maxTile]; tiles are packed largest first,
// first fit, into the atlas (ellipsoid/src/packer.hpp), and those that do not fit go to further
// passes (one layer of the atlas array each). Per pass:
//   1. clear the layer to (T2 = D, 1, 1, T1 / D = 0);
//   2. draw the tiles' ellipsoids (one instanced draw per program and mesh level, the
//      tile's place in the atlas folded into its projection, clip distances keeping it in
//      its tile): red = T2 - T2 g by reverse-subtractive blending (g from the radial
//      falloff), alpha = I/D - T1/D by subtractive blending (I the noise-textured
//      ellipsoid), and the sun light and noise modulation in green and blue;
//   3. with colourMatrixPass, the colour-matrix pass: the layer onto itself (texture
//      barrier) through a 4x4 colour matrix that copies red / D into alpha,
//      reverse-subtractive, for all tiles in one draw: alpha = ((I - T1) - T2 (1 - g)) / D,
//      eq. (2). By default the composite applies the same matrix as it reads the atlas.
// Then every tile is composited at its screen place over the frame, in one instanced draw:
// back to front by centre distance (the paper), or weighted and order-independent (see
// EllipsoidSettings::order). Objects inside clouds: see FlyThrough.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/cloud_radiance.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/gardner.hpp"
#include "nephele/gl.hpp"
#include "nephele/scene.hpp"
#include "nephele/shader.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

enum class AtlasPrecision { Float16, Unorm8 };
// What the tile pass rasterises per ellipsoid, and so where the model is evaluated.
enum class TileGeometry {
    Mesh,     // the paper (the default): a circumscribed ellipsoid mesh drawn by its back faces,
              // Gouraud-lit (sun light and noise coordinates per vertex), the opacity per pixel
    Polygon,  // an octagon circumscribing the silhouette (the whole tile when cut by the near plane),
              // every term of the model per pixel from the pixel's ray: about 10 dB closer to
              // gardner-exact, and on llvmpipe slower (the light's grid lookups per pixel)
};
enum class FlyThrough {
    Fraction,  // an object inside an ellipsoid is covered by the fraction of the ellipsoid's
               // optical depth in front of it (beyond the paper; the default)
    Stencil,   // the paper's section 4.3: per ellipsoid a depth pass of its front faces sets the
               // stencil where the ellipsoid is in front of the object; the tile is composited there
};

struct EllipsoidSettings {
    int minTile = 8;     // px, power of two
    int maxTile = 512;   // px, power of two
    int atlasWidth = 0;  // px; 0 = the frame's size (the paper's back buffer)
    int atlasHeight = 0;
    AtlasPrecision precision = AtlasPrecision::Float16;
    bool instanced = true;  // false: the paper's one draw per ellipsoid (the baseline)
    FlyThrough flyThrough = FlyThrough::Fraction;
    TileGeometry geometry = TileGeometry::Mesh;
    int tessellation = 0;           // slices of the ellipsoid mesh (Mesh geometry); 0 = adapted to the tile size
    int atlasMegabytes = 256;       // memory for the atlas layers (one per pass, 8 bytes a pixel at f16); when
                                    // the passes need more, the largest tiles are halved until they fit
    RadianceGridSettings light;     // each cloud's radiance grid (nephele/cloud_radiance.hpp): what lights it
    bool colourMatrixPass = false;  // true: the colour matrix in a pass of its own per atlas layer (the
                                    // paper's copy); false: the composite applies it as it reads the atlas
                                    // (the same image: filtering is linear), one pass less per tile pixel
    bool falloffTexture = false;    // Mesh geometry: true reads F(b) from the paper's projective radial
                                    // texture; false evaluates the same F at the same projective
                                    // coordinates in closed form (cheaper on llvmpipe, no resampling)
    // How the tiles are composited (nephele/gardner.hpp, CompositeOrder):
    //   PerEllipsoid  the paper: whole tiles "over" the frame back to front by the distance of
    //                 their ellipsoids' centres. When the eye flies through overlapping
    //                 ellipsoids their centre distances cross and the whole view swaps which
    //                 colour is on top at once: a pop.
    //   Weighted      order-independent (McGuire & Bavoil 2013, weighted blended): per pixel
    //                 sum(w a c) and sum(w a) added, prod(1 - a) multiplied in a frame-sized
    //                 RGBA32F + R32F target, then one full-screen resolve puts colour
    //                 sum(w a c) / sum(w a) with opacity 1 - prod(1 - a) "over" the frame;
    //                 w = model::compositeWeight of the pixel's shading depth, continuous, so
    //                 nothing can pop. The same opacity as back to front; the colour a weighted
    //                 mean (renderGardnerExact with CompositeOrder::Weighted is its exact model).
    //                 The stencil fly-through (the paper's per-ellipsoid stencil) stays back to front.
    //   Moments       order-independent too, in two passes (after Munstermann et al. 2018): the
    //                 first adds each pixel's absorbance and its moments over depth (a second
    //                 RGBA32F + R32F target), the second the weighted composite with, as w, the
    //                 transmittance in front of each contribution reconstructed from them
    //                 (model::momentWeight): nearly the per-pixel order, continuous, and its
    //                 opacity the back-to-front one (renderGardnerExact with Moments is its
    //                 exact model). One more pass over the tiles' pixels than Weighted.
    //   PerPixel      not available on the GPU (std::invalid_argument).
    CompositeOrder order = CompositeOrder::PerEllipsoid;
    float weightExponent = model::kWeightExponent;  // Weighted: k of w = (tRef / tShade)^k, model::compositeWeight
    NoiseSettings noise;
    bool timings = false;  // EllipsoidStats::tilesMs and compositeMs (glFinish between the parts: slower)
    // Tiles that last (after Harris & Lastra 2001). Off: every tile rendered every frame (the
    // paper). On: a tile stays in the atlas across frames (tiles are kept per view size and
    // place, so each display channel keeps its own) and is composited again, reprojected to the
    // new view as a plane through its ellipsoid's centre facing the eye it was rendered from,
    // until its error reaches reuseErrorPixels. The error, in pixels of the current frame: the
    // ellipsoid's pixel radius times the angle the eye has moved around its centre (the parallax
    // inside it), plus its pixel radius times the relative change of its distance times its
    // largest radius over its distance (a point that far in front of the plane grows that much
    // faster; a turn of the view alone costs nothing), plus (with noise) how far the wind carried
    // it through the noise and (with the detail) how far the detail's drift moved through it;
    // also reached when the sun's phase towards the eye or the extinction
    // (a near-LOD cloud fading) has changed by more than 3%, or the tile is magnified past its
    // size. Stale tiles are rendered again worst first within reuseBudget x the frame's pixels
    // of tile area a frame, what the tiles that must be rendered (below) take counted first
    // (the worst stale one always; 0: none), so that no frame stalls when everything changes
    // at once or a cloud comes into view; a tile whose light changed (a new sun, a new grid) ranks above
    // the others and waits its turn. Always rendered, whatever the budget: tiles with nothing in
    // the atlas yet (new in view, a new shape), tiles cut by the near plane or with more of them
    // in view than they hold, and tiles whose error reached 6 x the threshold.
    bool reuse = false;
    // > 0. One pixel: the error is a bound (the rim's parallax) on soft, low-contrast content, and
    // on the cruise bench's 60 s cruise 1 px against 0.5 took the worst frame from 58.2 to 57.8 dB
    // of every tile fresh and the mean change between frames by +0.000002, and rendered a third
    // fewer tile pixels (docs/compositor.md, "Tiles that last").
    double reuseErrorPixels = 1.0;
    double reuseBudget = 1.0;  // >= 0: tile pixels a frame, in frames' pixels
    // A level of detail per cloud (after Harris & Lastra 2001; Elinas & Stuerzlinger close their
    // paper wanting impostors for far clouds). On: a cloud farther than cloudLodDistance of its
    // bounding radii, beyond the near plane and at most cloudLodMaxPixels on screen is drawn as
    // one impostor (of what is in view of it: one cut by the view's edge is made again when more
    // of it comes into view): its tiles composited back to front into an RGBA16F image
    // of its own (premultiplied), that image composited over the frame in the back-to-front
    // order by the cloud's centre, and kept across frames, reprojected as a plane through the
    // cloud's centre facing the eye it was made from, until its error reaches
    // cloudLodErrorPixels (measured as a tile's, over the whole cloud: its parallax is the
    // whole cloud's; within reuseBudget x the frame's pixels of impostor area a frame). Its
    // tiles stay in the atlas meanwhile (with reuse), so that making it again renders only
    // those that are stale. A fresh impostor is its
    // tiles' image ("over" is associative; texel for pixel), so the switch does not pop.
    // Objects in a far cloud: the share of its bounding sphere in front of the opaque depth
    // (not the tiles' per-ellipsoid fraction). Close clouds and the eye inside one: no tile is
    // rendered finer than its ellipsoid's image holds (128 texels across for its smooth part,
    // or two per texel of the noise volume across its diameter, whichever is more), however
    // large it is on screen; it is magnified onto the view as any tile. Consecutive tiles (two
    // or more, in the composite's order) each magnified at least closeDownsample times are
    // composited at 1 / closeDownsample of the view's resolution and upsampled over the frame
    // with its depth (as the layered sky's layers: core/internal/reduced_target.hpp): their image
    // holds nothing finer, and round the eye they overlap across the whole view. Only with the
    // back-to-front composite and the fraction fly-through (PerEllipsoid, FlyThrough::Fraction);
    // other settings draw every tile at its size on screen.
    bool cloudLod = false;
    int closeDownsample = 2;           // 1..4; 1: every tile composited at the view's resolution
    double cloudLodErrorPixels = 1.5;  // > 0
    double cloudLodDistance = 4;       // >= 1, in the cloud's bounding radii (kept down to 0.9 x this)
    int cloudLodMaxPixels = 512;       // 8..4096: a cloud larger on screen is drawn as tiles
    int impostorMegabytes = 32;        // >= 1: the impostor atlas (RGBA16F layers of the next power of two
                                       // above cloudLodMaxPixels; at least one); a cloud that finds no room
                                       // is drawn as tiles
};

// Whether `s` draws far clouds as impostors: cloudLod, with the composite and fly-through it
// works with (back to front, the fraction fly-through).
inline bool cloudLodApplies(const EllipsoidSettings& s) {
    return s.cloudLod && s.order == CompositeOrder::PerEllipsoid && s.flyThrough == FlyThrough::Fraction;
}

struct EllipsoidStats {
    int ellipsoids = 0;  // in the scene
    int visible = 0;     // after culling
    int passes = 0;
    int maxTile = 0;                      // the largest tile size used (below settings.maxTile when memory bound)
    int lightVolume = 0;                  // voxels per side of the light volumes used (below settings.lightVolume
                                          // when settings.lightMegabytes bounds them)
    int drawCalls = 0;                    // draws issued by the compositor for this frame
    double utilisation = 0;               // mean over passes of tile area / atlas area
    std::int64_t tilePixels = 0;          // sum of tile areas
    std::int64_t screenPixels = 0;        // sum of the tiles' screen rectangles (pixels)
    int tilesRendered = 0;                // tiles drawn in the atlas this frame (all visible without reuse)
    std::int64_t tilePixelsRendered = 0;  // their area
    int tilesReused = 0;                  // tiles composited from an earlier frame's image (reuse)
    int tilesMust = 0;                    // reuse: of tilesRendered, those with no usable image (new, cut by the near
                                          // plane, a new shape, a part come into view)
    bool atlasRepacked = false;           // reuse: the atlas was too full or fragmented and packed anew (all fresh)
    bool atlasGrown = false;              // the atlas texture was made anew with more layers this frame (a stall)
    int programsFirstDrawn = 0;           // tile programs drawn for the first time this frame: a driver may compile
                                          // at a program's first draw (llvmpipe 0.4-0.5 s each on a cold shader
                                          // cache), so every one the settings may use is drawn in the first frame
    int impostors = 0;                    // cloudLod: clouds drawn as one impostor this frame
    int impostorsRendered = 0;            // ... of those, made (again) from their tiles this frame
    int tilesDownsampled = 0;             // cloudLod: tiles composited at 1 / closeDownsample of the resolution
    int lightVolumes = 0;   // clouds' radiance grids made for this frame (new or changed clouds, a new sun or sky)
    int lightUploads = 0;   // of those (and of updateLights() before) uploaded to the GPU
    int lightPending = 0;   // grids still being made on the worker (RadianceGridSettings::background)
    int lightStandIns = 0;  // clouds lit by a stand-in meanwhile, or past the grids' memory budget
    // With EllipsoidSettings::timings, the wall time of each part (ms, gl::PartTimer); else 0.
    double tilesMs = 0;      // projection, packing, light grids and the tile passes
    double compositeMs = 0;  // the tiles composited over the frame (with the weighted resolve)
    double planMs = 0;       // CPU time of this call before its first draw (projection, packing, light
                             // grids when they changed, uploads), wall ms
};

// One tile of the last frame, for a host's debug views.
struct TileDebug {
    float screen[4] = {0, 0, 0, 0};  // the ellipsoid's screen rectangle, NDC x0, y0, x1, y1
    int atlasX = 0, atlasY = 0;      // px, the tile's corner in its atlas layer
    int size = 0;                    // px, tile side
    int pass = 0;                    // atlas layer
};

// Needs a current OpenGL 4.5 context; leaves the GL state as it found it.
class EllipsoidRenderer {
public:
    explicit EllipsoidRenderer(const EllipsoidSettings& settings = {});
    ~EllipsoidRenderer();
    EllipsoidRenderer(const EllipsoidRenderer&) = delete;
    EllipsoidRenderer& operator=(const EllipsoidRenderer&) = delete;

    const EllipsoidSettings& settings() const { return settings_; }

    // Draws the scene's ellipsoid clouds over `framebuffer` (width x height, colour
    // attachment 0 with rgb = radiance and a = cloud opacity, and the opaque objects'
    // depth in its depth attachment when `opaqueDepth` is true). Blending accumulates the
    // cloud opacity into alpha ("over").
    EllipsoidStats render(const Scene& scene, const View& view, GLuint framebuffer, bool opaqueDepth);
    // The same into a host's frame: the view's viewport and depth convention, the frame's
    // depth as the host gave it (or a copy), its sRGB encoding. frame.hasDepth is opaqueDepth.
    EllipsoidStats render(const Scene& scene, const View& view, const HostFrame& frame);
    // A host's frame loop (SkyRenderer::update() calls it once per frame, before the channels
    // draw): brings the clouds' radiance grids up to date for `scene` without waiting. Missing
    // grids (new or changed clouds, a new sun or sky) are made on a worker thread, largest on
    // screen from `eye` first, and a stand-in lights their clouds meanwhile (light_cache.hpp).
    // From then on render() never waits for a grid either. Returns how many grids it took from
    // the worker.
    int updateLights(const Scene& scene, const Vec3* eye = nullptr);
    // Waits for the worker's grids of `scene` and takes them (a loading screen, a test).
    void waitForLights(const Scene& scene);
    // The last light update's figures: grids pending on the worker, stand-ins, over budget.
    RadianceUpdateStats lightStats() const;
    // Grids queued or being made on the worker now (thread-safe: any thread may ask); at 0 the
    // next updateLights() takes every grid made.
    int pendingLights() const;

    // The light on a surface at world `point` of unit `normal` from `scene`'s sun, sky and
    // clouds, by the grids of the last render() or updateLights() of that scene: what the
    // compositor lights objects by (object_light "all"). CPU only; call it from the thread that
    // renders, not during a render() or updateLights(). Before any grid is made, the open sky and
    // the unshadowed sun.
    SurfaceLight lightAt(const Scene& scene, const Vec3& point, const Vec3& normal) const;

    // Debug views of the last render (a host's tools: `nephele fly`). The tiles, and the atlas:
    // a GL_TEXTURE_2D_ARRAY of atlasSize() with a layer per pass (at least the last frame's
    // passes; rgba = the tile pass's terms, see the top of this file; 0 before the first tile).
    const std::vector<TileDebug>& lastTiles() const;
    GLuint atlasTexture() const;
    glm::ivec3 atlasSize() const;  // width, height, layers

private:
    friend struct EllipsoidBenchHooks;  // the benches' entry points (ellipsoid/src/ellipsoid_hooks.hpp), not a host's
    struct Impl;
    EllipsoidSettings settings_;
    std::unique_ptr<Impl> impl_;
};

}  // namespace nephele
NEPHELE_API_END
