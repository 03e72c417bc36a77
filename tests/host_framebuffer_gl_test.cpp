// Any framebuffer an image generator draws into: depth without stencil, depth-stencil, float
// and 16-bit depth, depth in a renderbuffer, multisampled colour and depth, several draw
// buffers with Nephele drawing into the one the host names, and the default framebuffer of a
// window. Each gives the image of the plain float frame, and the host's draw-buffer list and
// every draw buffer's blend state and colour mask come back as they were.
#include "gl_test_util.hpp"
#include "layered_test_util.hpp"
#include "scene_test_util.hpp"

#include "nephele/gl_state.hpp"
#include "nephele/log.hpp"
#include "nephele/host_view.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"
#include "nephele/sky.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <utility>
#include <string>

using namespace nephele;
using namespace nephele::gl;

namespace {


struct FramebufferSpec {
    std::string name;
    GLenum depthFormat = GL_DEPTH24_STENCIL8;  // GL_NONE: no depth
    bool depthRenderbuffer = false;
    int samples = 0;       // > 0: multisampled colour and depth (renderbuffers)
    int colorBuffers = 1;  // GL_COLOR_ATTACHMENT0.. of colorFormat, all in the draw-buffer list
    GLenum colorFormat = GL_RGBA32F;
};

// A host's framebuffer as the spec says.
struct HostFramebuffer {
    std::vector<Texture> colors;
    std::vector<Renderbuffer> renderbuffers;
    Texture depth;
    Framebuffer fbo;
    int width, height;
    HostFramebuffer(int w, int h, const FramebufferSpec& spec) : width(w), height(h) {
        fbo = Framebuffer::create();
        std::vector<GLenum> list;
        for (int i = 0; i < spec.colorBuffers; ++i) {
            const GLenum attachment = GL_COLOR_ATTACHMENT0 + i;
            if (spec.samples > 0) {
                renderbuffers.push_back(Renderbuffer::create());
                glNamedRenderbufferStorageMultisample(renderbuffers.back().id(), spec.samples, spec.colorFormat, w, h);
                glNamedFramebufferRenderbuffer(fbo.id(), attachment, GL_RENDERBUFFER, renderbuffers.back().id());
            } else {
                colors.push_back(Texture::create(GL_TEXTURE_2D));
                glTextureStorage2D(colors.back().id(), 1, spec.colorFormat, w, h);
                glNamedFramebufferTexture(fbo.id(), attachment, colors.back().id(), 0);
            }
            list.push_back(attachment);
        }
        glNamedFramebufferDrawBuffers(fbo.id(), GLsizei(list.size()), list.data());
        if (spec.depthFormat != GL_NONE) {
            const bool stencil = spec.depthFormat == GL_DEPTH24_STENCIL8 || spec.depthFormat == GL_DEPTH32F_STENCIL8;
            const GLenum point = stencil ? GL_DEPTH_STENCIL_ATTACHMENT : GL_DEPTH_ATTACHMENT;
            if (spec.samples > 0 || spec.depthRenderbuffer) {
                renderbuffers.push_back(Renderbuffer::create());
                glNamedRenderbufferStorageMultisample(renderbuffers.back().id(), spec.samples, spec.depthFormat, w, h);
                glNamedFramebufferRenderbuffer(fbo.id(), point, GL_RENDERBUFFER, renderbuffers.back().id());
            } else {
                depth = Texture::create(GL_TEXTURE_2D);
                glTextureStorage2D(depth.id(), 1, spec.depthFormat, w, h);
                glNamedFramebufferTexture(fbo.id(), point, depth.id(), 0);
            }
        }
        EXPECT_EQ(glCheckNamedFramebufferStatus(fbo.id(), GL_FRAMEBUFFER), GLenum(GL_FRAMEBUFFER_COMPLETE))
            << spec.name;
    }
};

// Colour attachment `index` of `framebuffer` as RGBA, top row first (multisampled: resolved
// by a blit into a single-sample texture, as a host resolves before display).
Image readAttachment(GLuint framebuffer, int index, int width, int height) {
    GlStateGuard guard;
    resetPassState();
    resetPixelStore();
    Texture resolved = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(resolved.id(), 1, GL_RGBA32F, width, height);
    Framebuffer dst = Framebuffer::create();
    glNamedFramebufferTexture(dst.id(), GL_COLOR_ATTACHMENT0, resolved.id(), 0);
    glNamedFramebufferReadBuffer(framebuffer, GL_COLOR_ATTACHMENT0 + index);
    glBlitNamedFramebuffer(framebuffer, dst.id(), 0, 0, width, height, 0, 0, width, height, GL_COLOR_BUFFER_BIT,
                           GL_NEAREST);
    glNamedFramebufferReadBuffer(framebuffer, GL_COLOR_ATTACHMENT0);
    std::vector<float> bottomUp(std::size_t(width) * height * 4);
    glGetTextureImage(resolved.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(bottomUp.size() * sizeof(float)), bottomUp.data());
    check("reading back a colour attachment");
    Image image(width, height, 4);
    for (int y = 0; y < height; ++y)
        std::copy_n(bottomUp.data() + std::size_t(height - 1 - y) * width * 4, std::size_t(width) * 4,
                    image.pixels.data() + std::size_t(y) * width * 4);
    return image;
}

std::vector<GLenum> drawBuffersOf(GLuint framebuffer) {
    GLint bound = 0;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &bound);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, framebuffer);
    std::vector<GLenum> list(GlStateSnapshot::kDrawBuffers);
    for (int i = 0; i < GlStateSnapshot::kDrawBuffers; ++i) {
        GLint v = 0;
        glGetIntegerv(GL_DRAW_BUFFER0 + i, &v);
        list[i] = GLenum(v);
    }
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, GLuint(bound));
    return list;
}

