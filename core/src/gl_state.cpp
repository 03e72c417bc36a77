#include "nephele/gl_state.hpp"

#include "nephele/log.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace nephele {
using namespace gl;

namespace {
constexpr GLenum kTargets[5] = {GL_TEXTURE_2D, GL_TEXTURE_3D, GL_TEXTURE_2D_ARRAY, GL_TEXTURE_RECTANGLE,
                                GL_TEXTURE_BUFFER};
constexpr GLenum kBindings[5] = {GL_TEXTURE_BINDING_2D, GL_TEXTURE_BINDING_3D, GL_TEXTURE_BINDING_2D_ARRAY,
                                 GL_TEXTURE_BINDING_RECTANGLE, GL_TEXTURE_BINDING_BUFFER};
GLint geti(GLenum e) {
    GLint v = 0;
    glGetIntegerv(e, &v);
    return v;
}
GLint getii(GLenum e, GLuint i) {
    GLint v = 0;
    glGetIntegeri_v(e, i, &v);
    return v;
}
void enable(GLenum cap, GLboolean on) { on ? glEnable(cap) : glDisable(cap); }

// The pixel store parameters in the order of GlStateSnapshot::PixelStore.
constexpr GLenum kPack[8] = {GL_PACK_ALIGNMENT, GL_PACK_ROW_LENGTH,  GL_PACK_IMAGE_HEIGHT, GL_PACK_SKIP_PIXELS,
                             GL_PACK_SKIP_ROWS, GL_PACK_SKIP_IMAGES, GL_PACK_SWAP_BYTES,   GL_PACK_LSB_FIRST};
constexpr GLenum kUnpack[8] = {GL_UNPACK_ALIGNMENT,   GL_UNPACK_ROW_LENGTH, GL_UNPACK_IMAGE_HEIGHT,
                               GL_UNPACK_SKIP_PIXELS, GL_UNPACK_SKIP_ROWS,  GL_UNPACK_SKIP_IMAGES,
                               GL_UNPACK_SWAP_BYTES,  GL_UNPACK_LSB_FIRST};
GlStateSnapshot::PixelStore capturePixelStore(const GLenum (&names)[8]) {
    GlStateSnapshot::PixelStore p{};
    GLint* v = &p.alignment;
    for (int i = 0; i < 8; ++i) v[i] = geti(names[i]);
    return p;
}
void restorePixelStore(const GLenum (&names)[8], const GlStateSnapshot::PixelStore& p) {
    const GLint* v = &p.alignment;
    for (int i = 0; i < 8; ++i) glPixelStorei(names[i], v[i]);
}
}  // namespace

