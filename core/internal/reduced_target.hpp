// Drawing at a reduced resolution, upsampled over the frame with the frame's depth: the layered
// sky's layers (LayeredSettings::downsample) and the compositor's close tiles magnified on
// screen (EllipsoidSettings::closeDownsample). For the libraries' use, not a host's.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/per_view.hpp"
#include "nephele/shader.hpp"

#include <string>

NEPHELE_API_BEGIN
namespace nephele {

// llvmpipe runs a fragment shader to its end whatever it discards, so the layers cost their
// covered pixels times N times the whole shader: drawing them at 1/d of the resolution divides
// that by d^2. The frame's depth is reduced per d x d block to its farthest value (so that the
// layers are computed wherever any pixel of the block sees past the objects); the upsampling
// takes, per full-resolution pixel, the bilinear neighbours whose block depth matches its own
// (nearest-depth upsampling), so that an object's silhouette stays sharp.
// The layers one shadow pass (or one fused upsampling) shadows at most: the size of the sampler
// and uniform arrays of shaders/layered_shadow.glsl, given to it as SHADOW_SLOTS.
inline constexpr int kMaxShadowLayers = 4;
inline std::string shadowSlotsDefine() { return "#define SHADOW_SLOTS " + std::to_string(kMaxShadowLayers) + "\n"; }

// Reuse of the reduced image across frames (ReducedTarget::reuse): what the caller knows of
// this frame's change.
struct ReuseFrame {
    int period = 8;       // every reduced pixel is drawn afresh at least every `period` frames (1: always)
    double maxError = 2;  // reduced px: a reused pixel's accumulated bound past which it is drawn afresh
    glm::dvec3 drift{0};  // m the drawn matter moved since the last frame (the wind's), in the world
    double nearest = 1;   // m: the nearest distance matter may have where the last frame drew none
    // reduced px: what the weather's step since the last frame adds to every kept texel's bound
    double weatherError = 0;
    bool invalidate = false;  // what was drawn no longer holds (new matter, a jump): every pixel afresh
};

class ReducedTarget {
public:
    ReducedTarget();  // builds its shaders in the current context
    // Binds a (width/d) x (height/d) target for the view's viewport (premultiplied RGBA16F
    // cleared to 0, depth = the frame's depth reduced per block, in the view's convention; the
    // far plane without depth) as the draw framebuffer and sets the viewport to it. Changes
    // depth, blend, colour mask, scissor, program, vertex array, texture unit 0. Returns its size.
    // With `reuse`, the target keeps its image from one begin() to the next (two sets of
    // textures, swapped), and the same pass that reduces the depth keeps what it can of the last
    // image (when there is one, reuse->period > 1 and not reuse->invalidate): a texel whose turn
    // of `period` has not come (8x8 blocks in a 4x4 Bayer order, so each frame's share is spread
    // over the image), whose block of the frame holds no surface now and did not then, that falls
    // inside the last image and whose bound (how far the eye's sideways move has turned its
    // view, plus reuse->weatherError each frame, accumulated) is within reuse->maxError takes
    // the last image's colour at the point it shows, reprojected by its mean distance as a world
    // point moved by reuse->drift, and the near plane's depth, which the draws that follow fail
    // against (llvmpipe then skips their shading); the others get 0 and their depth. The draws
    // write, besides the colour, the weights of their distance to the eye at colour attachment 1
    // (premultiplied "over" like the colour: (a d, a d^2, 0, a), d in km, at most 250: RGBA16F).
    glm::ivec2 begin(const DepthSource& frameDepth, const View& view, int divisor, const ReuseFrame* reuse = nullptr);
    // Whether this frame's begin() kept texels of the last image.
    bool reused() const { return reused_; }
    // The texels the last frame that reused kept, known without waiting for the GPU (-1: not
    // known: none yet, or not finished), of size().x * size().y.
    long long lastReusedPixels() const { return current_ ? current_->lastReused : -1; }
    glm::ivec2 size() const { return size_; }
    // After begin() (and composite()): binds the target's colour again (without its depth, which
    // a pass may then read through depth()) cleared to 0 within `rect` (reduced px: x0, y0, x1,
    // y1), the scissor left on that rectangle, depth test off. Changes the same state as begin().
    void resume(const glm::ivec4& rect);
    // The reduced depth (the target's, at its own origin): what a pass drawing into the target
    // reads as the frame's depth (setViewFrameUniforms with a viewport at 0). With reuse, a kept
    // texel holds the near plane's depth.
    DepthSource depth() const;
    // Composites the target "over" the frame's viewport (premultiplied) at full resolution, the
    // frame multiplied by the cloud shadows set in program(shadowLayers, frameDepth.texture != 0)
    // (the layered sky's ShadowPass::
    // setUniforms; none when shadowLayers is 0) before; within `rect` (px of the view: x0, y0,
    // x1, y1) when given. Changes the same state as begin() and texture units 0..2.
    // shadowLayers: how many layers program(shadowLayers) was given (0..4).
    void composite(const HostFrame& frame, const DepthSource& frameDepth, const View& view, int shadowLayers,
                   const glm::ivec4* rect = nullptr);
    // The upsampling program compiled for `shadowLayers` shadowing layers (0..4) and a frame with
    // depth or without (built on first use, or by prepare()).
    const Program& program(int shadowLayers, bool depth);
    void prepare();  // builds every upsampling program now

private:
    struct Images {
        gl::Texture color, depth, moments;  // moments: with history only
    };
    struct Target {        // at one reduced size (views of several sizes each keep theirs)
        Images images[2];  // [current]: this frame's; the other: the last frame's (history)
        int current = 0;
        gl::Texture& color() { return images[current].color; }
        gl::Texture& depth() { return images[current].depth; }
        gl::Framebuffer fbo;
        gl::Framebuffer colorOnly;  // resume()'s: the colour alone
        bool drawn = false;  // images[current] holds a frame begun with reuse, drawn from `eye` with `rotationVP`
        glm::dmat4 rotationVP{1}, lastRotationVP{1};  // view-projection with the eye at the origin
        glm::dvec3 eye{0}, lastEye{0};
        long long frames = 0;      // frames begun with history: whose turn it is to be drawn afresh
        gl::Buffer keptCounters;   // the texels kept, summed in kKeptCounters counters (little contention)
        GLsync counted = nullptr;  // when they are final
        Target() = default;
        Target(const Target&) = delete;
        Target& operator=(const Target&) = delete;
        ~Target() {
            if (counted) gl::glDeleteSync(counted);
        }
        bool countPending = false;
        long long lastReused = -1;
    };
    static constexpr int kKeptCounters = 64;
    static constexpr GLuint kKeptBinding = 0;  // the storage block "Kept" of reduced_depth.frag with REUSE
    void setReuseUniforms(const Program& p, Target& t, const View& view, const ReuseFrame& frame, bool haveLast);
    static void readKeptCount(Target& t);
    static void attachImages(Target& t, bool history);
    Program reduce_, reduceReuse_[2], upsample_[kMaxShadowLayers + 1][2];
    bool reused_ = false;
    gl::VertexArray empty_;
    PerViewCache<Target> targets_;
    Target* current_ = nullptr;  // begin()'s
    glm::ivec2 size_{0}, full_{0};
};

}  // namespace nephele
NEPHELE_API_END
