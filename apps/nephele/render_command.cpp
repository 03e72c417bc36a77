#include "render_command.hpp"
#include "nephele/metrics.hpp"

#include "output_files.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/layer_volume.hpp"
#include "nephele/noise.hpp"
#include "nephele/opaque.hpp"
#include "nephele/png.hpp"
#include "nephele/resources.hpp"

#include <chrono>
#include <optional>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <iostream>

namespace nephele::cli {

namespace {
constexpr std::pair<Method, const char*> kMethods[] = {
    {Method::Auto, "auto"},         {Method::Ellipsoid, "ellipsoid"}, {Method::Layered, "layered"},
    {Method::Raymarch, "raymarch"}, {Method::Pathtrace, "pathtrace"}, {Method::GardnerExact, "gardner-exact"}};
constexpr int kMaxSize = kMaxImageSize;
}  // namespace

Method parseMethod(const std::string& name) {
    for (auto [m, n] : kMethods)
        if (name == n) return m;
    throw UsageError("--method: unknown method '" + name +
                     "' (expected auto, ellipsoid, layered, raymarch, pathtrace or gardner-exact)");
}

const char* methodName(Method m) {
    for (auto [k, n] : kMethods)
        if (k == m) return n;
    return "?";
}

ChannelOptions parseChannel(const std::string& frustum, double yawDeg, double pitchDeg) {
    ChannelOptions c;
    if (!frustum.empty()) {
        double v[4];
        char extra = 0;
        if (std::sscanf(frustum.c_str(), "%lf,%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &v[3], &extra) != 4)
            throw UsageError(
                "--frustum must be four numbers L,R,B,T (the tangents of the edges at unit distance), got '" + frustum +
                "'");
        for (double x : v)
            if (!(std::isfinite(x) && std::abs(x) <= 100))
                throw UsageError(
                    "--frustum: each tangent must be a finite number in [-100, 100] (edges within 89.4 "
                    "degrees of the axis), got '" +
                    frustum + "'");
        if (!(v[1] - v[0] >= 1e-4 && v[3] - v[2] >= 1e-4))
            throw UsageError("--frustum: L must be less than R and B less than T, got '" + frustum + "'");
        c.frustum = Frustum{v[0], v[1], v[2], v[3]};
    }
    if (!(std::isfinite(yawDeg) && std::abs(yawDeg) <= 360))
        throw UsageError("--yaw-offset must be within [-360, 360] degrees, got " + std::to_string(yawDeg));
    if (!(std::isfinite(pitchDeg) && std::abs(pitchDeg) <= 90))
        throw UsageError("--pitch-offset must be within [-90, 90] degrees, got " + std::to_string(pitchDeg));
    c.yawDeg = yawDeg, c.pitchDeg = pitchDeg;
    return c;
}

View channelView(const Camera& camera, const ChannelOptions& c) {
    if (!c.frustum && c.yawDeg == 0 && c.pitchDeg == 0) return makeView(camera);
    const Frustum f = c.frustum ? *c.frustum : symmetricFrustum(camera.fovYDeg, double(camera.width) / camera.height);
    return makeView(camera, f, c.yawDeg, c.pitchDeg);
}

void applySize(Scene& scene, const RenderOptions& o) {
    Camera& cam = scene.camera;
    const double aspect = double(cam.width) / cam.height;
    auto check = [](const char* what, double v) {
        if (!(v >= 1 && v <= kMaxSize))
            throw UsageError(std::string(what) + " gives an image size of " + std::to_string(std::lround(v)) +
                             " pixels; it must be 1.." + std::to_string(kMaxSize));
        return int(std::lround(v));
    };
    if (o.scale) {
        if (o.width || o.height) throw UsageError("--scale cannot be combined with --width/--height");
        if (!(std::isfinite(*o.scale) && *o.scale > 0)) throw UsageError("--scale must be a positive number");
        cam.width = check("--scale", cam.width * *o.scale);
        cam.height = check("--scale", cam.height * *o.scale);
        return;
    }
    // One of the two alone keeps the camera's aspect ratio.
    if (o.width) cam.width = check("--width", *o.width);
    if (o.height) cam.height = check("--height", *o.height);
    if (o.width && !o.height) cam.height = check("--width", *o.width / aspect);
    if (o.height && !o.width) cam.width = check("--height", *o.height * aspect);
}

std::uint64_t frameBytes(const Scene& scene, const RenderOptions& o) {
    const std::uint64_t pixels = std::uint64_t(scene.camera.width) * std::uint64_t(scene.camera.height);
    // Read back and out: two RGBA floats (the read-back and its flip), RGB and alpha floats,
    // the 8-bit PNG rows; the exact opacity when asked for.
    std::uint64_t perPixel = 16 + 16 + 12 + 4 + 4 + (o.densityAlpha.empty() ? 0 : 4);
    std::uint64_t fixed = 64 << 20;  // shaders, meshes, noise and light volumes: tens of MB
    switch (o.method) {
        case Method::Pathtrace:
        case Method::GardnerExact: break;                  // CPU: the image itself is the read-back's RGBA
        case Method::Raymarch: perPixel += 20 + 4; break;  // GL frame (RGBA32F + depth), depth copy
        case Method::Layered:
            perPixel += 20 + 4 + 12;
            fixed += lightingBytes(o.layered.lighting);
            break;
        case Method::Auto:
            perPixel += 20 + 4 + 12;
            fixed += lightingBytes(o.layered.lighting);
            [[fallthrough]];
        case Method::Ellipsoid:
            perPixel += 20 + 4 + 20;  // GL frame, depth copy, the weighted composite's targets
            fixed += std::uint64_t(o.ellipsoid.atlasMegabytes) << 20;
            break;
    }
    return pixels * perPixel + fixed;
}

void checkFrameMemory(const Scene& scene, const RenderOptions& o) {
    const std::uint64_t need = frameBytes(scene, o), have = availableMemoryBytes();
    if (need > have)
        throw ResourceError(std::string(o.width || o.height || o.scale ? "--width/--height/--scale: " : "") + "a " +
                            std::to_string(scene.camera.width) + "x" + std::to_string(scene.camera.height) +
                            " frame with --method " + methodName(o.method) + " needs about " + formatBytes(need) +
                            " of memory, more than the " + formatBytes(have) + " available");
}

int reportError(const std::exception& e, const std::string& doing) {
    const bool badInput = dynamic_cast<const SceneError*>(&e) || dynamic_cast<const UsageError*>(&e) ||
                          dynamic_cast<const std::invalid_argument*>(&e);
    if (dynamic_cast<const std::bad_alloc*>(&e)) {
        std::cerr << "nephele: " << doing << " failed: out of memory (std::bad_alloc); lower the image size or the "
                  << "settings that size the work\n";
        return 1;
    }
    std::cerr << "nephele: " << (badInput ? "" : doing + " failed: ") << e.what() << "\n";
    return badInput ? 2 : 1;
}

FrameRenderer::FrameRenderer(const RenderOptions& o) : options_(o) {
    if (o.method == Method::GardnerExact || o.method == Method::Pathtrace) {  // CPU: no GL context
        const NoiseSettings& ns = o.ellipsoid.noise;
        noise_ = makeNoiseVolume(ns);
        return;
    }
    ContextOptions co;
    co.backend = o.backend;
    context_ = Context::create(co);
    gl::setChecks(true);  // a frame costs far more than the checks
    opaque_ = std::make_unique<OpaquePass>();
    if (o.method == Method::Raymarch) raymarch_ = std::make_unique<RaymarchRenderer>(o.raymarch);
    else if (o.method == Method::Layered) layered_ = std::make_unique<LayeredRenderer>(o.layered);
    else if (o.method == Method::Auto)
        sky_ = std::make_unique<SkyRenderer>(SkySettings{o.layered, o.nearLod, o.ellipsoid});
    else clouds_ = std::make_unique<EllipsoidRenderer>(o.ellipsoid);
}

FrameRenderer::~FrameRenderer() = default;

Frame FrameRenderer::render(const Scene& sceneIn, double time) {
    // The detail drifts with its wind: at time t it has been carried t * wind.
    std::optional<Scene> drifted;
    if (sceneIn.medium.detail.on() && sceneIn.medium.detail.wind != Vec3(0.0)) {
        drifted = sceneIn;
        drifted->medium.detail.drift = sceneIn.medium.detail.wind * time;
    }
    const Scene& scene = drifted ? *drifted : sceneIn;
    Camera camera = cameraAt(scene, time);
    camera.width = scene.camera.width;
    camera.height = scene.camera.height;
    const View view = channelView(camera, options_.channel);
    Image rgba;
    Frame frame;
    if (options_.method == Method::GardnerExact) {
        rgba = renderGardnerExact(scene, view, noise_, options_.ellipsoid.noise, options_.exactOrder,
                                  model::kWeightExponent, options_.ellipsoid.light, &exactLight_);
    } else if (options_.method == Method::Pathtrace) {
        PathTraceSettings ps = options_.pathtrace;
        ps.progress = ::isatty(2) != 0;
        if (!scene.layers.empty()) ps.layers = std::make_shared<LayerVolumes>(scene, options_.layered, time);
        rgba = options_.cacheDir.empty() ? renderPathTraced(scene, view, ps, &noise_)
                                         : renderPathTracedCached(scene, view, ps, &noise_, options_.cacheDir);
    } else {
        context_->makeCurrent();
        if (!target_ || target_->width() != camera.width || target_->height() != camera.height)
            target_ = std::make_unique<FrameTarget>(camera.width, camera.height);
        opaque_->draw(scene, view, target_->framebuffer());
        const bool objects = !scene.objects.empty();
        gl::glFinish();
        const auto t0 = std::chrono::steady_clock::now();
        if (sky_) {  // auto: the far field, then the near LOD's clouds and the explicit ones
            const SkyStats st = sky_->render(scene, view, target_->framebuffer(), time, objects);
            frame.layered = st.layered, frame.nearLod = st.nearLod, frame.stats = st.ellipsoids;
        } else if (layered_) frame.layered = layered_->render(scene, view, target_->framebuffer(), time);
        else if (raymarch_) raymarch_->render(scene, view, target_->framebuffer(), objects);
        else frame.stats = clouds_->render(scene, view, target_->framebuffer(), objects);
        gl::glFinish();
        frame.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        rgba = target_->readColor();
    }
    if (!options_.densityAlpha.empty()) frame.densityAlpha = exactDensityOpacity(scene, view);
    frame.color = channels(rgba, 0, 3);
    frame.alpha = channels(rgba, 3, 1);
    return frame;
}

Frame renderFrame(const Scene& scene, const RenderOptions& o) {
    if (o.method == Method::Layered) {
        std::size_t clouds = 0;
        for (const Cloud& c : scene.clouds) clouds += c.ellipsoids.empty() ? 0 : 1;
        if (clouds > 0)
            std::cerr << "nephele: note: --method layered draws the far-field layers only; " << clouds
                      << " explicit ellipsoid cloud(s) left out\n";
        if (scene.layers.empty())
            std::cerr << "nephele: note: the scene has no layers; --method layered draws only the sky\n";
    } else if (!scene.layers.empty() && o.method != Method::Auto && o.method != Method::Pathtrace)
        std::cerr << "nephele: note: --method " << methodName(o.method) << " does not draw far-field layers; "
                  << scene.layers.size() << " layer(s) left out (--method auto or layered draws them)\n";
    return FrameRenderer(o).render(scene, o.time);
}

namespace {
// A name that says the other format is refused: the file would hold bytes its name belies
// (-o x.pfm wrote a PNG under that name).
void checkFormatName(const std::string& path, const char* flag, const char* wrong, const char* writes,
                     const char* instead) {
    std::string tail = path.size() >= 4 ? path.substr(path.size() - 4) : path;
    for (char& c : tail) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (tail == wrong)
        throw UsageError(std::string(flag) + " writes " + writes + ", but '" + path + "' is named " + wrong + " (" +
                         instead + ")");
}
}  // namespace

int runRender(const RenderOptions& o) {
    Scene scene;
    Frame frame;
    OutputFiles files;  // written only after the frame rendered, all or nothing
    files.add(
        o.output, [&](const std::string& p) { writePng(p, frame.color, Encoding::Srgb); }, "-o");
    if (!o.alpha.empty())
        files.add(
            o.alpha, [&](const std::string& p) { writePng(p, frame.alpha, Encoding::Linear); }, "--alpha");
    if (!o.pfm.empty())
        files.add(
            o.pfm, [&](const std::string& p) { writePfm(p, frame.color); }, "--pfm");
    if (!o.densityAlpha.empty())
        files.add(
            o.densityAlpha, [&](const std::string& p) { writePng(p, frame.densityAlpha, Encoding::Linear); },
            "--density-alpha");
    try {
        if (!std::isfinite(o.time)) throw UsageError("--time must be a finite number of seconds");
        files.checkPaths();
        files.refuseInput(o.scene, "scene file");
        checkFormatName(o.output, "-o", ".pfm", "a PNG", "--pfm writes linear float RGB");
        checkFormatName(o.alpha, "--alpha", ".pfm", "a PNG", "--pfm writes linear float RGB");
        checkFormatName(o.densityAlpha, "--density-alpha", ".pfm", "a PNG", "--pfm writes linear float RGB");
        checkFormatName(o.pfm, "--pfm", ".png", "a PFM", "-o writes the PNG");
        scene = loadScene(o.scene);
        applySize(scene, o);
        checkFrameMemory(scene, o);
        frame = renderFrame(scene, o);
    } catch (const std::exception& e) {
        return reportError(e, "rendering");
    }
    try {
        files.commit();
    } catch (const std::exception& e) {
        std::cerr << "nephele: writing the output failed: " << e.what() << "\n";
        return 1;
    }
    std::cerr << "nephele: wrote " << o.output;
    if (!o.alpha.empty()) std::cerr << ", " << o.alpha;
    if (!o.pfm.empty()) std::cerr << ", " << o.pfm;
    if (!o.densityAlpha.empty()) std::cerr << ", " << o.densityAlpha;
    std::cerr << " (" << scene.camera.width << "x" << scene.camera.height << ", method " << methodName(o.method)
              << (o.method == Method::GardnerExact || o.method == Method::Pathtrace
                      ? ""
                      : std::string(", ") + backendName(o.backend))
              << ")\n";
    if (o.silhouette) std::cout << "silhouette dimension " << silhouetteDimension(frame.alpha) << "\n";
    const EllipsoidStats& st = frame.stats;
    if (st.ellipsoids > 0)
        std::cerr << "nephele: ellipsoids: " << st.visible << " of " << st.ellipsoids << " visible, " << st.passes
                  << " pass(es), atlas use " << std::lround(100 * st.utilisation) << "%, " << st.drawCalls
                  << " draw calls"
                  << (st.impostors > 0 ? ", " + std::to_string(st.impostors) + " far cloud(s) as impostors" : "")
                  << "\n";
    if (o.method == Method::Auto && frame.layered.sceneLayers > 0) {
        const NearLodStats& n = frame.nearLod;
        std::cerr << "nephele: near LOD: " << n.cells << " cell(s) within "
                  << o.layered.nearRadius + o.layered.blendBand << " m, " << n.clouds << " cumulus spawned ("
                  << n.fading << " fading in the blend band), " << n.ellipsoids << " ellipsoids\n";
    }
    if (frame.layered.sceneLayers > 0)
        std::cerr << "nephele: layers: " << frame.layered.sceneLayers << " scene layer(s), " << frame.layered.instances
                  << " instances in " << frame.layered.drawCalls << " draw calls"
                  << (frame.layered.precomputeMs > 0
                          ? ", lighting precomputed in " + std::to_string(std::lround(frame.layered.precomputeMs)) +
                                " ms"
                          : std::string(", lighting from the cache"))
                  << "\n";
    return 0;
}

}  // namespace nephele::cli