namespace {

// The framebuffers, viewport and scissor, capabilities, blending, depth, stencil, clear values and
// rasterisation state, in GlStateSnapshot's order.
void captureFixedFunction(GlStateSnapshot& s) {
    s.drawFramebuffer = geti(GL_DRAW_FRAMEBUFFER_BINDING);
    s.readFramebuffer = geti(GL_READ_FRAMEBUFFER_BINDING);
    s.renderbuffer = geti(GL_RENDERBUFFER_BINDING);
    glGetIntegerv(GL_VIEWPORT, s.viewport);
    glGetIntegerv(GL_SCISSOR_BOX, s.scissorBox);
    s.depthTest = glIsEnabled(GL_DEPTH_TEST);
    s.stencilTest = glIsEnabled(GL_STENCIL_TEST);
    s.cullFace = glIsEnabled(GL_CULL_FACE);
    s.scissorTest = glIsEnabled(GL_SCISSOR_TEST);
    s.polygonOffsetFill = glIsEnabled(GL_POLYGON_OFFSET_FILL);
    s.polygonOffsetLine = glIsEnabled(GL_POLYGON_OFFSET_LINE);
    s.polygonOffsetPoint = glIsEnabled(GL_POLYGON_OFFSET_POINT);
    s.framebufferSrgb = glIsEnabled(GL_FRAMEBUFFER_SRGB);
    s.multisample = glIsEnabled(GL_MULTISAMPLE);
    s.sampleAlphaToCoverage = glIsEnabled(GL_SAMPLE_ALPHA_TO_COVERAGE);
    s.sampleAlphaToOne = glIsEnabled(GL_SAMPLE_ALPHA_TO_ONE);
    s.sampleCoverage = glIsEnabled(GL_SAMPLE_COVERAGE);
    s.sampleMask = glIsEnabled(GL_SAMPLE_MASK);
    s.colorLogicOp = glIsEnabled(GL_COLOR_LOGIC_OP);
    s.primitiveRestart = glIsEnabled(GL_PRIMITIVE_RESTART);
    s.rasterizerDiscard = glIsEnabled(GL_RASTERIZER_DISCARD);
    s.programPointSize = glIsEnabled(GL_PROGRAM_POINT_SIZE);
    s.depthClamp = glIsEnabled(GL_DEPTH_CLAMP);
    s.dither = glIsEnabled(GL_DITHER);
    for (GLuint i = 0; i < GLuint(GlStateSnapshot::kDrawBuffers); ++i) {
        GlStateSnapshot::DrawBufferBlend& b = s.blend[i];
        b.blend = glIsEnabledi(GL_BLEND, i);
        b.equationRgb = getii(GL_BLEND_EQUATION_RGB, i);
        b.equationAlpha = getii(GL_BLEND_EQUATION_ALPHA, i);
        b.srcRgb = getii(GL_BLEND_SRC_RGB, i);
        b.dstRgb = getii(GL_BLEND_DST_RGB, i);
        b.srcAlpha = getii(GL_BLEND_SRC_ALPHA, i);
        b.dstAlpha = getii(GL_BLEND_DST_ALPHA, i);
        glGetBooleani_v(GL_COLOR_WRITEMASK, i, b.colorMask);
    }
    glGetFloatv(GL_BLEND_COLOR, s.blendColor);
    glGetBooleanv(GL_DEPTH_WRITEMASK, &s.depthMask);
    s.depthFunc = geti(GL_DEPTH_FUNC);
    glGetDoublev(GL_DEPTH_RANGE, s.depthRange);
    s.clipOrigin = geti(GL_CLIP_ORIGIN);
    s.clipDepthMode = geti(GL_CLIP_DEPTH_MODE);
    s.front = {geti(GL_STENCIL_FUNC),           geti(GL_STENCIL_REF),  geti(GL_STENCIL_VALUE_MASK),
               geti(GL_STENCIL_WRITEMASK),      geti(GL_STENCIL_FAIL), geti(GL_STENCIL_PASS_DEPTH_FAIL),
               geti(GL_STENCIL_PASS_DEPTH_PASS)};
    s.back = {geti(GL_STENCIL_BACK_FUNC),           geti(GL_STENCIL_BACK_REF),  geti(GL_STENCIL_BACK_VALUE_MASK),
              geti(GL_STENCIL_BACK_WRITEMASK),      geti(GL_STENCIL_BACK_FAIL), geti(GL_STENCIL_BACK_PASS_DEPTH_FAIL),
              geti(GL_STENCIL_BACK_PASS_DEPTH_PASS)};
    glGetFloatv(GL_COLOR_CLEAR_VALUE, s.clearColor);
    glGetDoublev(GL_DEPTH_CLEAR_VALUE, &s.clearDepth);
    s.clearStencil = geti(GL_STENCIL_CLEAR_VALUE);
    s.cullFaceMode = geti(GL_CULL_FACE_MODE);
    s.frontFace = geti(GL_FRONT_FACE);
    glGetIntegerv(GL_POLYGON_MODE, s.polygonMode);
    glGetFloatv(GL_POLYGON_OFFSET_FACTOR, &s.polygonOffsetFactor);
    glGetFloatv(GL_POLYGON_OFFSET_UNITS, &s.polygonOffsetUnits);
}

// The program, buffer, texture and sampler bindings, the pixel stores, the clip distances and
// the shader storage bindings.
void captureBindings(GlStateSnapshot& s) {
    s.program = geti(GL_CURRENT_PROGRAM);
    s.vertexArray = geti(GL_VERTEX_ARRAY_BINDING);
    s.arrayBuffer = geti(GL_ARRAY_BUFFER_BINDING);
    s.elementArrayBuffer = geti(GL_ELEMENT_ARRAY_BUFFER_BINDING);
    s.uniformBuffer = geti(GL_UNIFORM_BUFFER_BINDING);
    s.pixelPackBuffer = geti(GL_PIXEL_PACK_BUFFER_BINDING);
    s.pixelUnpackBuffer = geti(GL_PIXEL_UNPACK_BUFFER_BINDING);
    s.drawIndirectBuffer = geti(GL_DRAW_INDIRECT_BUFFER_BINDING);
    s.activeTexture = geti(GL_ACTIVE_TEXTURE);
    for (int u = 0; u < GlStateSnapshot::kUnits; ++u) {
        glActiveTexture(GL_TEXTURE0 + u);
        for (int t = 0; t < 5; ++t) s.textures[u][t] = geti(kBindings[t]);
        s.samplers[u] = geti(GL_SAMPLER_BINDING);
    }
    glActiveTexture(GLenum(s.activeTexture));
    s.pack = capturePixelStore(kPack);
    s.unpack = capturePixelStore(kUnpack);
    for (int i = 0; i < 8; ++i) s.clipDistance[i] = glIsEnabled(GL_CLIP_DISTANCE0 + i);
    s.shaderStorageBuffer = geti(GL_SHADER_STORAGE_BUFFER_BINDING);
    for (GLuint i = 0; i < 8; ++i) {
        GlStateSnapshot::Range& r = s.shaderStorage[i];
        glGetIntegeri_v(GL_SHADER_STORAGE_BUFFER_BINDING, i, &r.buffer);
        glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_START, i, &r.start);
        glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_SIZE, i, &r.size);
    }
}

}  // namespace

