// A host image generator, as the loop of docs/embedding.md: its own headless EGL context, its
// own framebuffer (float colour, depth texture, reversed Z in [0, 1]) with a "terrain" already
// drawn, two display channels side by side (off-axis frusta), CIGI-shaped weather, and
// nephele::SkyRenderer driven through prepare / update / draw. It writes the frame to
// OUT.pfm and exits 1 when the clouds are missing from either channel or show in front of
// the terrain, 2 on a bad scene.
//
//   nephele_host SCENE.json OUT.pfm [WIDTH HEIGHT]
#include "nephele/gl.hpp"
#include "nephele/image.hpp"
#include "nephele/log.hpp"
#include "nephele/sky.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

using namespace nephele::gl;  // the host reaches GL through the entry points Nephele loaded

namespace {

// A surfaceless OpenGL 4.5 core context (Mesa), current on this thread.
void makeContext() {
    EGLDisplay display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY || !eglInitialize(display, nullptr, nullptr) || !eglBindAPI(EGL_OPENGL_API))
        throw std::runtime_error("no EGL display for desktop OpenGL");
    const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                              EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    EGLContext context = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
    if (context == EGL_NO_CONTEXT || !eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))
        throw std::runtime_error("no OpenGL 4.5 core context");
}

struct Frame {
    GLuint fbo = 0, color = 0, depth = 0;
    int width = 0, height = 0;
};

