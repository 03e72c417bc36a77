// A level of detail per cloud (EllipsoidSettings::cloudLod; Harris & Lastra 2001, and Elinas &
// Stuerzlinger's own closing remark that far clouds want impostors): a far cloud is drawn as one
// impostor, its tiles composited back to front into an RGBA image of its own (premultiplied
// colour and opacity) once, then that image composited over the frame, reprojected to each new
// view as a plane through the cloud's centre facing the eye it was made from, until its error
// passes the reuse threshold. Private to the compositor.
//
// "Over" is associative: a cloud's tiles composited into its impostor and the impostor over the
// frame is the same image as its tiles over the frame one by one, when no other cloud's tile
// falls between them in the order. So a fresh impostor is its tiles' image (to the RGBA16F
// image's precision, texel for pixel), and the switch from tiles to impostor cannot pop; the
// way back shows at most the reused impostor's error. Far clouds are ordered as wholes, by the
// distance of their centres (which differs from the tiles' order only where two clouds overlap
// in depth and on screen).
#pragma once

#include "light_cache.hpp"
#include "packer.hpp"
#include "prepared_clouds.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

namespace nephele {

struct ImpostorSettings {
    double distance = 4;       // EllipsoidSettings::cloudLodDistance: in bounding radii of the cloud
    int maxPixels = 512;       // EllipsoidSettings::cloudLodMaxPixels: larger on screen: tiles
    int atlasSize = 1024;      // px, the impostor atlas's layers (square)
    int layers = 4;            // the layers the memory budget allows
    double errorPixels = 1.5;  // EllipsoidSettings::cloudLodErrorPixels
    double budget = 1.0;       // EllipsoidSettings::reuseBudget: impostor pixels made a frame, in frames' pixels
};

// One impostor of a frame.
struct ImpostorDraw {
    int cloud = 0;                         // scene.clouds index
    bool fresh = false;                    // made this frame from its tiles
    TilePlacement place{-1, -1, 0, 0, 0};  // in the impostor atlas (a square of `size` holding w x h texels)
    int px = 0, py = 0;                    // fresh: the view's pixel (lower left origin) at its image's corner
    int w = 0, h = 0;                      // texels of its image (fresh: the view's pixels it covers)
    glm::mat4 reproject{1.0f};             // image clip (x, y, 0, 1) -> the frame's clip space
    double distance = 0;                   // m, the cloud's centre: its place in the back-to-front order
    Vec3 centre{0.0};                      // m, the cloud's bounding sphere now
    double radius = 0;                     // m
};

struct ImpostorPlan {
    std::vector<char> impostor;       // per scene cloud: drawn as an impostor this frame
    std::vector<ImpostorDraw> draws;  // back to front
    int rendered = 0;                 // impostors made this frame
};

class CloudImpostors {
public:
    // Decides which of the visible clouds in `prepared` are impostors this frame, which of those
    // are made again (stale, worst first within the budget; always: new, an ellipsoid new in view
    // or changed, more of it in view than its image holds, an error of 6x the threshold), and
    // where each lives. Needs a current GL context: makes the atlas on first use.
    ImpostorPlan plan(const ImpostorSettings& s, const Scene& scene, const View& view, const PreparedClouds& prepared,
                      const std::vector<PlacedRadiance>& light);
    // The atlas (RGBA16F, a 2D array of s.layers layers of atlasSize^2) and a framebuffer per layer.
    GLuint texture() const { return texture_.id(); }
    GLuint framebuffer(int layer) const { return fbos_.at(std::size_t(layer)).id(); }
    int atlasSize() const { return atlasSize_; }
    std::size_t live() const { return live_.size(); }

private:
    struct Live {
        TilePlacement place{-1, -1, 0, 0, 0};
        std::vector<std::uint64_t> shapes;  // its ellipsoids when made (sorted fingerprints)
        std::uint64_t light = 0;
        double weight = 0;  // the cloud's weight (near-LOD fade) when made
        Vec3 eyeFromCentre{0.0}, centre{0.0};
        double phase = 0;
        Vec3 rc{0.0}, rx{0.0}, ry{0.0};  // image clip (x, y) -> camera-relative ray when made
        int w = 0, h = 0;                // texels of its image in its place
        std::uint64_t seen = 0;
        bool made = false;
    };
    // plan()'s parts (cloud_impostors.cpp).
    struct Group;
    struct Candidate;
    void makeAtlas(const ImpostorSettings& s);
    static std::vector<Group> groupClouds(const PreparedClouds& prepared, std::size_t nClouds);
    std::vector<Candidate> candidates(const ImpostorSettings& s, const Scene& scene, const View& view,
                                      const PreparedClouds& prepared, const std::vector<PlacedRadiance>& light,
                                      const std::vector<Group>& groups, std::uint64_t frame, ImpostorPlan& out);
    std::vector<char> makeImages(const ImpostorSettings& s, const View& view, const PreparedClouds& prepared,
                                 const std::vector<Group>& groups, std::vector<Candidate>& cands, ImpostorPlan& out);

    std::unique_ptr<TileAllocator> allocator_;
    gl::Texture texture_;
    std::vector<gl::Framebuffer> fbos_;
    int atlasSize_ = 0, layers_ = 0;
    std::unordered_map<std::uint64_t, Live> live_;
    std::uint64_t frame_ = 0;
};

}  // namespace nephele