GlStateSnapshot GlStateSnapshot::capture() {
    GlStateSnapshot s{};
    captureFixedFunction(s);
    captureBindings(s);
    return s;
}

void GlStateSnapshot::restore() const {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, GLuint(drawFramebuffer));
    glBindFramebuffer(GL_READ_FRAMEBUFFER, GLuint(readFramebuffer));
    glBindRenderbuffer(GL_RENDERBUFFER, GLuint(renderbuffer));
    glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
    glScissor(scissorBox[0], scissorBox[1], scissorBox[2], scissorBox[3]);
    enable(GL_DEPTH_TEST, depthTest);
    enable(GL_STENCIL_TEST, stencilTest);
    enable(GL_CULL_FACE, cullFace);
    enable(GL_SCISSOR_TEST, scissorTest);
    enable(GL_POLYGON_OFFSET_FILL, polygonOffsetFill);
    enable(GL_POLYGON_OFFSET_LINE, polygonOffsetLine);
    enable(GL_POLYGON_OFFSET_POINT, polygonOffsetPoint);
    enable(GL_FRAMEBUFFER_SRGB, framebufferSrgb);
    enable(GL_MULTISAMPLE, multisample);
    enable(GL_SAMPLE_ALPHA_TO_COVERAGE, sampleAlphaToCoverage);
    enable(GL_SAMPLE_ALPHA_TO_ONE, sampleAlphaToOne);
    enable(GL_SAMPLE_COVERAGE, sampleCoverage);
    enable(GL_SAMPLE_MASK, sampleMask);
    enable(GL_COLOR_LOGIC_OP, colorLogicOp);
    enable(GL_PRIMITIVE_RESTART, primitiveRestart);
    enable(GL_RASTERIZER_DISCARD, rasterizerDiscard);
    enable(GL_PROGRAM_POINT_SIZE, programPointSize);
    enable(GL_DEPTH_CLAMP, depthClamp);
    enable(GL_DITHER, dither);
    for (GLuint i = 0; i < GLuint(kDrawBuffers); ++i) {
        const DrawBufferBlend& b = blend[i];
        b.blend ? glEnablei(GL_BLEND, i) : glDisablei(GL_BLEND, i);
        glBlendEquationSeparatei(i, GLenum(b.equationRgb), GLenum(b.equationAlpha));
        glBlendFuncSeparatei(i, GLenum(b.srcRgb), GLenum(b.dstRgb), GLenum(b.srcAlpha), GLenum(b.dstAlpha));
        glColorMaski(i, b.colorMask[0], b.colorMask[1], b.colorMask[2], b.colorMask[3]);
    }
    glBlendColor(blendColor[0], blendColor[1], blendColor[2], blendColor[3]);
    glDepthMask(depthMask);
    glDepthFunc(GLenum(depthFunc));
    glDepthRange(depthRange[0], depthRange[1]);
    glClipControl(GLenum(clipOrigin), GLenum(clipDepthMode));
    glStencilFuncSeparate(GL_FRONT, GLenum(front.func), front.ref, GLuint(front.valueMask));
    glStencilFuncSeparate(GL_BACK, GLenum(back.func), back.ref, GLuint(back.valueMask));
    glStencilMaskSeparate(GL_FRONT, GLuint(front.writeMask));
    glStencilMaskSeparate(GL_BACK, GLuint(back.writeMask));
    glStencilOpSeparate(GL_FRONT, GLenum(front.fail), GLenum(front.depthFail), GLenum(front.pass));
    glStencilOpSeparate(GL_BACK, GLenum(back.fail), GLenum(back.depthFail), GLenum(back.pass));
    glClearColor(clearColor[0], clearColor[1], clearColor[2], clearColor[3]);
    glClearDepth(clearDepth);
    glClearStencil(clearStencil);
    glCullFace(GLenum(cullFaceMode));
    glFrontFace(GLenum(frontFace));
    glPolygonMode(GL_FRONT_AND_BACK, GLenum(polygonMode[0]));
    glPolygonOffset(polygonOffsetFactor, polygonOffsetUnits);
    glUseProgram(GLuint(program));
    glBindVertexArray(GLuint(vertexArray));  // carries its element buffer
    glBindBuffer(GL_ARRAY_BUFFER, GLuint(arrayBuffer));
    glBindBuffer(GL_UNIFORM_BUFFER, GLuint(uniformBuffer));
    glBindBuffer(GL_PIXEL_PACK_BUFFER, GLuint(pixelPackBuffer));
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, GLuint(pixelUnpackBuffer));
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, GLuint(drawIndirectBuffer));
    for (int u = 0; u < kUnits; ++u) {
        glActiveTexture(GL_TEXTURE0 + u);
        for (int t = 0; t < 5; ++t) glBindTexture(kTargets[t], GLuint(textures[u][t]));
        glBindSampler(GLuint(u), GLuint(samplers[u]));
    }
    glActiveTexture(GLenum(activeTexture));
    restorePixelStore(kPack, pack);
    restorePixelStore(kUnpack, unpack);
    for (int i = 0; i < 8; ++i) enable(GL_CLIP_DISTANCE0 + i, clipDistance[i]);
    for (GLuint i = 0; i < 8; ++i) {
        const Range& r = shaderStorage[i];
        if (r.buffer != 0 && r.size > 0)
            glBindBufferRange(GL_SHADER_STORAGE_BUFFER, i, GLuint(r.buffer), r.start, r.size);
        else glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, GLuint(r.buffer));
    }
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, GLuint(shaderStorageBuffer));
}

