// The GL state Nephele touches, saved and restored, so that a simulator's frame is left
// exactly as the library found it (as Dear ImGui's backends do).
//
// What is covered: framebuffer bindings, viewport, scissor, enables (blend, depth, stencil, cull, scissor, polygon
// offset fill/line/point, sRGB, multisample, sample alpha-to-coverage/alpha-to-one/coverage/
// mask, colour logic op, primitive restart, rasterizer discard, program point size, depth
// clamp, dither), blend equations/functions/colour, colour/depth/stencil write masks, depth
// function and range, clip control (origin, depth mode), stencil functions and operations
// (front and back), clear values, cull face, front face, polygon mode, polygon offset,
// program, vertex array, array/element/uniform/pixel buffers, active texture unit and the
// 2D/3D/2D-array/rectangle/buffer textures and samplers of units 0..15, the pixel store
// (pack and unpack: alignment, row length, image height, skips, byte order), clip distances
// 0..7, shader storage buffer bindings 0..7. Blend enables, equations, functions and colour
// write masks are saved and restored per draw buffer (0..kDrawBuffers-1), so that a host's
// second colour target keeps its own blending. The draw-buffer lists of the host framebuffers
// Nephele draws into are restored by HostStateScope (bindFrame records them).
#pragma once

#include "nephele/api.hpp"
#include "nephele/gl.hpp"

#include <array>
#include <string>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

struct GlStateSnapshot {
    static constexpr int kUnits = 16;
    static constexpr int kDrawBuffers = 8;  // GL 4.5 guarantees at least 8 (GL_MAX_DRAW_BUFFERS)
    struct Stencil {
        GLint func, ref, valueMask, writeMask, fail, depthFail, pass;
    };

    GLint drawFramebuffer, readFramebuffer, renderbuffer;
    GLint viewport[4];
    GLint scissorBox[4];
    GLboolean depthTest, stencilTest, cullFace, scissorTest, polygonOffsetFill, polygonOffsetLine, polygonOffsetPoint,
        framebufferSrgb, multisample, sampleAlphaToCoverage, sampleAlphaToOne, sampleCoverage, sampleMask, colorLogicOp,
        primitiveRestart, rasterizerDiscard, programPointSize, depthClamp, dither;
    struct DrawBufferBlend {
        GLboolean blend;
        GLint equationRgb, equationAlpha, srcRgb, dstRgb, srcAlpha, dstAlpha;
        GLboolean colorMask[4];
    };
    std::array<DrawBufferBlend, kDrawBuffers> blend;  // per draw buffer
    GLfloat blendColor[4];
    GLboolean depthMask;
    GLint depthFunc;
    GLdouble depthRange[2];
    GLint clipOrigin, clipDepthMode;
    Stencil front, back;
    GLfloat clearColor[4];
    GLdouble clearDepth;
    GLint clearStencil;
    GLint cullFaceMode, frontFace, polygonMode[2];
    GLfloat polygonOffsetFactor, polygonOffsetUnits;
    GLint program, vertexArray, arrayBuffer, elementArrayBuffer, uniformBuffer, pixelPackBuffer, pixelUnpackBuffer,
        drawIndirectBuffer;
    GLint activeTexture;
    std::array<std::array<GLint, 5>, kUnits> textures;  // 2D, 3D, 2D array, rectangle, buffer
    std::array<GLint, kUnits> samplers;
    struct PixelStore {
        GLint alignment, rowLength, imageHeight, skipPixels, skipRows, skipImages, swapBytes, lsbFirst;
    };
    PixelStore pack, unpack;
    std::array<GLboolean, 8> clipDistance;
    GLint shaderStorageBuffer;
    struct Range {
        GLint buffer;
        GLint64 start, size;
    };
    std::array<Range, 8> shaderStorage;  // indexed bindings 0..7

    static GlStateSnapshot capture();
    void restore() const;
    // "" when equal, else one line per differing item: "blend: 1 -> 0".
    std::string differences(const GlStateSnapshot& other) const;
};

// The fixed-function state a Nephele pass starts from, whatever the host left (call it inside
// a GlStateGuard): no scissor, stencil, face culling, sRGB conversion, rasterizer discard,
// polygon offset, depth clamp, clip distances, logic op or sample coverage/alpha-to-coverage/
// mask; OpenGL's clip control (lower left, depth [-1, 1]) and depth range [0, 1]; filled
// polygons; every colour channel written; no depth writes. The depth test and blending are
// each pass's own to set.
void resetPassState();
// The pixel store for tightly packed client memory, pack and unpack (alignment 4; no row
// length, image height, skips or byte swapping), and no pixel pack/unpack buffer bound, so
// that uploads and read-backs do not see the host's settings (call it inside a GlStateGuard).
void resetPixelStore();

// Captures on construction, restores on destruction (also when an exception unwinds).
class GlStateGuard {
public:
    GlStateGuard() : saved_(GlStateSnapshot::capture()) {}
    ~GlStateGuard() { saved_.restore(); }
    GlStateGuard(const GlStateGuard&) = delete;
    GlStateGuard& operator=(const GlStateGuard&) = delete;

private:
    GlStateSnapshot saved_;
};

// How the library enters a host's frame: saves the GL state, then resets the pass state and
// the pixel store (resetPassState, resetPixelStore); restores the host's state on destruction,
// and the draw-buffer list of every host framebuffer that selectDrawBuffer changed meanwhile.
// Scopes nest (per thread); the innermost one records.
//
// GL errors the host left pending are the host's: the outermost scope takes them off the
// context on entry (so that Nephele's own checks do not report them as its own), logs each as
// a warning naming it as the host's, and sets the same errors again on exit (GL_INVALID_ENUM,
// GL_INVALID_VALUE and GL_INVALID_OPERATION are raised again by a call that must fail so; the
// log says so of any other, which GL gives no call to raise).
class HostStateScope {
public:
    HostStateScope();
    ~HostStateScope();
    HostStateScope(const HostStateScope&) = delete;
    HostStateScope& operator=(const HostStateScope&) = delete;

    // Makes `attachment` the only draw buffer of the framebuffer object `framebuffer` (bound as
    // GL_DRAW_FRAMEBUFFER), recording its draw-buffer list in the innermost scope so that it is
    // restored on that scope's exit. A host's framebuffer with several draw buffers would
    // otherwise get Nephele's output in every one of them, and dual-source blending (one draw
    // buffer at most) would fail. Throws std::logic_error outside a scope.
    static void selectDrawBuffer(GLuint framebuffer, GLenum attachment);

private:
    struct SavedDrawBuffers {
        GLuint framebuffer;
        std::array<GLenum, GlStateSnapshot::kDrawBuffers> buffers;
    };
    std::vector<GLenum> hostErrors_;  // pending on entry (outermost scope only), set again on exit
    GlStateGuard guard_;
    std::vector<SavedDrawBuffers> drawBuffers_;
    HostStateScope* outer_;
};

}  // namespace nephele
NEPHELE_API_END
