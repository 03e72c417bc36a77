#include "nephele/sky.hpp"

#include "nephele/gl_state.hpp"
#include "nephele/opaque.hpp"
#include "layer_assets.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

namespace nephele {

LayeredSettings autoLayeredSettings(LayeredSettings base) {
    if (base.nearRadius == 0) base.nearRadius = kAutoNearRadius;
    if (base.blendBand == 0) base.blendBand = kAutoBlendBand;
    base.lod0Radius = std::max(base.lod0Radius, base.nearRadius + base.blendBand + kAutoLod0Margin);
    return base;
}

EllipsoidSettings autoEllipsoidSettings(EllipsoidSettings base) {
    base.reuse = true;
    base.cloudLod = true;
    base.cloudLod = cloudLodApplies(base);
    return base;
}

namespace {
EllipsoidSettings withTimings(EllipsoidSettings s, bool timings) {
    s.timings = s.timings || timings;
    return s;
}
}  // namespace

SkyRenderer::SkyRenderer(SkySettings settings)
    : settings_(std::move(settings)),
      clouds_(withTimings(settings_.ellipsoid, settings_.timings)),
      assets_(std::make_shared<LayerAssets>(settings_.layered)) {
    validate(settings_.layered);
    validate(settings_.nearLod, settings_.layered);
    if (settings_.cellsPerUpdate < 0) throw std::invalid_argument("SkySettings::cellsPerUpdate must be >= 0");
    nearLod_ = std::make_unique<NearLod>(settings_.nearLod, settings_.layered);
    nearLod_->shareAssets(assets_);
}

SkyRenderer::~SkyRenderer() = default;

void SkyRenderer::makeLayered() {
    if (layered_) return;
    layered_ = std::make_unique<LayeredRenderer>(settings_.layered);
    layered_->shareAssets(assets_);
}

SkyStats SkyRenderer::render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds,
                             bool opaqueDepth) {
    SkyStats stats;
    if (scene.layers.empty()) {
        stats.ellipsoids = clouds_.render(scene, view, framebuffer, opaqueDepth);
        return stats;
    }
    assets_->setBackground(false);  // what this frame needs, made now
    makeLayered();
    gl::PartTimer timer(settings_.timings);
    stats.layered = layered_->render(scene, view, framebuffer, timeSeconds);
    stats.farFieldMs = timer.lap();
    const std::vector<Cloud> near = nearLod_->update(scene, view.eye, timeSeconds, &stats.nearLod);
    stats.nearLodMs = timer.lap();
    stats.ellipsoids = clouds_.render(withNearClouds(scene, near), view, framebuffer, opaqueDepth);
    return stats;
}

void SkyRenderer::prepare(const Scene& scene) {
    makeLayered();
    layered_->prepare();
    scene_ = scene;
    explicitClouds_ = scene.clouds.size();
    frame_ = scene;
    time_ = 0;
    drift_.clear();
    updates_ = 0;
    // The layers' lighting and modulation, made now (the one wait); later changes in the background.
    assets_->setBackground(false);
    for (const Layer& layer : scene.layers) {
        assets_->lighting(lightingParameters(scene.medium, layer));
        assets_->modulation(layer.seed);
    }
    assets_->setBackground(true);
    clouds_.updateLights(scene, &scene.camera.position);
    clouds_.waitForLights(scene);  // the explicit clouds lit from the first frame
    warmUp(scene);
    prepared_ = true;
}

