// The GL state Nephele touches, saved and restored, so that a simulator's frame is left
// exactly as the library found it (as Dear ImGui's backends do).
//
// What is covered: framebuffer bindings and draw/read buffers of the default framebuffer
// binding, viewport, scissor, enables (blend, depth, stencil, cull, scissor, polygon
// offset, sRGB, multisample, primitive restart, rasterizer discard, program point size,
// depth clamp, dither), blend equations/functions/colour, colour/depth/stencil write masks,
// depth function and range, stencil functions and operations (front and back), clear
// values, cull face, front face, polygon mode, polygon offset, program, vertex array,
// array/element/uniform/pixel buffers, active texture unit and the 2D/3D/2D-array/
// rectangle/buffer textures and samplers of units 0..15, pixel store alignment, clip
// distances 0..7, shader storage buffer bindings 0..7. Blend enables and functions are
// restored for all draw buffers alike (from draw buffer 0's state).
#pragma once

#include "nephele/gl.hpp"

#include <array>
#include <string>

namespace nephele {

struct GlStateSnapshot {
    static constexpr int kUnits = 16;
    struct Stencil { GLint func, ref, valueMask, writeMask, fail, depthFail, pass; };

    GLint drawFramebuffer, readFramebuffer, renderbuffer;
    GLint viewport[4];
    GLint scissorBox[4];
    GLboolean blend, depthTest, stencilTest, cullFace, scissorTest, polygonOffsetFill,
        framebufferSrgb, multisample, primitiveRestart, rasterizerDiscard, programPointSize,
        depthClamp, dither;
    GLint blendEquationRgb, blendEquationAlpha, blendSrcRgb, blendDstRgb, blendSrcAlpha, blendDstAlpha;
    GLfloat blendColor[4];
    GLboolean colorMask[4];
    GLboolean depthMask;
    GLint depthFunc;
    GLdouble depthRange[2];
    Stencil front, back;
    GLfloat clearColor[4];
    GLdouble clearDepth;
    GLint clearStencil;
    GLint cullFaceMode, frontFace, polygonMode[2];
    GLfloat polygonOffsetFactor, polygonOffsetUnits;
    GLint program, vertexArray, arrayBuffer, elementArrayBuffer, uniformBuffer, pixelPackBuffer,
        pixelUnpackBuffer, drawIndirectBuffer;
    GLint activeTexture;
    std::array<std::array<GLint, 5>, kUnits> textures;  // 2D, 3D, 2D array, rectangle, buffer
    std::array<GLint, kUnits> samplers;
    GLint packAlignment, unpackAlignment;
    std::array<GLboolean, 8> clipDistance;
    GLint shaderStorageBuffer;
    struct Range { GLint buffer; GLint64 start, size; };
    std::array<Range, 8> shaderStorage;                  // indexed bindings 0..7

    static GlStateSnapshot capture();
    void restore() const;
    // "" when equal, else one line per differing item: "blend: 1 -> 0".
    std::string differences(const GlStateSnapshot& other) const;
};

// The fixed-function state a Nephele pass starts from, whatever the host left (call it inside
// a GlStateGuard): no scissor, stencil, face culling, sRGB conversion, rasterizer discard,
// polygon offset or clip distances; filled polygons; every colour channel written; no depth
// writes. The depth test and blending are each pass's own to set.
void resetPassState();

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

}  // namespace nephele
