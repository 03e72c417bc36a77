// Shared by the *GLTest suites: a headless context per test suite and golden images.
#pragma once

#include "nephele/context.hpp"
#include "nephele/gl.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/camera.hpp"
#include "nephele/image.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"
#include "nephele/shader.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace nephele::test {

// A test's compute probe: `file` built from the shader folder `dir` (NEPHELE_SHADER_DIR, which
// the probe's #includes of the library's shaders resolve through), the variable unset again
// whether or not the build throws.
inline Program buildProbe(const std::string& dir, const char* file) {
    ::setenv("NEPHELE_SHADER_DIR", dir.c_str(), 1);
    try {
        Program program = Program::build({{GL_COMPUTE_SHADER, file}});
        ::unsetenv("NEPHELE_SHADER_DIR");
        return program;
    } catch (...) {
        ::unsetenv("NEPHELE_SHADER_DIR");
        throw;
    }
}

// A scene of data/scenes at `width` pixels wide (its aspect kept; 160x120 for the 4:3
// scenes): enough pixels per ellipsoid to measure, small enough for CI on llvmpipe.
inline Scene sharedScene(const std::string& name, int width = 160) {
    Scene s = loadScene(std::string(NEPHELE_SCENES) + "/" + name);
    const double aspect = double(s.camera.width) / s.camera.height;
    s.camera.width = width;
    s.camera.height = int(std::lround(width / aspect));
    return s;
}

// Makes a context of `backend` (checks on) or fails the test with the context's message.
inline std::unique_ptr<Context> makeContext(GlBackend backend) {
    ContextOptions o;
    o.backend = backend;
    o.visible = false;
    o.width = 64;
    o.height = 64;
    auto ctx = Context::create(o);
    gl::setChecks(true);
    return ctx;
}

// A test fixture with a headless EGL context per test (checks on).
class EglTest : public ::testing::Test {
protected:
    void SetUp() override { ctx_ = makeContext(GlBackend::Egl); }
    std::unique_ptr<Context> ctx_;
};

// A host's window: draws the scene's sky and objects, then `clouds(view, 0)`, into the
// default framebuffer of a hidden GLFW window the camera's size (needs a DISPLAY: the suite
// runs under xvfb-run) and reads it back as RGBA, top row first.
template <class DrawClouds>
Image renderInWindow(const Scene& scene, DrawClouds&& clouds) {
    ContextOptions o;
    o.backend = GlBackend::Glfw;
    o.visible = false;
    o.width = scene.camera.width;
    o.height = scene.camera.height;
    auto window = Context::create(o);
    gl::setChecks(true);
    GLint viewport[4];
    gl::glGetIntegerv(GL_VIEWPORT, viewport);
    const int w = viewport[2], h = viewport[3];
    EXPECT_EQ(w, scene.camera.width);
    EXPECT_EQ(h, scene.camera.height);
    const View view = makeView(scene.camera);
    OpaquePass().draw(scene, view, 0);
    clouds(view, GLuint(0));
    std::vector<float> bottomUp(std::size_t(w) * h * 4);
    gl::glReadBuffer(GL_BACK);
    gl::glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, bottomUp.data());
    Image image(w, h, 4);
    for (int y = 0; y < h; ++y)
        std::copy_n(bottomUp.data() + std::size_t(h - 1 - y) * w * 4, std::size_t(w) * 4,
                    image.pixels.data() + std::size_t(y) * w * 4);
    return image;
}

// Where tests write actual and diff images for a person to look at.
inline std::string outputDir() {
    const std::string dir = std::string(NEPHELE_TEST_OUTPUT);
    std::filesystem::create_directories(dir);
    return dir;
}

// An image clamped to [0, 1]: what a display shows of it.
inline Image clamped(Image image) {
    for (float& v : image.pixels) v = std::clamp(v, 0.0f, 1.0f);
    return image;
}

// Writes outputDir()/NAME.png for a person to look at: RGB and RGBA as RGB (sRGB), one
// channel as its values (linear: an opacity map). writePng clamps to [0, 1].
inline void save(const std::string& name, const Image& image) {
    writePng(outputDir() + "/" + name + ".png", image.channels == 4 ? channels(image, 0, 3) : image,
             image.channels == 1 ? Encoding::Linear : Encoding::Srgb);
}

