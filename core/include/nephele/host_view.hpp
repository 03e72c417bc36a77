// A host image generator's view of one display channel: its own matrices (any perspective
// frustum, off-axis included), its depth convention, where the channel's viewport lies in
// its framebuffer, where its depth is, and what its colour buffer holds.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/gl.hpp"

NEPHELE_API_BEGIN
namespace nephele {

// What the colour attachment Nephele draws into holds; Nephele blends linear radiance into it.
enum class ColorTarget {
    Auto,    // a framebuffer object: asked of its attachment (component type, colour encoding); the
             // default framebuffer (a window): Unorm8, since drivers report sRGB-capable visuals as
             // sRGB whatever the window asked for (say Srgb8 for an sRGB window)
    Float,   // a float format (HDR: tone-map after Nephele)
    Unorm8,  // 8-bit linear: each blend clamps to [0, 1]
    Srgb8,   // an sRGB format: Nephele enables GL_FRAMEBUFFER_SRGB while it writes, so that
             // blending happens in linear light and the stored values are sRGB-encoded
};

struct ViewDesc {
    glm::dmat4 view{1.0};        // world -> eye (rigid, OpenGL convention: the eye looks down -z), in
                                 // double so that a simulator's world far from the origin stays exact
    glm::dmat4 projection{1.0};  // eye -> clip: any perspective frustum (glm::frustum, glm::perspective,
                                 // reversed or infinite), in the convention `depth` states
    DepthConvention depth;
    glm::ivec4 viewport{0, 0, 0, 0};  // x, y, width, height of the channel in `framebuffer` (pixels, lower left)
    GLuint framebuffer = 0;           // the host's (0 = the default framebuffer): its draw buffer `drawBuffer`
                                      // gets rgb radiance "over" and alpha accumulating the cloud opacity
    GLenum drawBuffer = GL_NONE;      // the colour attachment Nephele draws into (GL_COLOR_ATTACHMENTi of
                                      // `framebuffer`); GL_NONE: the framebuffer's draw buffer 0 as the host
                                      // set it. While Nephele draws, it is the framebuffer's only draw buffer;
                                      // the host's draw-buffer list and every draw buffer's blend state and
                                      // colour mask are restored before draw() returns
    GLuint depthTexture = 0;          // the host's depth as a single-sample 2D texture, sampled instead of a
                                      // copy of `framebuffer`'s depth (it may be that attachment itself: Nephele
                                      // never writes the host's depth); texel (x, y) = framebuffer pixel (x, y).
                                      // A multisampled depth is copied (resolved) from the framebuffer instead
    bool hasDepth = true;             // false: no depth at all (the clouds cover everything in the frame)
    bool cloudShadows = false;        // opt-in: the layers' cloud shadows multiply the colour of the frame's
                                      // surfaces (where its depth holds one) and of the empty pixels below the
                                      // horizon (taken as ground at LayeredSettings::groundHeight). Off, the
                                      // host's pixels are left as they are and the host shades its own
    ColorTarget color = ColorTarget::Auto;
};

// The View of a ViewDesc: eye, axes, frustum and near/far read from the matrices. Throws
// std::invalid_argument naming what is wrong: a view matrix that is not rigid, a projection
// that is not a perspective frustum (or whose near/far do not satisfy 0 < near < far in the
// stated convention), a viewport outside 1..16384 pixels or at a negative offset.
View makeView(const ViewDesc& desc);

// Checks the host's objects `desc` names, before anything is drawn, and throws
// std::invalid_argument naming the object and what is wrong with it: a framebuffer that is not
// a framebuffer object of the current context or is incomplete (its status named); a depth
// texture that is not a texture, not GL_TEXTURE_2D, not of a depth format, or smaller than the
// viewport. Needs a current context; raises no GL error.
void checkHostObjects(const ViewDesc& desc);

// The ColorTarget of the colour attachment `desc` draws into (desc.color unless Auto). Needs a
// current context.
ColorTarget colorTargetOf(const ViewDesc& desc);

// A ViewDesc of `view` (as made by makeView(Camera) or makeView(Camera, Frustum, ...)) drawn
// into `framebuffer` at `view.origin`: the bridge from the scene camera to the host API. The
// frame holds the scene's own sky, ground and objects, so it takes the cloud shadows as
// render() draws them (cloudShadows on).
ViewDesc viewDescOf(const View& view, GLuint framebuffer, bool hasDepth = true);

}  // namespace nephele
NEPHELE_API_END