class HostFramebufferGLTest : public test::EglTest {
protected:
    static constexpr int kW = 96, kH = 64;
    // The sky drawn into the plain frame of the other host tests (RGBA32F, DEPTH24_STENCIL8).
    void SetUp() override {
        test::EglTest::SetUp();
        scene_ = test::hostScene(kW, kH);
        view_ = makeView(scene_.camera);
        sky_ = std::make_unique<SkyRenderer>(test::smallSky());
        sky_->prepare(scene_);
        sky_->update(0.25, Weather::of(scene_), view_.eye);
        sky_->waitForBackgroundWork();
        HostFramebuffer plain(kW, kH, {"plain"});
        OpaquePass().draw(scene_, view_, plain.fbo.id());
        sky_->draw(viewDescOf(view_, plain.fbo.id()));
        reference_ = readAttachment(plain.fbo.id(), 0, kW, kH);
    }
    void expectClose(const Image& image, const std::string& name, double meanBound, double fractionBound) {
        const ImageDifference d = compareImages(image, reference_, 2.0 / 255);
        std::printf("[ figure ] %s: mean %.5f, max %.4f, %.2f%% of pixels over 2/255\n", name.c_str(), d.meanAbs,
                    d.maxAbs, 100 * d.fractionOver);
        EXPECT_LE(d.meanAbs, meanBound) << name;
        EXPECT_LE(d.fractionOver, fractionBound) << name << " (max " << d.maxAbs << ")";
        if (d.meanAbs > meanBound || d.fractionOver > fractionBound) {
            writePng(test::outputDir() + "/host_framebuffer_" + name + "_actual.png", image);
            writePng(test::outputDir() + "/host_framebuffer_" + name + "_diff.png", differenceImage(image, reference_));
        }
    }
    Scene scene_;
    View view_;
    std::unique_ptr<SkyRenderer> sky_;
    Image reference_;
};

}  // namespace

// Depth without stencil (the IGs' usual DEPTH_COMPONENT32F), float depth with stencil, 24 and
// 16 bits, in textures and in a renderbuffer. The depth copy takes the attachment's own format
// (a blit needs equal formats); asking a missing stencil attachment its size was
// GL_INVALID_OPERATION ("the copy of the frame's depth"). The float and 24-bit formats give
// the reference's depth comparisons exactly, and 16 bits move no cloud pixel of this view
// either (measured: identical in every format; a copy that fails draws nothing: mean 0.197).
TEST_F(HostFramebufferGLTest, EveryDepthFormatGivesTheSameImage) {
    const FramebufferSpec specs[] = {
        {"depth32f", GL_DEPTH_COMPONENT32F},
        {"depth24", GL_DEPTH_COMPONENT24},
        {"depth16", GL_DEPTH_COMPONENT16},
        {"depth32f_stencil8", GL_DEPTH32F_STENCIL8},
        {"depth32f_renderbuffer", GL_DEPTH_COMPONENT32F, true},
        {"depth24_stencil8_renderbuffer", GL_DEPTH24_STENCIL8, true},
    };
    for (const FramebufferSpec& spec : specs) {
        HostFramebuffer target(kW, kH, spec);
        OpaquePass().draw(scene_, view_, target.fbo.id());
        EXPECT_NO_THROW(sky_->draw(viewDescOf(view_, target.fbo.id()))) << spec.name;
        expectClose(readAttachment(target.fbo.id(), 0, kW, kH), spec.name, 1e-6, 0.0);
    }
}