struct GoldenTolerance {
    double pixel;        // per-channel difference (in [0,1] of 8-bit sRGB) that counts a pixel as off
    double fractionOff;  // largest allowed fraction of pixels that are off
    double mean;         // largest allowed mean absolute difference over all channels
};

// Compares an sRGB-encoded rendering with tests/golden/NAME.png. On failure, or when the
// golden is missing, writes NAME[_TAG]_actual.png and NAME[_TAG]_diff.png to outputDir()
// and fails; tests/promote_golden.sh NAME [TAG] copies an actual image to golden after a
// person looked at it. TAG tells apart renderings (e.g. backends) that share one golden.
inline void expectMatchesGolden(const Image& linearRgb, const std::string& name, const GoldenTolerance& tol,
                                const std::string& tag = "") {
    const std::string stem = outputDir() + "/" + name + (tag.empty() ? "" : "_" + tag);
    const std::string actualPath = stem + "_actual.png";
    writePng(actualPath, linearRgb, Encoding::Srgb);
    const Image actual = readPng(actualPath);  // the 8-bit values as stored
    const std::string goldenPath = std::string(NEPHELE_GOLDEN) + "/" + name + ".png";
    if (!std::filesystem::exists(goldenPath)) {
        ADD_FAILURE() << "no golden image " << goldenPath << "; look at " << actualPath
                      << " and promote it with tests/promote_golden.sh " << name << " " << tag;
        return;
    }
    const Image golden = readPng(goldenPath);
    ASSERT_EQ(golden.width, actual.width);
    ASSERT_EQ(golden.height, actual.height);
    ASSERT_EQ(golden.channels, actual.channels);
    const ImageDifference d = compareImages(actual, golden, tol.pixel);
    const bool ok = d.fractionOver <= tol.fractionOff && d.meanAbs <= tol.mean;
    if (!ok) writePng(stem + "_diff.png", differenceImage(actual, golden, 8.0f), Encoding::Linear);
    else std::filesystem::remove(actualPath);
    EXPECT_TRUE(ok) << name << ": " << d.fractionOver * 100 << "% of pixels differ by more than " << tol.pixel * 255
                    << "/255 (allowed " << tol.fractionOff * 100 << "%), mean difference " << d.meanAbs * 255
                    << "/255 (allowed " << tol.mean * 255 << "/255), max " << d.maxAbs * 255
                    << "/255. Actual and diff images: " << outputDir();
}

// A host's GL state as hostile as it gets (issue #39: one fixture for the tests that check a
// pass leaves the host's state as it found it). Made, it has set: programs, vertex arrays,
// textures and samplers bound on every unit; buffers bound where uploads and SSBOs look (the
// SSBO bindings 0-7 whole, 1 also as a range); another framebuffer bound; every fixed-function
// setting away from its default. It owns the objects it bound.
struct HostileGlState {
    Program program;
    gl::VertexArray vao;
    gl::Buffer buffer;
    gl::Sampler sampler;
    std::vector<gl::Texture> textures;
    gl::Framebuffer other;