namespace {

// Writes one line per item that differs between two snapshots.
struct Differences {
    std::ostringstream& out;
    template <class A, class B>
    void cmp(const char* name, A a, B b) {
        if (a != b) out << name << ": " << +a << " -> " << +b << "\n";
    }
    template <class A, class B>
    void cmpN(const char* name, const A* a, const B* b, int n) {
        for (int i = 0; i < n; ++i)
            if (a[i] != b[i]) out << name << "[" << i << "]: " << +a[i] << " -> " << +b[i] << "\n";
    }
};

// captureFixedFunction's state, `s` against `o`.
void fixedFunctionDifferences(const GlStateSnapshot& s, const GlStateSnapshot& o, Differences& d) {
    d.cmp("draw framebuffer", s.drawFramebuffer, o.drawFramebuffer);
    d.cmp("read framebuffer", s.readFramebuffer, o.readFramebuffer);
    d.cmp("renderbuffer", s.renderbuffer, o.renderbuffer);
    d.cmpN("viewport", s.viewport, o.viewport, 4);
    d.cmpN("scissor box", s.scissorBox, o.scissorBox, 4);
    d.cmp("depth test", s.depthTest, o.depthTest);
    d.cmp("stencil test", s.stencilTest, o.stencilTest);
    d.cmp("cull face", s.cullFace, o.cullFace);
    d.cmp("scissor test", s.scissorTest, o.scissorTest);
    d.cmp("polygon offset fill", s.polygonOffsetFill, o.polygonOffsetFill);
    d.cmp("polygon offset line", s.polygonOffsetLine, o.polygonOffsetLine);
    d.cmp("polygon offset point", s.polygonOffsetPoint, o.polygonOffsetPoint);
    d.cmp("framebuffer sRGB", s.framebufferSrgb, o.framebufferSrgb);
    d.cmp("multisample", s.multisample, o.multisample);
    d.cmp("sample alpha to coverage", s.sampleAlphaToCoverage, o.sampleAlphaToCoverage);
    d.cmp("sample alpha to one", s.sampleAlphaToOne, o.sampleAlphaToOne);
    d.cmp("sample coverage", s.sampleCoverage, o.sampleCoverage);
    d.cmp("sample mask", s.sampleMask, o.sampleMask);
    d.cmp("colour logic op", s.colorLogicOp, o.colorLogicOp);
    d.cmp("primitive restart", s.primitiveRestart, o.primitiveRestart);
    d.cmp("rasterizer discard", s.rasterizerDiscard, o.rasterizerDiscard);
    d.cmp("program point size", s.programPointSize, o.programPointSize);
    d.cmp("depth clamp", s.depthClamp, o.depthClamp);
    d.cmp("dither", s.dither, o.dither);
    for (int i = 0; i < GlStateSnapshot::kDrawBuffers; ++i) {
        const GlStateSnapshot::DrawBufferBlend& a = s.blend[i];
        const GlStateSnapshot::DrawBufferBlend& b = o.blend[i];
        const std::string n = "draw buffer " + std::to_string(i) + " ";
        d.cmp((n + "blend").c_str(), a.blend, b.blend);
        const GLint x[6] = {a.equationRgb, a.equationAlpha, a.srcRgb, a.dstRgb, a.srcAlpha, a.dstAlpha};
        const GLint y[6] = {b.equationRgb, b.equationAlpha, b.srcRgb, b.dstRgb, b.srcAlpha, b.dstAlpha};
        d.cmpN((n + "blend (equation rgb, alpha; src rgb, dst rgb, src alpha, dst alpha)").c_str(), x, y, 6);
        d.cmpN((n + "color mask").c_str(), a.colorMask, b.colorMask, 4);
    }
    d.cmpN("blend color", s.blendColor, o.blendColor, 4);
    d.cmp("depth mask", s.depthMask, o.depthMask);
    d.cmp("depth func", s.depthFunc, o.depthFunc);
    d.cmpN("depth range", s.depthRange, o.depthRange, 2);
    d.cmp("clip origin", s.clipOrigin, o.clipOrigin);
    d.cmp("clip depth mode", s.clipDepthMode, o.clipDepthMode);
    const GLint* f = &s.front.func;
    const GLint* of = &o.front.func;
    const GLint* b = &s.back.func;
    const GLint* ob = &o.back.func;
    d.cmpN("stencil front (func ref mask wmask fail zfail pass)", f, of, 7);
    d.cmpN("stencil back (func ref mask wmask fail zfail pass)", b, ob, 7);
    d.cmpN("clear color", s.clearColor, o.clearColor, 4);
    d.cmp("clear depth", s.clearDepth, o.clearDepth);
    d.cmp("clear stencil", s.clearStencil, o.clearStencil);
    d.cmp("cull face mode", s.cullFaceMode, o.cullFaceMode);
    d.cmp("front face", s.frontFace, o.frontFace);
    d.cmpN("polygon mode", s.polygonMode, o.polygonMode, 2);
    d.cmp("polygon offset factor", s.polygonOffsetFactor, o.polygonOffsetFactor);
    d.cmp("polygon offset units", s.polygonOffsetUnits, o.polygonOffsetUnits);
}

// captureBindings' state, `s` against `o`.
void bindingDifferences(const GlStateSnapshot& s, const GlStateSnapshot& o, Differences& d) {
    d.cmp("program", s.program, o.program);
    d.cmp("vertex array", s.vertexArray, o.vertexArray);
    d.cmp("array buffer", s.arrayBuffer, o.arrayBuffer);
    d.cmp("element array buffer", s.elementArrayBuffer, o.elementArrayBuffer);
    d.cmp("uniform buffer", s.uniformBuffer, o.uniformBuffer);
    d.cmp("pixel pack buffer", s.pixelPackBuffer, o.pixelPackBuffer);
    d.cmp("pixel unpack buffer", s.pixelUnpackBuffer, o.pixelUnpackBuffer);
    d.cmp("draw indirect buffer", s.drawIndirectBuffer, o.drawIndirectBuffer);
    d.cmp("active texture", s.activeTexture, o.activeTexture);
    for (int u = 0; u < GlStateSnapshot::kUnits; ++u) {
        d.cmpN(("texture unit " + std::to_string(u) + " (2D 3D 2DArray Rect Buffer)").c_str(), s.textures[u].data(),
               o.textures[u].data(), 5);
        d.cmp(("sampler unit " + std::to_string(u)).c_str(), s.samplers[u], o.samplers[u]);
    }
    d.cmpN("pack store (alignment row-length image-height skip-pixels skip-rows skip-images swap lsb)",
           &s.pack.alignment, &o.pack.alignment, 8);
    d.cmpN("unpack store (alignment row-length image-height skip-pixels skip-rows skip-images swap lsb)",
           &s.unpack.alignment, &o.unpack.alignment, 8);
    d.cmpN("clip distance", s.clipDistance.data(), o.clipDistance.data(), 8);
    d.cmp("shader storage buffer", s.shaderStorageBuffer, o.shaderStorageBuffer);
    for (int i = 0; i < 8; ++i) {
        const std::string n = "shader storage binding " + std::to_string(i) + " (buffer start size)";
        const GLint64 a[3] = {s.shaderStorage[i].buffer, s.shaderStorage[i].start, s.shaderStorage[i].size};
        const GLint64 b[3] = {o.shaderStorage[i].buffer, o.shaderStorage[i].start, o.shaderStorage[i].size};
        d.cmpN(n.c_str(), a, b, 3);
    }
}

}  // namespace

