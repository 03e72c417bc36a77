#pragma once

#include "nephele/context.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/gardner.hpp"
#include "nephele/layered.hpp"
#include "nephele/sky.hpp"
#include "nephele/near_lod.hpp"
#include "nephele/noise.hpp"
#include "nephele/opaque.hpp"
#include "nephele/pathtrace.hpp"
#include "nephele/raymarch.hpp"
#include "nephele/image.hpp"
#include "nephele/scene.hpp"

#include <memory>
#include <optional>
#include <string>

namespace nephele::cli {

// Bad input: exit code 2.
class UsageError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Image sizes, per side: GL 4.5's least GL_MAX_TEXTURE_SIZE and GL_MAX_FRAMEBUFFER_WIDTH.
inline constexpr int kMaxImageSize = 16384;

enum class Method { Auto, Ellipsoid, Layered, Raymarch, Pathtrace, GardnerExact };
Method parseMethod(const std::string& name);  // throws UsageError
const char* methodName(Method m);

// A display channel of the scene camera (--frustum, --yaw-offset, --pitch-offset).
struct ChannelOptions {
    std::optional<Frustum> frustum;   // instead of the camera's fov_y
    double yawDeg = 0, pitchDeg = 0;  // the channel's rotation about the eye
};
// Throws UsageError naming the flag: --frustum must be four finite tangents L,R,B,T in
// [-100, 100] with L < R and B < T; the yaw within [-360, 360], the pitch within [-90, 90].
ChannelOptions parseChannel(const std::string& frustum, double yawDeg, double pitchDeg);
// The view of `camera` as the channel options turn and frame it (makeView(camera) without any).
View channelView(const Camera& camera, const ChannelOptions& channel);

struct RenderOptions {
    std::string scene, output, alpha, pfm, densityAlpha;
    Method method = Method::Auto;
    std::optional<int> width, height;
    std::optional<double> scale;
    double time = 0;
    ChannelOptions channel;  // --frustum, --yaw-offset, --pitch-offset
    GlBackend backend = GlBackend::Egl;
    EllipsoidSettings ellipsoid;  // --min-tile, --max-tile, --atlas, --precision, --draws, --flythrough
    RaymarchSettings raymarch;    // --step, --lod-distance, --light-grid, --octaves
    PathTraceSettings pathtrace;  // --spp, --bounces, --seed
    LayeredSettings layered;      // --layers, --lod0-radius, --lod0-spacing, --light-size, --near-radius, --blend-band
                                  // (auto: nearRadius/blendBand default to kAutoNearRadius/kAutoBlendBand)
    NearLodSettings nearLod;      // auto: the near LOD's cells
    std::string cacheDir;         // path-traced references are cached here ("" = no cache)
    CompositeOrder exactOrder = CompositeOrder::PerEllipsoid;  // gardner-exact: --exact-order
    bool silhouette = false;  // --silhouette: print the box-counting dimension of the alpha > 0.5 silhouette
};

struct Frame {
    Image color;           // RGB linear radiance
    Image alpha;           // grey, cloud opacity (1 - transmittance of cloud matter)
    EllipsoidStats stats;  // the ellipsoid compositor's, when it ran
    LayeredStats layered;  // the layered sky's, when it ran
    NearLodStats nearLod;  // auto: what the near LOD spawned
    Image densityAlpha;    // the exact opacity of the density field, when asked for
    double ms = 0;         // wall time of the GPU methods' draw, to glFinish (not the read-back)
};

// Prints the error on stderr and returns the exit code: 2 for bad input (SceneError,
// UsageError, std::invalid_argument), else 1, with "DOING failed: " before the message
// (std::bad_alloc is said as running out of memory).
int reportError(const std::exception& e, const std::string& doing);

// Renders frames with one method, keeping the GL context and renderers between frames
// (fly-throughs). Throws ContextError / GlError for runtime failures.
class FrameRenderer {
public:
    explicit FrameRenderer(const RenderOptions& options);
    ~FrameRenderer();
    // The scene at `time` (camera from its path when it has one), at the scene camera's size.
    Frame render(const Scene& scene, double time);

private:
    RenderOptions options_;
    std::unique_ptr<Context> context_;
    std::unique_ptr<FrameTarget> target_;
    std::unique_ptr<OpaquePass> opaque_;
    std::unique_ptr<EllipsoidRenderer> clouds_;
    std::unique_ptr<RaymarchRenderer> raymarch_;
    std::unique_ptr<LayeredRenderer> layered_;
    std::unique_ptr<SkyRenderer> sky_;  // auto
    NoiseVolume noise_;
    ExactLight exactLight_;  // gardner-exact: the clouds' grids, kept across the frames of a path
};

// Applies --width/--height/--scale to the scene camera (UsageError if out of range).
void applySize(Scene& scene, const RenderOptions& options);
// About the memory one frame of the scene camera's size takes with options.method (the GL
// frame, the method's targets, the read-back and the output images), in bytes.
std::uint64_t frameBytes(const Scene& scene, const RenderOptions& options);
// Throws ResourceError naming the size flags when frameBytes() is over the memory available.
void checkFrameMemory(const Scene& scene, const RenderOptions& options);
// Renders the scene at options.time with options.method. Throws UsageError for what this
// build cannot render, ContextError / GlError for runtime failures.
Frame renderFrame(const Scene& scene, const RenderOptions& options);
// The `render` command: returns the process exit code (0, 1 or 2), messages on stderr.
int runRender(const RenderOptions& options);

}  // namespace nephele::cli
