// An image generator (IG) written against the installed package, as docs/embedding.md tells
// it: its own headless EGL context and framebuffer (a float picture in colour attachment 1, an
// 8-bit symbology overlay in attachment 0, a DEPTH_COMPONENT32F depth texture without stencil,
// reversed Z with an infinite far plane), two off-axis display channels side by side, the sun
// and the ambient from the date, time and place, background work that never stalls the frame,
// a CIGI Weather Control change ramped mid-flight, and the cloud queries and the clouds' light
// at its own aircraft, flying into a cloud. It writes the last frame to OUT.pfm and exits 1 when
// something is wrong (the clouds missing, in front of the canopy, the overlay touched, a GL
// error left, a warning logged, the transition popping, the queries not seeing the cloud), 2 on a
// bad scene.
//
//   nephele_host SCENE.json OUT.pfm [WIDTH HEIGHT]
#include "nephele/geodetic.hpp"
#include "nephele/gl.hpp"
#include "nephele/image.hpp"
#include "nephele/log.hpp"
#include "nephele/sky.hpp"
#include "nephele/time_of_day.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using namespace nephele::gl;  // the host reaches GL through the entry points Nephele loaded
using Clock = std::chrono::steady_clock;

namespace {

// A surfaceless OpenGL 4.5 core context (Mesa), current on this thread.
void makeContext() {
    EGLDisplay display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY || !eglInitialize(display, nullptr, nullptr) || !eglBindAPI(EGL_OPENGL_API))
        throw std::runtime_error("no EGL display for desktop OpenGL");
    const EGLint attribs[] = {
        EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
        EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    EGLContext context = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
    if (context == EGL_NO_CONTEXT || !eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))
        throw std::runtime_error("no OpenGL 4.5 core context");
}

// The host's framebuffer: its symbology overlay in attachment 0 (Nephele must leave it alone),
// its picture in attachment 1 (where Nephele draws), a float depth texture without stencil.
struct Frame {
    GLuint fbo = 0, overlay = 0, color = 0, depth = 0;
    int width = 0, height = 0;
};
constexpr GLenum kPicture = GL_COLOR_ATTACHMENT1;               // ViewDesc::drawBuffer
constexpr float kOverlayClear[4] = {0.25f, 0.5f, 0.75f, 1.0f};  // the overlay as the host left it

Frame makeFrame(int w, int h) {
    Frame f{0, 0, 0, 0, w, h};
    glCreateTextures(GL_TEXTURE_2D, 1, &f.overlay);
    glTextureStorage2D(f.overlay, 1, GL_RGBA8, w, h);
    glCreateTextures(GL_TEXTURE_2D, 1, &f.color);
    glTextureStorage2D(f.color, 1, GL_RGBA16F, w, h);
    glCreateTextures(GL_TEXTURE_2D, 1, &f.depth);
    glTextureStorage2D(f.depth, 1, GL_DEPTH_COMPONENT32F, w, h);
    glCreateFramebuffers(1, &f.fbo);
    glNamedFramebufferTexture(f.fbo, GL_COLOR_ATTACHMENT0, f.overlay, 0);
    glNamedFramebufferTexture(f.fbo, kPicture, f.color, 0);
    glNamedFramebufferTexture(f.fbo, GL_DEPTH_ATTACHMENT, f.depth, 0);
    const GLenum buffers[] = {GL_COLOR_ATTACHMENT0, kPicture};
    glNamedFramebufferDrawBuffers(f.fbo, 2, buffers);
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

constexpr double kCanopyDistance = 5;  // m: the canopy's frame over the frame's top rows, against the sky
constexpr int kCanopyRows = 8;

// The host's drawing before the clouds: the overlay's clear, its sky (the clear sky's horizon,
// alpha 0: Nephele accumulates the clouds' opacity there), far depth, and the canopy frame
// (lit by the ambient's ground light).
void drawHost(const Frame& f, const nephele::Sky& sky, double near) {
    glBindFramebuffer(GL_FRAMEBUFFER, f.fbo);
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glDepthMask(GL_TRUE);
    const float background[4] = {float(sky.horizon.r), float(sky.horizon.g), float(sky.horizon.b), 0.0f};
    const float far = 0.0f, canopy = float(near / kCanopyDistance);
    const float canopyColor[4] = {0.1f * float(sky.ground.r), 0.1f * float(sky.ground.g), 0.1f * float(sky.ground.b),
                                  0.0f};
    glClearBufferfv(GL_COLOR, 0, kOverlayClear);
    glClearBufferfv(GL_COLOR, 1, background);
    glClearBufferfv(GL_DEPTH, 0, &far);
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, f.height - kCanopyRows, f.width, kCanopyRows);
    glClearBufferfv(GL_COLOR, 1, canopyColor);
    glClearBufferfv(GL_DEPTH, 0, &canopy);
    glDisable(GL_SCISSOR_TEST);
}