Frame makeFrame(int w, int h) {
    Frame f{0, 0, 0, w, h};
    glCreateTextures(GL_TEXTURE_2D, 1, &f.color);
    glTextureStorage2D(f.color, 1, GL_RGBA16F, w, h);
    glCreateTextures(GL_TEXTURE_2D, 1, &f.depth);
    glTextureStorage2D(f.depth, 1, GL_DEPTH_COMPONENT32F, w, h);
    glCreateFramebuffers(1, &f.fbo);
    glNamedFramebufferTexture(f.fbo, GL_COLOR_ATTACHMENT0, f.color, 0);
    glNamedFramebufferTexture(f.fbo, GL_DEPTH_ATTACHMENT, f.depth, 0);
    if (glCheckNamedFramebufferStatus(f.fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw std::runtime_error("incomplete framebuffer");
    return f;
}

// Reversed Z, depth in [0, 1], infinite far plane; the frustum's edges as tangents.
glm::dmat4 projection(double l, double r, double b, double t, double near) {
    glm::dmat4 p(0.0);
    p[0][0] = 2 / (r - l), p[1][1] = 2 / (t - b);
    p[2][0] = (r + l) / (r - l), p[2][1] = (t + b) / (t - b), p[2][3] = -1;
    p[3][2] = near;  // depth = near / distance: 1 at the near plane, 0 at infinity
    return p;
}

constexpr double kTerrainDistance = 5;  // m: the "terrain" covering the frame's bottom rows
constexpr int kTerrainRows = 8;

// The host's own drawing before the clouds: a sky-blue clear with alpha 0 (Nephele accumulates
// the clouds' opacity there), far depth, and terrain depth over the bottom rows.
void drawTerrain(const Frame& f, double near) {
    glBindFramebuffer(GL_FRAMEBUFFER, f.fbo);
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glDepthMask(GL_TRUE);
    glClearColor(0.3f, 0.45f, 0.7f, 0.0f);
    glClearDepth(0.0);  // reversed Z: far
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 0, f.width, kTerrainRows);
    glClearDepth(near / kTerrainDistance);
    glClear(GL_DEPTH_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);
}

nephele::Image readFrame(const Frame& f) {
    nephele::Image bottomUp(f.width, f.height, 4), image(f.width, f.height, 4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, f.fbo);
    glReadPixels(0, 0, f.width, f.height, GL_RGBA, GL_FLOAT, bottomUp.pixels.data());
    const std::size_t row = std::size_t(f.width) * 4;
    for (int y = 0; y < f.height; ++y)  // nephele::Image: row 0 at the top
        std::copy_n(&bottomUp.pixels[(f.height - 1 - y) * row], row, &image.pixels[y * row]);
    return image;
}

// The clouds must cover part of each channel above the terrain, and nothing of the terrain.
int check(const nephele::Image& img, int channelWidth) {
    int failures = 0;
    for (int c = 0; c < img.width / channelWidth; ++c) {
        long cloudy = 0, sky = 0;
        float overTerrain = 0;
        for (int y = 0; y < img.height; ++y)
            for (int x = c * channelWidth; x < (c + 1) * channelWidth; ++x) {
                const float a = img.at(x, y, 3);
                if (y >= img.height - kTerrainRows) overTerrain = std::max(overTerrain, a);
                else ++sky, cloudy += a > 0.05f;
            }
        const double fraction = double(cloudy) / double(sky);
        std::printf("nephele_host: channel %d: clouds over %.1f%% of the sky, opacity over the terrain %.3f\n", c,
                    100 * fraction, overTerrain);
        // 1%: any cloud in view covers far more; 0 opacity: terrain at 5 m hides every cloud.
        if (fraction < 0.01) std::fprintf(stderr, "nephele_host: channel %d: the clouds are missing\n", c), ++failures;
        if (overTerrain > 0) std::fprintf(stderr, "nephele_host: channel %d: clouds in front of the terrain\n", c), ++failures;
    }
    return failures;
}

int run(const std::string& scenePath, const std::string& out, int w, int h) {
    makeContext();
    nephele::gl::load(reinterpret_cast<nephele::gl::ProcLoader>(eglGetProcAddress));
    nephele::setLogCallback([](nephele::LogLevel level, std::string_view message) {
        std::fprintf(stderr, "nephele_host: [%d] %.*s\n", int(level), int(message.size()), message.data());
    });
    const nephele::Scene scene = nephele::loadScene(scenePath);
    nephele::SkyRenderer sky;
    sky.prepare(scene);
    nephele::Weather weather = nephele::Weather::of(scene);
    weather.transitionSeconds = 2.0 / 30;  // a change ramps over two frames (a real IG: seconds)
    const Frame frame = makeFrame(2 * w, h);
    const nephele::Camera& cam = scene.camera;
    const glm::dmat4 view = glm::lookAt(cam.position, cam.position + cam.direction, cam.up);
    const double tanY = std::tan(glm::radians(cam.fovYDeg) / 2), tanX = tanY * 2 * w / h;  // both channels
    for (int f = 0; f < 3; ++f) {
        if (f == 1 && !weather.layers.empty())  // a CIGI Weather Control packet arrives
            weather.apply({.layerId = weather.layers.begin()->first, .coverage = 70,
                           .baseElevation = weather.layers.begin()->second.layer.base,
                           .thickness = weather.layers.begin()->second.layer.thickness});
        drawTerrain(frame, cam.nearClip);
        sky.update(1.0 / 30, weather, cam.position);
        for (int c = 0; c < 2; ++c) {
            nephele::ViewDesc v;
            v.view = view;
            v.projection = projection(-tanX + c * tanX, c * tanX, -tanY, tanY, cam.nearClip);
            v.depth = {.reversedZ = true, .zeroToOne = true};
            v.viewport = {c * w, 0, w, h};
            v.framebuffer = frame.fbo;
            v.depthTexture = frame.depth;
            sky.draw(v);
        }
    }
    // The cloud queries (any thread, no GL): what a sensor along the view sees through, and
    // the matter at the heart of the scene's first cloud.
    const double seen = sky.transmittance(cam.position, cam.direction, 20000);
    if (!(seen >= 0 && seen <= 1)) throw std::runtime_error("the cloud queries gave a transmittance outside [0, 1]");
    if (!scene.clouds.empty() && !scene.clouds[0].ellipsoids.empty() && scene.clouds[0].ellipsoids[0].density > 0 &&
        !(sky.densityAt(scene.clouds[0].ellipsoids[0].center) > 0))
        throw std::runtime_error("the cloud queries found no matter at the heart of the first cloud");
    std::fprintf(stderr, "nephele_host: transmittance along the view over 20 km: %.3f\n", seen);
    const nephele::Image image = readFrame(frame);
    nephele::writePfm(out, nephele::channels(image, 0, 3));
    if (glGetError() != GL_NO_ERROR) throw std::runtime_error("a GL error in the host's frame");
    return check(image, w) ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3 && argc != 5) {
        std::fprintf(stderr, "usage: nephele_host SCENE.json OUT.pfm [WIDTH HEIGHT]\n");
        return 2;
    }
    try {
        return run(argv[1], argv[2], argc == 5 ? std::atoi(argv[3]) : 160, argc == 5 ? std::atoi(argv[4]) : 120);
    } catch (const nephele::SceneError& e) {
        std::fprintf(stderr, "nephele_host: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nephele_host: %s\n", e.what());
        return 1;
    }
}