std::string GlStateSnapshot::differences(const GlStateSnapshot& o) const {
    std::ostringstream out;
    Differences d{out};
    fixedFunctionDifferences(*this, o, d);
    bindingDifferences(*this, o, d);
    return out.str();
}

void resetPassState() {
    for (GLenum cap : {GL_SCISSOR_TEST, GL_STENCIL_TEST, GL_CULL_FACE, GL_FRAMEBUFFER_SRGB, GL_RASTERIZER_DISCARD,
                       GL_POLYGON_OFFSET_FILL, GL_DEPTH_CLAMP, GL_COLOR_LOGIC_OP, GL_SAMPLE_ALPHA_TO_COVERAGE,
                       GL_SAMPLE_ALPHA_TO_ONE, GL_SAMPLE_COVERAGE, GL_SAMPLE_MASK, GL_PRIMITIVE_RESTART})
        glDisable(cap);
    for (int c = 0; c < 8; ++c) glDisable(GLenum(GL_CLIP_DISTANCE0 + c));
    glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
    glDepthRange(0.0, 1.0);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthMask(GL_FALSE);
}

namespace {
thread_local HostStateScope* innermostScope = nullptr;
}

namespace {
// The GL errors pending now, each once (a lost context reports errors forever: bounded).
std::vector<GLenum> takePendingErrors() {
    std::vector<GLenum> errors;
    for (int i = 0; i < 16; ++i) {
        const GLenum e = glGetError();
        if (e == GL_NO_ERROR) break;
        if (std::find(errors.begin(), errors.end(), e) == errors.end()) errors.push_back(e);
    }
    return errors;
}

// Sets `error` again by a call GL must reject with it; false when no call can.
bool raiseAgain(GLenum error) {
    switch (error) {
        case GL_INVALID_ENUM: glEnable(GL_NONE); return true;
        case GL_INVALID_VALUE: glScissor(0, 0, -1, -1); return true;
        case GL_INVALID_OPERATION: glEndQuery(GL_SAMPLES_PASSED); return true;  // no query active
        default: return false;
    }
}

std::vector<GLenum> takeHostErrors() {
    std::vector<GLenum> errors = takePendingErrors();
    for (GLenum e : errors)
        logMessage(LogLevel::Warning, std::string("a GL error was pending when the host called Nephele: ") +
                                          errorName(e) + " (the host's; left set for the host)");
    return errors;
}

void raiseHostErrors(const std::vector<GLenum>& errors) {
    for (GLenum e : errors)
        if (!raiseAgain(e))
            logMessage(LogLevel::Warning, std::string("the host's pending ") + errorName(e) +
                                              " could not be set again: GL has no call that raises it");
}
}  // namespace