SkyUpdateStats SkyRenderer::update(double dt, const Weather& weather, const Vec3& eye) {
    if (!prepared_) throw std::logic_error("SkyRenderer::update: call prepare(scene) first");
    if (!(dt >= 0 && std::isfinite(dt))) throw std::invalid_argument("SkyRenderer::update: dt must be a finite number >= 0 s");
    weather.validate();
    SkyUpdateStats stats;
    time_ += dt;
    // The layers: each one's drift integrated with the wind it has now (continuous when it changes).
    scene_.sun = weather.sun;
    scene_.sun.direction = glm::normalize(weather.sun.direction);
    scene_.sky = weather.sky;
    scene_.layers.clear();
    for (const auto& [id, l] : weather.layers) {
        auto [it, added] = drift_.try_emplace(id, l.layer.windOffset + time_ * l.layer.wind);
        if (!added) it->second += dt * l.layer.wind;
        if (!l.enabled) continue;
        Layer layer = l.layer;
        layer.windOffset = it->second - time_ * layer.wind;  // layerDrift(layer, time_) == the integrated drift
        scene_.layers.push_back(layer);
        // Queue what the layer needs (the near LOD and the layered sky use it when it is ready).
        assets_->lighting(lightingParameters(scene_.medium, layer));
        assets_->modulation(layer.seed);
    }
    stats.layers = int(scene_.layers.size());
    // The compositor's scene: the explicit clouds (kept, not copied again) and this frame's near ones.
    frame_.sun = scene_.sun;
    frame_.sky = scene_.sky;
    frame_.layers = scene_.layers;
    frame_.clouds.resize(explicitClouds_);
    // The first update after prepare() makes every cell in reach; later ones spread them.
    std::vector<Cloud> near = nearLod_->update(scene_, eye, time_, &stats.nearLod, updates_++ > 0 ? settings_.cellsPerUpdate : 0);
    frame_.clouds.insert(frame_.clouds.end(), std::make_move_iterator(near.begin()), std::make_move_iterator(near.end()));
    const auto t0 = std::chrono::steady_clock::now();
    stats.lightVolumes = clouds_.updateLights(frame_, &eye);
    const RadianceUpdateStats light = clouds_.lightStats();
    stats.lightPending = light.pending;
    stats.lightStandIns = light.standIns;
    stats.lightMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats.backgroundJobs = assets_->pending();
    return stats;
}

SkyStats SkyRenderer::draw(const ViewDesc& desc) {
    if (!prepared_) throw std::logic_error("SkyRenderer::draw: call prepare(scene) first");
    HostStateScope scope;  // first: the host's pending GL errors are its own
    const View view = makeView(desc);
    checkHostObjects(desc);
    HostFrame frame;
    frame.framebuffer = desc.framebuffer;
    frame.drawBuffer = desc.drawBuffer;
    frame.hasDepth = desc.hasDepth;
    frame.cloudShadows = desc.cloudShadows;
    frame.srgb = colorTargetOf(desc) == ColorTarget::Srgb8;
    SkyStats stats;
    // The frame's depth once for both renderers: the host's texture, or one copy.
    if (desc.hasDepth && desc.depthTexture != 0) frame.depth = {desc.depthTexture, view.origin};
    else frame.depth = depths_.get({view.camera.width, view.camera.height}).source(frame, view);
    gl::PartTimer timer(settings_.timings);
    if (!scene_.layers.empty()) stats.layered = layered_->render(scene_, view, frame, time_);
    stats.farFieldMs = timer.lap();
    stats.ellipsoids = clouds_.render(frame_, view, frame);
    return stats;
}

// One draw of the scene off-screen, so that the driver builds its variants of the programs
// (llvmpipe compiles a program's code at its first draw) and the layers' textures are uploaded.
void SkyRenderer::warmUp(const Scene& scene) {
    Camera camera = scene.camera;
    camera.width = camera.height = 64;
    const View view = makeView(camera);
    FrameTarget target(64, 64);
    HostFrame frame;
    frame.framebuffer = target.framebuffer();
    if (!scene.layers.empty()) layered_->render(scene, view, frame, 0);
    clouds_.render(scene, view, frame);
}

int SkyRenderer::backgroundJobs() const { return assets_->pending(); }

void SkyRenderer::waitForBackgroundWork() {
    assets_->wait();
    clouds_.waitForLights(frame_);
}

}  // namespace nephele