    HostileGlState() {
        using namespace gl;
        program = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "sky.frag"}});
        vao = VertexArray::create();
        buffer = Buffer::create();
        glNamedBufferStorage(buffer.id(), 4096, nullptr, GL_DYNAMIC_STORAGE_BIT);
        sampler = Sampler::create();
        glSamplerParameteri(sampler.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glSamplerParameteri(sampler.id(), GL_TEXTURE_WRAP_S, GL_MIRRORED_REPEAT);
        constexpr std::array<GLenum, 4> kTargets{GL_TEXTURE_2D, GL_TEXTURE_3D, GL_TEXTURE_2D_ARRAY,
                                                 GL_TEXTURE_RECTANGLE};
        for (GLenum target : kTargets) {
            textures.push_back(Texture::create(target));
            if (target == GL_TEXTURE_2D || target == GL_TEXTURE_RECTANGLE)
                glTextureStorage2D(textures.back().id(), 1, GL_RGBA8, 4, 4);
            else glTextureStorage3D(textures.back().id(), 1, GL_RGBA8, 4, 4, 4);
        }
        other = Framebuffer::create();
        glNamedFramebufferTexture(other.id(), GL_COLOR_ATTACHMENT0, textures[0].id(), 0);
        for (int u = 0; u < GlStateSnapshot::kUnits; ++u) {
            glActiveTexture(GL_TEXTURE0 + u);
            for (std::size_t t = 0; t < textures.size(); ++t) glBindTexture(kTargets[t], textures[t].id());
            glBindSampler(GLuint(u), sampler.id());
        }
        glActiveTexture(GL_TEXTURE5);
        glUseProgram(program.id());
        glBindVertexArray(vao.id());
        for (GLenum target : {GL_PIXEL_UNPACK_BUFFER, GL_PIXEL_PACK_BUFFER, GL_ARRAY_BUFFER, GL_UNIFORM_BUFFER,
                              GL_DRAW_INDIRECT_BUFFER})
            glBindBuffer(target, buffer.id());
        for (GLuint i = 0; i < 8; ++i) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, buffer.id());
        glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 1, buffer.id(), 0, 128);
        glBindFramebuffer(GL_FRAMEBUFFER, other.id());
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        glPixelStorei(GL_UNPACK_ROW_LENGTH, 7);
        glPixelStorei(GL_UNPACK_SKIP_PIXELS, 2);
        glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 3);
        glPixelStorei(GL_PACK_ALIGNMENT, 8);
        glPixelStorei(GL_PACK_ROW_LENGTH, 5);
        for (GLenum cap : {GL_SCISSOR_TEST, GL_POLYGON_OFFSET_FILL, GL_FRAMEBUFFER_SRGB, GL_DEPTH_TEST, GL_STENCIL_TEST,
                           GL_CULL_FACE, GL_BLEND, GL_COLOR_LOGIC_OP, GL_DEPTH_CLAMP, GL_PRIMITIVE_RESTART,
                           GL_SAMPLE_ALPHA_TO_COVERAGE, GL_CLIP_DISTANCE0, GL_CLIP_DISTANCE2, GL_CLIP_DISTANCE3})
            glEnable(cap);
        glDisable(GL_DITHER);
        glScissor(5, 5, 10, 10);
        glPolygonOffset(4, 40);
        glColorMask(GL_TRUE, GL_FALSE, GL_TRUE, GL_FALSE);
        glDepthMask(GL_TRUE);
        glDepthFunc(GL_NEVER);
        glDepthRange(0.3, 0.6);
        glClipControl(GL_UPPER_LEFT, GL_ZERO_TO_ONE);
        glStencilFunc(GL_NEVER, 3, 0x0F);
        glStencilOp(GL_INCR, GL_DECR, GL_INVERT);
        glCullFace(GL_FRONT_AND_BACK);
        glFrontFace(GL_CW);
        glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
        glBlendEquationSeparate(GL_MIN, GL_MAX);
        glBlendFuncSeparate(GL_DST_COLOR, GL_ZERO, GL_ONE, GL_ONE);
        glLogicOp(GL_XOR);
        glClearColor(0.1f, 0.2f, 0.3f, 0.4f);
        glViewport(7, 9, 11, 13);
        check("setting up the hostile host state");
    }
    // A program deleted while current stays until another is made current: a pass that then
    // restores it would name a deleted program (GL_INVALID_VALUE). A host unbinds it first.
    ~HostileGlState() {
        GLint current = 0;
        gl::glGetIntegerv(GL_CURRENT_PROGRAM, &current);
        if (GLuint(current) == program.id()) gl::glUseProgram(0);
    }
    HostileGlState(const HostileGlState&) = delete;
    HostileGlState& operator=(const HostileGlState&) = delete;
};

// Runs draw(k) for k = 0 .. frames - 1 from the current state: each must leave it as it found it.
template <class Draw>
void expectStateUnchanged(Draw&& draw, int frames = 1) {
    for (int k = 0; k < frames; ++k) {
        const GlStateSnapshot before = GlStateSnapshot::capture();
        draw(k);
        EXPECT_EQ(before.differences(GlStateSnapshot::capture()), "") << "draw " << k;
    }
}

}  // namespace nephele::test
