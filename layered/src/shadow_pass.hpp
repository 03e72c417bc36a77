// The cloud-shadow pass of the layered sky (Wang et al. eq. 19): internal to layered/.
#pragma once

#include "nephele/camera.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/layered.hpp"
#include "nephele/shader.hpp"
#include "reduced_target.hpp"

#include <vector>

namespace nephele {

// Why a pass over the finished frame rather than a term in the opaque pass's shaders: the
// shadow then falls on whatever the frame's depth holds (Nephele's objects, or a host
// simulator's own terrain and aircraft, whose shaders Nephele does not own), core stays free
// of any layered code, and the opaque pass and its golden images are untouched. At reduced
// resolution (LayeredSettings::downsample > 1) it is fused into the upsampling pass (dual-source
// blending), so it costs no pass of its own; at full resolution it is one full-screen pass per
// kShadowLayers (4) shadowing layers. Sky pixels are multiplied by 1.
class ShadowPass {
public:
    static constexpr int kLayersPerPass = kMaxShadowLayers;  // kShadowLayers in shaders/layered_shadow.glsl
    static constexpr int kFirstUnit = 3;                     // texture units kFirstUnit.. hold the layers' modulation

    ShadowPass();  // builds its shader in the current context
    // The scene layers that can shadow (coverage * density > 0), none without a sun above the horizon.
    static std::vector<int> shadowingLayers(const Scene& scene);
    // Sets the uniforms of shaders/layered_shadow.glsl in `program` for layers[first ..
    // first + kLayersPerPass) and binds their modulation textures (modulationTextures[scene
    // layer index]) to units kFirstUnit... Returns how many layers it took.
    static int setUniforms(const Program& program, const Scene& scene, const View& view, double timeSeconds,
                           const std::vector<int>& layers, int first, const std::vector<GLuint>& modulationTextures,
                           const ModulationSettings& modulation, double groundHeight);
    // Multiplies the rgb of the frame's viewport (alpha untouched) by the shadows of `layers`.
    // frameDepth: the frame's depth (FrameDepth::source), texture 0 when the frame has none.
    // Expects the caller to hold a HostStateScope; changes blend, depth, program, vertex array,
    // texture units 0 and kFirstUnit... Returns the draw calls issued.
    int draw(const Scene& scene, const View& view, const HostFrame& frame, const DepthSource& frameDepth,
             double timeSeconds, const std::vector<int>& layers, const std::vector<GLuint>& modulationTextures,
             const ModulationSettings& modulation, double groundHeight);

private:
    Program program_;
    gl::VertexArray empty_;
};

}  // namespace nephele