HostStateScope::HostStateScope()
    : hostErrors_(innermostScope ? std::vector<GLenum>{} : takeHostErrors()), outer_(innermostScope) {
    innermostScope = this;
    resetPassState();
    resetPixelStore();
}

HostStateScope::~HostStateScope() {
    // Newest first, so that a framebuffer recorded twice ends with its first (the host's) list.
    for (auto it = drawBuffers_.rbegin(); it != drawBuffers_.rend(); ++it)
        glNamedFramebufferDrawBuffers(it->framebuffer, GlStateSnapshot::kDrawBuffers, it->buffers.data());
    innermostScope = outer_;
    raiseHostErrors(hostErrors_);  // (calls that fail change no state: the guard's restore is unaffected)
}

void HostStateScope::selectDrawBuffer(GLuint framebuffer, GLenum attachment) {
    if (!innermostScope) throw std::logic_error("HostStateScope::selectDrawBuffer outside a HostStateScope");
    SavedDrawBuffers saved{framebuffer, {}};
    bool alone = true;  // already the only draw buffer: nothing to change or restore
    for (int i = 0; i < GlStateSnapshot::kDrawBuffers; ++i) {
        saved.buffers[i] = GLenum(geti(GL_DRAW_BUFFER0 + i));
        alone = alone && saved.buffers[i] == (i == 0 ? attachment : GLenum(GL_NONE));
    }
    if (alone) return;
    innermostScope->drawBuffers_.push_back(saved);
    glNamedFramebufferDrawBuffer(framebuffer, attachment);
}

void resetPixelStore() {
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    for (const GLenum* names : {kPack, kUnpack})
        for (int i = 0; i < 8; ++i) glPixelStorei(names[i], i == 0 ? 4 : 0);
}

}  // namespace nephele
