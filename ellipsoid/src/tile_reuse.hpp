// Tiles that last across frames (EllipsoidSettings::reuse, after Harris & Lastra 2001): which
// tiles of a frame are rendered and which are composited again from an earlier frame's image,
// reprojected to the new view, and where each lives in the atlas. Private to the compositor.
//
// A reused tile is drawn as a plane through its ellipsoid's centre, facing the eye it was
// rendered from, moved with the ellipsoid (wind): the tile's clip space maps onto that plane
// projectively, and the plane onto the frame by the frame's view and projection, so that one
// 4x4 matrix per tile takes a tile corner to the frame's clip space (tile_quad.vert).
#pragma once

#include "light_cache.hpp"
#include "packer.hpp"
#include "prepared_clouds.hpp"

#include "nephele/camera.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

namespace nephele {

// What makes a kept image (a tile, a cloud's impostor) stale, besides its error in pixels.
namespace reuse {
// The phase's relative change towards the eye: the single scattering is a share of a tile's
// light, so 3% of it stays below the image's 8 bits in most tiles.
constexpr double kPhaseChange = 0.03;
// The same for the extinction or a cloud's weight (a near-LOD cloud fading in or out).
constexpr double kSigmaChange = 0.03;
// An error of the geometry or the phase (not a change of extinction or of light) of this many
// times the threshold is made again whatever the budget: the budget spreads work over frames,
// but never lets an image drift this far (the approach into a cumulus fell to 33 dB from fresh
// tiles without it, 39.3 dB at 8).
constexpr double kMustError = 6;
// The priority of an image whose light changed (a new sun, a grid finished): above any
// geometric error, so that a weather change is caught up first, largest on screen first.
constexpr double kLightChanged = 1000;

// What every kept image depends on besides the view and its own light grid: the sun's
// direction, the medium and the noise's period.
std::uint64_t imageInputs(const Scene& scene, double noisePeriod);
// The sun's phase towards the eye at `centre`.
double sunPhase(const Vec3& centre, const View& view, const Scene& scene);
// The parallax an image of something of `radius` (m) and `r` pixels shows wrongly when
// reprojected as the plane through its centre: the angle the eye moved around the centre
// (eye - centre then, and now), and the change of distance (a point `radius` in front of the
// plane grows by radius / distance more than the plane). A turn of the view alone costs
// nothing: the reprojection is exact for it. Plus `drift` (m): how far the world-fixed noise and
// the detail moved through the ellipsoid (0 without either). Pixels.
double parallaxPixels(double r, const Vec3& eyeFromCentreThen, const Vec3& eyeFromCentreNow, double radius,
                      double drift);
// How far (m) an ellipsoid's surface and its light grid's box moved relative to its centre since
// its image was made: the largest displacement of a surface point (the axes' difference, a
// bound on |(A' - A) u| over unit u) or of a corner of the grid's box. A near-LOD cloud reshaped
// by a weather ramp changes a little every frame: an error like the parallax, not a new image.
double reshapeMetres(const glm::dmat3& axesThen, const glm::dmat3& axesNow, const Vec3& loThen, const Vec3& loNow,
                     const Vec3& hiThen, const Vec3& hiNow);
// How far (pixels) what is in view now, `inView`, reaches beyond a kept image's reprojected
// quad (NDC bounds, reprojectImage): more than a threshold is a part come into view.
double outsidePixels(const glm::dvec4& quad, const ScreenRect& inView, const View& view);
}  // namespace reuse

struct ReuseSettings {
    int atlasWidth = 0, atlasHeight = 0;  // px
    int frameWidth = 0, frameHeight = 0;  // px
    int minTile = 8, maxTile = 512;       // px, powers of two (maxTile fits the atlas)
    int budgetLayers = 1;                 // the atlas layers the memory budget allows
    int layers = 0;                       // the atlas texture's layers now: tiles stay within them between
                                          // repacks (a larger texture is made only when packing anew, when
                                          // every tile is rendered anyway, so nothing is copied)
    int maxLayers = 1;                    // the most the allocator may use (GL's limit)
    double errorPixels = 1.0;             // EllipsoidSettings::reuseErrorPixels
    double budget = 1.0;                  // EllipsoidSettings::reuseBudget
};

struct ReusePlan {
    std::vector<TilePlacement> fresh;   // tiles to render this frame (id = prepared index), largest first
    std::vector<TilePlacement> reused;  // tiles composited from their image (id = prepared index)
    std::vector<glm::mat4> reproject;   // per reused tile: tile clip (x, y, 0, 1) -> the frame's clip space
    std::vector<glm::vec4> screenRect;  // per reused tile: NDC x0, y0, x1, y1 of its reprojected quad
    int layers = 0;                     // atlas layers in use
    double utilisation = 0;             // tile area in use / the layers' area
    int maxTile = 0;                    // the largest tile size allowed this frame
    bool reset = false;                 // the atlas was packed anew (everything fresh)
    int must = 0;                       // fresh tiles that had no usable image (all of them after a reset)
};

// The reprojection of an image rendered from the eye at centre + eyeFromCentre, image clip
// (x, y) seen along the ray rc + x rx + y ry (camera-relative then), drawn as the plane through
// `centre` (where it is now) facing that eye: `reproject` takes image clip (x, y, 0, 1) to the
// frame's clip space (viewProj: the frame's camera-relative view-projection, eye at `eye`),
// `rect` is its quad's NDC bounds. false: the plane is edge-on or behind the eye.
bool reprojectImage(const Vec3& eyeFromCentre, const Vec3& centre, const Vec3& rc, const Vec3& rx, const Vec3& ry,
                    const glm::dmat4& viewProj, const Vec3& eye, glm::dmat4& reproject, glm::dvec4& rect);

class TileReuse {
public:
    // Decides the frame's tiles for `prepared` (the frame's visible ellipsoids) lit by `light`
    // (one grid per scene cloud). Frees the tiles of ellipsoids no longer visible. Throws
    // GlError when the visible tiles do not fit even at minTile in maxLayers layers.
    // Tiles of clouds flagged in `keep` (per scene cloud; cloud impostors kept from an earlier
    // frame) stay in the atlas although not in `prepared`: a cloud's impostor is made again
    // from them, rendering only those that are stale.
    ReusePlan plan(const ReuseSettings& s, const Scene& scene, const View& view, const PreparedClouds& prepared,
                   const std::vector<PlacedRadiance>& light, const std::vector<char>& keep = {});
    // A fresh tile of the last plan() was rendered through tile clip (x, y) -> camera-relative
    // ray rc + x rx + y ry: what its reprojection needs.
    void rendered(int preparedIndex, const Vec3& rc, const Vec3& rx, const Vec3& ry);
    std::size_t liveTiles() const { return live_.size(); }

private:
    struct Live {
        TilePlacement place;              // its atlas place (id unused)
        int cloud = -1;                   // scene.clouds index
        std::uint64_t noise = 0;          // its noise offset (another one: another image)
        glm::dmat3 axes{1.0};             // PreparedEllipsoid::axes when rendered
        Vec3 lightLo{0.0}, lightHi{0.0};  // its cloud's grid box relative to its centre (m)
        double sigma = 0;                 // extinction * density * the cloud's weight (1/m)
        std::uint64_t light = 0;          // the grid, the sun, the medium
        Vec3 eyeFromCentre{0.0};          // eye - centre when rendered (m)
        Vec3 centre{0.0};                 // m
        Vec3 detailDrift{0.0};            // Medium::Detail::drift when rendered (m)
        double phase = 0;                 // the sun's phase towards the eye at its centre
        Vec3 rc{0.0}, rx{0.0}, ry{0.0};
        std::uint64_t seen = 0;  // the last frame it was visible
        bool reusable = false;   // rendered wholly beyond the near plane (a cut tile cannot be reprojected)
    };
    struct Candidate;
    // The phases of plan(), in order.
    void beginFrame(const ReuseSettings& s, std::size_t n);
    std::vector<Candidate> candidates(const ReuseSettings& s, const Scene& scene, const View& view,
                                      const PreparedClouds& prepared, const std::vector<PlacedRadiance>& light);
    void staleness(Candidate& c, const ReuseSettings& s, const Scene& scene, const View& view,
                   const PreparedEllipsoid& e, const glm::dmat4& viewProj) const;
    void releaseUnseen(const std::vector<Candidate>& cands, const std::vector<char>& keep, std::uint64_t frame);
    static std::vector<int> chooseRenders(const ReuseSettings& s, const std::vector<Candidate>& cands, int& must);
    bool placeRenders(const ReuseSettings& s, std::vector<Candidate>& cands, std::vector<int>& render);
    void repack(const ReuseSettings& s, const PreparedClouds& prepared, std::vector<Candidate>& cands,
                std::vector<int>& render, ReusePlan& out);
    void writePlan(const Scene& scene, const View& view, const PreparedClouds& prepared,
                   const std::vector<Candidate>& cands, const std::vector<int>& render, std::uint64_t frame,
                   ReusePlan& out);

    std::unique_ptr<TileAllocator> allocator_;
    ReuseSettings allocatedFor_;
    std::unordered_map<std::uint64_t, Live> live_;
    std::vector<Live*> fresh_;  // by prepared index, the last plan's fresh tiles (else null)
    std::uint64_t frame_ = 0;
    int limit_ = 0;  // the largest tile size, kept from frame to frame (see plan())
};

}  // namespace nephele
