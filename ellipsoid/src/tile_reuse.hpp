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

struct ReuseSettings {
    int atlasWidth = 0, atlasHeight = 0;  // px
    int frameWidth = 0, frameHeight = 0;  // px
    int minTile = 8, maxTile = 512;       // px, powers of two (maxTile fits the atlas)
    int budgetLayers = 1;                 // the atlas layers the memory budget allows
    int layers = 0;                       // the atlas texture's layers now: tiles stay within them between
                                          // repacks (a larger texture is made only when packing anew, when
                                          // every tile is rendered anyway, so nothing is copied)
    int maxLayers = 1;                    // the most the allocator may use (GL's limit)
    double errorPixels = 0.5;             // EllipsoidSettings::reuseErrorPixels
    double budget = 1.0;                  // EllipsoidSettings::reuseBudget
};

struct ReusePlan {
    std::vector<TilePlacement> fresh;    // tiles to render this frame (id = prepared index), largest first
    std::vector<TilePlacement> reused;   // tiles composited from their image (id = prepared index)
    std::vector<glm::mat4> reproject;    // per reused tile: tile clip (x, y, 0, 1) -> the frame's clip space
    std::vector<glm::vec4> screenRect;   // per reused tile: NDC x0, y0, x1, y1 of its reprojected quad
    int layers = 0;                      // atlas layers in use
    double utilisation = 0;              // tile area in use / the layers' area
    int maxTile = 0;                     // the largest tile size allowed this frame
    bool reset = false;                  // the atlas was packed anew (everything fresh)
    int must = 0;                        // fresh tiles that had no usable image (all of them after a reset)
};

class TileReuse {
public:
    // Decides the frame's tiles for `prepared` (the frame's visible ellipsoids) lit by `light`
    // (one grid per scene cloud). Frees the tiles of ellipsoids no longer visible. Throws
    // GlError when the visible tiles do not fit even at minTile in maxLayers layers.
    ReusePlan plan(const ReuseSettings& s, const Scene& scene, const View& view, const PreparedClouds& prepared,
                   const std::vector<PlacedRadiance>& light);
    // A fresh tile of the last plan() was rendered through tile clip (x, y) -> camera-relative
    // ray rc + x rx + y ry: what its reprojection needs.
    void rendered(int preparedIndex, const Vec3& rc, const Vec3& rx, const Vec3& ry);
    std::size_t liveTiles() const { return live_.size(); }

private:
    struct Live {
        TilePlacement place;         // its atlas place (id unused)
        std::uint64_t shape = 0;     // radii, axes, noise offset
        double sigma = 0;            // extinction * density * the cloud's weight (1/m)
        std::uint64_t light = 0;     // the grid, its placement, the sun, the medium
        Vec3 eyeFromCentre{0.0};     // eye - centre when rendered (m)
        Vec3 centre{0.0};            // m
        double pixelRadius = 0;      // half the larger side of its screen rectangle (px)
        double phase = 0;            // the sun's phase towards the eye at its centre
        Vec3 rc{0.0}, rx{0.0}, ry{0.0};
        std::uint64_t seen = 0;      // the last frame it was visible
        bool reusable = false;       // rendered wholly beyond the near plane (a cut tile cannot be reprojected)
    };
    std::unique_ptr<TileAllocator> allocator_;
    ReuseSettings allocatedFor_;
    std::unordered_map<std::uint64_t, Live> live_;
    std::vector<Live*> fresh_;       // by prepared index, the last plan's fresh tiles (else null)
    std::uint64_t frame_ = 0;
    int limit_ = 0;                  // the largest tile size, kept from frame to frame (see plan())
};

}  // namespace nephele