// The host's aircraft in one channel: a small block of its colour and depth where it projects.
void drawAircraft(const nephele::ViewDesc& v, const nephele::Vec3& at, const glm::dvec3& radiance) {
    const glm::dvec4 clip = v.projection * v.view * glm::dvec4(at, 1.0);
    if (clip.w <= 0) return;
    const glm::dvec2 pixel = glm::dvec2(v.viewport.x, v.viewport.y) +
                             (glm::dvec2(clip) / clip.w * 0.5 + 0.5) * glm::dvec2(v.viewport.z, v.viewport.w);
    const int half = std::max(2, v.viewport.w / 40), x = int(pixel.x) - half, y = int(pixel.y) - half;
    const int x0 = std::max(x, v.viewport.x), x1 = std::min(x + 2 * half, v.viewport.x + v.viewport.z);
    if (x1 <= x0) return;
    const float color[4] = {float(radiance.r), float(radiance.g), float(radiance.b), 0.0f},
                depth = float(clip.z / clip.w);
    glEnable(GL_SCISSOR_TEST);
    glScissor(x0, y, x1 - x0, 2 * half);
    glClearBufferfv(GL_COLOR, 1, color);
    glClearBufferfv(GL_DEPTH, 0, &depth);
    glDisable(GL_SCISSOR_TEST);
}

nephele::Image readAttachment(const Frame& f, GLenum attachment) {
    nephele::Image bottomUp(f.width, f.height, 4), image(f.width, f.height, 4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, f.fbo);
    glReadBuffer(attachment);
    glReadPixels(0, 0, f.width, f.height, GL_RGBA, GL_FLOAT, bottomUp.pixels.data());
    const std::size_t row = std::size_t(f.width) * 4;
    for (int y = 0; y < f.height; ++y)  // nephele::Image: row 0 at the top
        std::copy_n(&bottomUp.pixels[(f.height - 1 - y) * row], row, &image.pixels[y * row]);
    return image;
}

// The mean cloud opacity (alpha) over the rows above the canopy: what a pop would jump.
double skyOpacity(const nephele::Image& img) {
    double sum = 0;
    for (int y = kCanopyRows; y < img.height; ++y)  // nephele::Image: row 0 at the top
        for (int x = 0; x < img.width; ++x) sum += img.at(x, y, 3);
    return sum / (double(img.width) * (img.height - kCanopyRows));
}

// The flight model's position at s in [0, 1] along a short leg.
nephele::Geodetic along(const nephele::Geodetic (&leg)[2], double s) {
    return {std::lerp(leg[0].latitudeDeg, leg[1].latitudeDeg, s),
            std::lerp(leg[0].longitudeDeg, leg[1].longitudeDeg, s), std::lerp(leg[0].heightM, leg[1].heightM, s)};
}