// A frame without any depth attachment is drawn as hasDepth = false: the clouds over
// everything, the opaque box included.
TEST_F(HostFramebufferGLTest, AFrameWithoutDepthIsDrawnOverEverything) {
    HostFramebuffer none(kW, kH, {"none", GL_NONE});
    HostFramebuffer plain(kW, kH, {"plain"});
    OpaquePass().draw(scene_, view_, none.fbo.id());
    OpaquePass().draw(scene_, view_, plain.fbo.id());
    EXPECT_NO_THROW(sky_->draw(viewDescOf(view_, none.fbo.id())));
    sky_->draw(viewDescOf(view_, plain.fbo.id(), false));
    const ImageDifference d =
        compareImages(readAttachment(none.fbo.id(), 0, kW, kH), readAttachment(plain.fbo.id(), 0, kW, kH), 1e-6);
    EXPECT_LE(d.maxAbs, 1e-6);
}

// Multisampled colour and depth (4 samples): Nephele draws into the multisampled framebuffer
// (every sample of a pixel gets the pixel's cloud), its depth copy resolves the host's depth,
// and the host resolves the colour. Only the edges the rasteriser antialiases differ from the
// single-sample frame (the box's and the meshes' edges). Measured: mean 0.0009, 0.47% of the
// pixels over 2/255; clouds drawn over the box as if the frame had no depth (a depth copy
// lost): mean 0.0029, 0.88%. The bounds sit between.
TEST_F(HostFramebufferGLTest, AMultisampledFrameGetsTheSameCloudsWithAntialiasedEdges) {
    HostFramebuffer ms(kW, kH, {"msaa4", GL_DEPTH_COMPONENT32F, false, 4});
    OpaquePass().draw(scene_, view_, ms.fbo.id());
    EXPECT_NO_THROW(sky_->draw(viewDescOf(view_, ms.fbo.id())));
    expectClose(readAttachment(ms.fbo.id(), 0, kW, kH), "msaa4", 0.0018, 0.0065);
}

// Two draw buffers, the host naming the second: Nephele draws the reference image into it and
// leaves the first as it was; dual-source blending (the upsampling) needs a single draw
// buffer, so Nephele narrows the list while it draws and restores it. The host's per-buffer
// blend state and colour masks come back too (they were all reset to buffer 0's).
TEST_F(HostFramebufferGLTest, SeveralDrawBuffersOnlyTheNamedOneIsDrawnAndAllStateIsRestored) {
    HostFramebuffer two(kW, kH, {"two", GL_DEPTH_COMPONENT32F, false, 0, 2});
    HostFramebuffer plain(kW, kH, {"plain", GL_DEPTH_COMPONENT32F});  // (a blit of depth needs equal formats)
    OpaquePass().draw(scene_, view_, plain.fbo.id());
    // The host's frame in attachment 1 (the opaque pass, copied), a marker in attachment 0.
    glBlitNamedFramebuffer(plain.fbo.id(), two.fbo.id(), 0, 0, kW, kH, 0, 0, kW, kH,
                           GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT, GL_NEAREST);
    check("copying the host's frame");
    const float marker[4] = {0.25f, 0.5f, 0.75f, 1.0f};
    glClearNamedFramebufferfv(two.fbo.id(), GL_COLOR, 0, marker);
    // Each draw buffer with its own blending and mask, as an IG's G-buffer pass might leave it.
    glEnablei(GL_BLEND, 1);
    glBlendFuncSeparatei(1, GL_ONE, GL_ONE, GL_ZERO, GL_ONE);
    glBlendEquationSeparatei(1, GL_MAX, GL_FUNC_ADD);
    glColorMaski(1, GL_TRUE, GL_FALSE, GL_TRUE, GL_TRUE);
    glDisablei(GL_BLEND, 0);
    glColorMaski(0, GL_FALSE, GL_TRUE, GL_TRUE, GL_FALSE);
    const std::vector<GLenum> listBefore = drawBuffersOf(two.fbo.id());
    const GlStateSnapshot before = GlStateSnapshot::capture();
    ViewDesc d = viewDescOf(view_, two.fbo.id());
    d.drawBuffer = GL_COLOR_ATTACHMENT1;
    EXPECT_NO_THROW(sky_->draw(d));
    EXPECT_EQ(before.differences(GlStateSnapshot::capture()), "");
    EXPECT_EQ(drawBuffersOf(two.fbo.id()), listBefore);
    expectClose(readAttachment(two.fbo.id(), 1, kW, kH), "second_draw_buffer", 1e-6, 0.0);
    const Image first = readAttachment(two.fbo.id(), 0, kW, kH);
    int changed = 0;
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
            for (int k = 0; k < 4; ++k) changed += first.at(x, y, k) != marker[k];
    EXPECT_EQ(changed, 0);
}