// The sun and the clear sky at the origin, `seconds` after `start` (the same UTC day).
nephele::Daylight daylightAt(const nephele::EnuFrame& world, nephele::UtcTime start, double seconds) {
    const double s = start.hour * 3600 + start.minute * 60 + start.second + seconds;
    start.hour = int(s / 3600) % 24, start.minute = int(s / 60) % 60, start.second = std::fmod(s, 60);
    return nephele::daylight(start, world.origin().latitudeDeg, world.origin().longitudeDeg);
}

int fail(const char* what) {
    std::fprintf(stderr, "nephele_host: %s\n", what);
    return 1;
}

// The clouds must cover part of each channel above the canopy and none of the canopy; the
// overlay must be as the host left it.
int checkFrame(const nephele::Image& img, const nephele::Image& overlay, int channelWidth) {
    int failures = 0;
    for (int c = 0; c < img.width / channelWidth; ++c) {
        long cloudy = 0, sky = 0;
        float overCanopy = 0;
        for (int y = 0; y < img.height; ++y)
            for (int x = c * channelWidth; x < (c + 1) * channelWidth; ++x) {
                const float a = img.at(x, y, 3);
                if (y < kCanopyRows) overCanopy = std::max(overCanopy, a);
                else ++sky, cloudy += a > 0.05f;
            }
        const double fraction = double(cloudy) / double(sky);
        std::printf("nephele_host: channel %d: clouds over %.1f%% of the sky, opacity over the canopy %.3f\n", c,
                    100 * fraction, overCanopy);
        // 1%: any cloud in view covers far more; 0 opacity: a canopy at 5 m hides every cloud.
        if (fraction < 0.01) failures += fail("the clouds are missing from a channel");
        if (overCanopy > 0) failures += fail("clouds in front of the canopy");
    }
    float touched = 0;
    for (int y = 0; y < overlay.height; ++y)
        for (int x = 0; x < overlay.width; ++x)
            for (int k = 0; k < 4; ++k) touched = std::max(touched, std::abs(overlay.at(x, y, k) - kOverlayClear[k]));
    if (touched > 1.0f / 255) failures += fail("the overlay (draw buffer 0) was drawn into");
    return failures;
}

// A ramp of `frames` frames moves the opacity about 1/frames of its way each frame; a pop moves
// it most of the way in one. Measured from the frame before the change to the ramp's end.
int checkRamp(const std::vector<double>& opacity, int first, int frames) {
    const int last = std::min(first + frames, int(opacity.size()) - 1);
    const double total = std::abs(opacity[last] - opacity[first - 1]);
    double step = 0;
    for (int f = first; f <= last; ++f) step = std::max(step, std::abs(opacity[f] - opacity[f - 1]));
    std::printf("nephele_host: the change moved the sky's opacity by %.4f over %d frames, at most %.4f a frame\n",
                total, last - first + 1, step);
    if (total < 0.002) return fail("the weather change did not show");
    // Half the way in one frame is a pop: a linear ramp of 6 frames moves a sixth.
    return step > 0.5 * total ? fail("the weather change popped instead of ramping") : 0;
}

struct Options {
    std::string scene, out;
    int width = 160, height = 120;
};