// A draw buffer that cannot be drawn into is named in the error: GL_NONE as draw buffer 0, and
// an attachment with no image.
TEST_F(HostFramebufferGLTest, ADrawBufferThatCannotBeDrawnIsNamed) {
    HostFramebuffer target(kW, kH, {"target", GL_DEPTH_COMPONENT32F});
    const GLenum none = GL_NONE;
    glNamedFramebufferDrawBuffers(target.fbo.id(), 1, &none);
    const std::string fb = "framebuffer " + std::to_string(target.fbo.id());
    try {
        sky_->draw(viewDescOf(view_, target.fbo.id()));
        ADD_FAILURE() << "no error for a GL_NONE draw buffer";
    } catch (const GlError& e) {
        EXPECT_NE(std::string(e.what()).find(fb + ": its draw buffer 0 is GL_NONE"), std::string::npos) << e.what();
    }
    ViewDesc d = viewDescOf(view_, target.fbo.id());
    d.drawBuffer = GL_COLOR_ATTACHMENT3;
    try {
        sky_->draw(d);
        ADD_FAILURE() << "no error for an empty attachment";
    } catch (const GlError& e) {
        EXPECT_NE(std::string(e.what()).find(fb + ": GL_COLOR_ATTACHMENT3, its draw buffer, has no image attached"),
                  std::string::npos)
            << e.what();
    }
    GLenum err = glGetError();
    EXPECT_EQ(err, GLenum(GL_NO_ERROR));
}

// The default framebuffer of a window (GLFW under Xvfb: 8-bit colour, its own depth-stencil):
// the same image as an 8-bit framebuffer object. Both round each blend to 1/255 the same way;
// the window's depth is its own format. Measured: identical; allow 2/255 on 1% of the pixels
// (a driver may dither a window's buffer).
TEST(HostFramebufferWindowGLTest, TheDefaultFramebufferOfAWindow) {
    if (!std::getenv("DISPLAY")) GTEST_SKIP() << "needs a display (the suite runs under xvfb-run)";
    const Scene scene = test::hostScene(96, 64);
    auto draw = [&](const View& view, GLuint fb) {
        SkyRenderer sky(test::smallSky());
        sky.prepare(scene);
        sky.update(0.25, Weather::of(scene), view.eye);
        sky.waitForBackgroundWork();
        sky.draw(viewDescOf(view, fb));
    };
    Image offscreen;
    {
        auto egl = test::makeContext(GlBackend::Egl);
        const View view = makeView(scene.camera);
        HostFramebuffer eight(96, 64, {"rgba8", GL_DEPTH24_STENCIL8, false, 0, 1, GL_RGBA8});
        OpaquePass().draw(scene, view, eight.fbo.id());
        draw(view, eight.fbo.id());
        offscreen = readAttachment(eight.fbo.id(), 0, 96, 64);
    }
    const Image window = test::renderInWindow(scene, draw);
    const ImageDifference d = compareImages(window, offscreen, 2.0 / 255);
    std::printf("[ figure ] window: mean %.5f, max %.4f, %.2f%% of pixels over 2/255\n", d.meanAbs, d.maxAbs,
                100 * d.fractionOver);
    EXPECT_LE(d.fractionOver, 0.01);
    EXPECT_LE(d.meanAbs, 0.5 / 255);
    if (d.fractionOver > 0.01 || d.meanAbs > 0.5 / 255) {
        writePng(test::outputDir() + "/host_framebuffer_window_actual.png", window);
        writePng(test::outputDir() + "/host_framebuffer_window_offscreen.png", offscreen);
    }
}

// GL errors the host left pending are the host's: draw() neither fails on them nor clears
// them; it logs each as the host's and leaves it set. (Before, Nephele's first check after a
// draw threw "<its pass>: GL_INVALID_ENUM", and colorTargetOf drained them silently.)
TEST_F(HostFramebufferGLTest, TheHostsPendingGlErrorsAreReportedAndLeftSet) {
    HostFramebuffer target(kW, kH, {"target"});
    // (Mesa keeps one pending error at a time: one per draw.)
    const std::pair<GLenum, std::function<void()>> errors[] = {
        {GL_INVALID_ENUM, [] { glEnable(GL_NONE); }},
        {GL_INVALID_VALUE, [] { glScissor(0, 0, -1, -1); }},
        {GL_INVALID_OPERATION, [] { glEndQuery(GL_SAMPLES_PASSED); }},
    };
    for (const auto& [error, raise] : errors) {
        OpaquePass().draw(scene_, view_, target.fbo.id());
        std::vector<std::string> messages;
        const LogCallback previous = setLogCallback([&](LogLevel, std::string_view m) { messages.emplace_back(m); });
        raise();  // the host's
        EXPECT_NO_THROW(sky_->draw(viewDescOf(view_, target.fbo.id()))) << errorName(error);
        setLogCallback(previous);
        EXPECT_EQ(glGetError(), error) << errorName(error);
        EXPECT_EQ(glGetError(), GLenum(GL_NO_ERROR)) << errorName(error);
        ASSERT_EQ(messages.size(), 1u) << errorName(error);
        EXPECT_NE(messages[0].find(std::string("pending when the host called Nephele: ") + errorName(error)),
                  std::string::npos)
            << messages[0];
        expectClose(readAttachment(target.fbo.id(), 0, kW, kH), "after_host_errors", 1e-6, 0.0);
    }
}

// The host's objects are checked before anything is drawn, and the error names the object and
// what is wrong (a bad framebuffer was reported as "uploading the layered sky's textures", a
// bad depth texture as "reducing the frame's depth").
TEST_F(HostFramebufferGLTest, BadHostObjectsAreNamedBeforeAnythingIsDrawn) {
    auto expectError = [&](const ViewDesc& d, const std::string& expected) {
        try {
            sky_->draw(d);
            ADD_FAILURE() << "no error; expected: " << expected;
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
        }
        EXPECT_EQ(glGetError(), GLenum(GL_NO_ERROR)) << expected;
    };
    expectError(viewDescOf(view_, 4242), "ViewDesc::framebuffer 4242 is not a framebuffer object");
    Framebuffer empty = Framebuffer::create();
    expectError(viewDescOf(view_, empty.id()), "ViewDesc::framebuffer " + std::to_string(empty.id()) +
                                                   " is incomplete: GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT");
    HostFramebuffer target(kW, kH, {"target"});
    ViewDesc d = viewDescOf(view_, target.fbo.id());
    d.depthTexture = 4343;
    expectError(d, "ViewDesc::depthTexture 4343 is not a texture object");
    d.depthTexture = target.colors[0].id();
    expectError(d, "ViewDesc::depthTexture " + std::to_string(d.depthTexture) + " is not of a depth format");
    Texture small = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(small.id(), 1, GL_DEPTH_COMPONENT32F, kW / 2, kH);
    d.depthTexture = small.id();
    expectError(d, "is 48x64, smaller than the viewport's extent 96x64");
    Texture volume = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(volume.id(), 1, GL_R8, 4, 4, 4);
    d.depthTexture = volume.id();
    expectError(d, "is not a GL_TEXTURE_2D");
}

// The layers' cloud shadows on the host's pixels are opt-in (ViewDesc::cloudShadows; the
// helicopter went to x0.47 under a layer by default): off, the host's surfaces and the empty
// pixels below the horizon are only covered by the clouds "over" them, never darkened; on (as
// viewDescOf sets for a scene's own frame), the frame is the reference. The frame with shadows
// is nowhere brighter, and darker where the box and the ground lie in the layer's shadow.
TEST_F(HostFramebufferGLTest, CloudShadowsOnTheHostsPixelsAreOptIn) {
    EXPECT_FALSE(ViewDesc{}.cloudShadows);
    HostFramebuffer target(kW, kH, {"target"});
    OpaquePass().draw(scene_, view_, target.fbo.id());
    ViewDesc d = viewDescOf(view_, target.fbo.id());
    d.cloudShadows = false;
    sky_->draw(d);
    const Image off = readAttachment(target.fbo.id(), 0, kW, kH);
    int darker = 0, brighter = 0;
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
            for (int k = 0; k < 3; ++k) {
                const float delta = off.at(x, y, k) - reference_.at(x, y, k);
                darker += delta > 0.02f;
                brighter += delta < -1e-6f;
            }
    std::printf("[ figure ] cloud shadows: %d channel values darker by > 0.02 with them, %d brighter\n", darker,
                brighter);
    EXPECT_EQ(brighter, 0);
    EXPECT_GT(darker, 2000);  // measured 2565 of 27648; with the opt-in ignored (shadows always): 0
}