int run(const Options& o) {
    makeContext();
    nephele::gl::load(reinterpret_cast<nephele::gl::ProcLoader>(eglGetProcAddress));
    std::atomic<int> errors = 0;
    nephele::setLogCallback([&errors](nephele::LogLevel level, std::string_view message) {
        if (level >= nephele::LogLevel::Warning) ++errors;  // e.g. a GL error the host left pending
        std::fprintf(stderr, "nephele_host: [%s] %.*s\n", nephele::logLevelName(level), int(message.size()),
                     message.data());
    });
    // The database's origin (the scene's world is east-north-up there) and the clock: the sun
    // and the clear sky's ambient for the clouds and for the host's own lighting.
    const nephele::EnuFrame world({.latitudeDeg = 43.6045, .longitudeDeg = 1.4440, .heightM = 150});
    const nephele::UtcTime start{2026, 6, 21, 16, 30, 0};
    nephele::Daylight day = daylightAt(world, start, 0);
    nephele::Scene scene = nephele::loadScene(o.scene);
    scene.sun = day.sun, scene.sky = day.sky;

    // Background work: the workers on equal terms with the frame (Idle, the default, or Low
    // yield to a host that keeps every core busy), one core per job, a flag when all is done;
    // at most kCellsPerUpdate near cells made per update (the per-frame budget); prepare()
    // builds the shaders and returns, the first frames lit by stand-ins.
    std::atomic<bool> idle = false;
    nephele::SkySettings settings;
    settings.background.priority = nephele::BackgroundSettings::Priority::Normal;
    settings.background.threads = 1;
    settings.background.onIdle = [&idle] { idle = true; };
    settings.cellsPerUpdate = nephele::kCellsPerUpdate;
    settings.prepareWaits = false;
    nephele::SkyRenderer sky(settings);
    const auto t0 = Clock::now();
    sky.prepare(scene);
    std::printf("nephele_host: prepare() %.2f s, %d jobs pending\n",
                std::chrono::duration<double>(Clock::now() - t0).count(), sky.pending());

    nephele::Weather weather = nephele::Weather::of(scene);
    const Frame frame = makeFrame(2 * o.width, o.height);
    const nephele::Camera& cam = scene.camera;
    // Two display channels side by side, each an off-axis half of one wide view.
    const double tanY = std::tan(glm::radians(cam.fovYDeg) / 2), tanX = tanY * 2 * o.width / o.height;
    std::array<nephele::ViewDesc, 2> channels;
    for (int c = 0; c < 2; ++c) {
        nephele::ViewDesc& v = channels[c];
        v.projection = projection(-tanX + c * tanX, c * tanX, -tanY, tanY, cam.nearClip);
        v.depth = {.reversedZ = true, .zeroToOne = true};
        v.viewport = {c * o.width, 0, o.width, o.height};
        v.framebuffer = frame.fbo;
        v.drawBuffer = kPicture;
        v.depthTexture = frame.depth;  // the attachment itself: Nephele reads it, never writes it
    }
    // The flight, as the host's flight model gives it (latitude, longitude, height): from the
    // camera's side into the heart of the scene's first cloud, the eye chasing the aircraft.
    if (scene.clouds.empty() || scene.clouds[0].ellipsoids.empty())
        throw nephele::SceneError(o.scene, "clouds", "the host needs a cloud to fly into");
    const nephele::Vec3 heart = scene.clouds[0].ellipsoids[0].center, chase = cam.position - heart;
    const nephele::Geodetic leg[2] = {world.enuToGeodetic(heart + 0.3 * chase), world.enuToGeodetic(heart)};
    constexpr int kFlightFrames = 12, kRampFrames = 6;
    constexpr double dt = 1.0 / 30;
    constexpr auto kHoverLimit = std::chrono::seconds(120);
    std::vector<double> opacity;
    double clock = 0;  // s since `start`
    int readyFrame = -1, changeFrame = -1;
    nephele::CloudPresence in;

    for (int f = 0; changeFrame < 0 || f < changeFrame + kFlightFrames; ++f) {
        const auto frameStart = Clock::now();
        // The aircraft hovers until the background work is done (the clouds' grids, the layer's
        // lighting: stand-ins meanwhile), then a CIGI Weather Control packet comes (more cover,
        // ramped over kRampFrames frames; a real IG: seconds) and it flies into the cloud.
        if (readyFrame < 0 && idle) readyFrame = f;  // this frame's update takes all that was made
        if (changeFrame < 0 && readyFrame >= 0 && f > readyFrame) {
            const auto& [id, layer] = *weather.layers.begin();
            weather.apply(
                {.layerId = id, .coverage = 90, .baseElevation = layer.layer.base, .thickness = layer.layer.thickness});
            weather.transitionSeconds = kRampFrames * dt;
            changeFrame = f;
        }
        if (changeFrame < 0 && frameStart - t0 > kHoverLimit)
            throw std::runtime_error("the background work never finished");
        const double s = changeFrame < 0 ? 0.0 : double(f - changeFrame) / (kFlightFrames - 1);
        const nephele::Vec3 aircraft = world.geodeticToEnu(along(leg, s)), eye = aircraft + chase;
        const glm::dmat4 view = glm::lookAt(eye, aircraft, glm::dvec3(0, 0, 1));
        // The sun follows the clock once a simulated minute (0.25 degree): each new sun is a new
        // weather and new light for every cloud, too much to take every frame.
        if (std::floor((clock + dt) / 60) > std::floor(clock / 60)) {
            day = daylightAt(world, start, clock + dt);
            weather.sun = day.sun, weather.sky = day.sky;
        }
        clock += dt;
        const nephele::SkyUpdateStats u = sky.update(dt, weather, eye);

        // At the aircraft: the matter (icing, turbulence), inside or not, the sun through every
        // cloud and layer for its sunlit side, and the clouds' diffuse light.
        const double sigma = sky.densityAt(aircraft);
        in = sky.insideCloud(aircraft);
        const double sunT = sky.transmittance(aircraft, weather.sun.direction, std::numeric_limits<double>::infinity());
        const nephele::Vec3 normal = glm::normalize(eye - aircraft);
        const nephele::SurfaceLight light = sky.lightAt(aircraft, normal);
        const glm::dvec3 sunE =
            weather.sun.color * weather.sun.intensity * std::max(glm::dot(normal, weather.sun.direction), 0.0);
        const glm::dvec3 radiance = 0.4 / std::numbers::pi * (sunE * sunT + light.diffuse);  // albedo 0.4, Lambertian

        drawHost(frame, day.sky, cam.nearClip);
        for (nephele::ViewDesc& v : channels) {
            v.view = view;
            drawAircraft(v, aircraft, radiance);
            sky.draw(v);
        }
        opacity.push_back(skyOpacity(readAttachment(frame, kPicture)));
        if (changeFrame >= 0 || f == readyFrame || f % 30 == 0)
            std::printf(
                "nephele_host: frame %3d %4.0f ms: transition %.2f, pending %d, opacity %.4f; aircraft: "
                "%.4f /m, %s (%.1f m deep), sun through the clouds %.3f\n",
                f, std::chrono::duration<double, std::milli>(Clock::now() - frameStart).count(), u.transition,
                sky.pending(), opacity[f], sigma, in.inside ? "inside" : "outside", in.depth, sunT);
        std::this_thread::sleep_until(frameStart + std::chrono::duration<double>(dt));  // the host's frame rate
    }

    const nephele::Image image = readAttachment(frame, kPicture);
    nephele::writePfm(o.out, nephele::channels(image, 0, 3));
    int failures = checkFrame(image, readAttachment(frame, GL_COLOR_ATTACHMENT0), o.width);
    failures += checkRamp(opacity, changeFrame, kRampFrames);
    if (!in.inside) failures += fail("the aircraft is at the cloud's heart and the queries do not see it inside");
    if (glGetError() != GL_NO_ERROR) failures += fail("a GL error was left in the host's frame");
    if (errors > 0) failures += fail("Nephele logged warnings or errors");
    return failures ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3 && argc != 5) {
        std::fprintf(stderr, "usage: nephele_host SCENE.json OUT.pfm [WIDTH HEIGHT]\n");
        return 2;
    }
    std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress and failures in order in a CI log
    Options o{argv[1], argv[2]};
    if (argc == 5) o.width = std::atoi(argv[3]), o.height = std::atoi(argv[4]);
    try {
        return run(o);
    } catch (const nephele::SceneError& e) {
        std::fprintf(stderr, "nephele_host: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nephele_host: %s\n", e.what());
        return 1;
    }
}
