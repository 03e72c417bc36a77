// SkyRenderer (sky.hpp): the layered far field and the compositor's explicit and near clouds as one
// host API, behind its Impl.
#include "nephele/sky.hpp"

#include "nephele/gl_state.hpp"
#include "nephele/opaque.hpp"
#include "nephele/per_view.hpp"
#include "cloud_field.hpp"
#include "layer_assets.hpp"
#include "weather_blend.hpp"

#include <chrono>
#include <functional>
#include <cmath>
#include <map>
#include <mutex>
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

// The host's completion signal: each worker calls fire() when it runs dry; the host is told
// when nothing is pending anywhere. Shared with the workers' settings, so that a worker
// finishing while the renderer is destroyed finds it closed.
struct IdleSignal {
    std::mutex mutex;
    bool open = true;
    std::function<void()> host;
    std::function<int()> pending;
    void fire() {
        std::lock_guard lock(mutex);
        if (open && host && pending && pending() == 0) host();
    }
};

// `s` with its background settings handed to both workers, their onIdle routed through `idle`.
SkySettings withBackground(SkySettings s, const std::shared_ptr<IdleSignal>& idle) {
    validate(s.background);
    idle->host = s.background.onIdle;
    BackgroundSettings worker = s.background;
    worker.onIdle = [signal = std::weak_ptr<IdleSignal>(idle)] {
        if (auto sig = signal.lock()) sig->fire();
    };
    s.layered.background = worker;
    s.ellipsoid.light.backgroundWork = worker;
    return s;
}
}  // namespace

// What SkyRenderer holds (sky.hpp): the compositor for the explicit and the near clouds, the
// layered sky, the near LOD, the layers' lighting and modulation jobs they share, and the host
// API's state between prepare(), update() and draw().
struct SkyRenderer::Impl {
    explicit Impl(SkySettings settings);
    ~Impl();
    void makeLayered();
    void warmUp(const Scene& scene);
    SkyStats render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds, bool opaqueDepth);
    void prepare(const Scene& scene);
    SkyUpdateStats update(double dt, const Weather& weather, const Vec3& eye);
    SkyStats draw(const ViewDesc& desc);
    int backgroundJobs() const;
    void waitForBackgroundWork();
    int pending() const { return backgroundJobs() + clouds_.pendingLights(); }
    // Makes the field the cloud queries read from this update's clouds and layers (by CIGI id).
    void publishField(std::vector<Cloud>& near, const Vec3& eye, const std::vector<std::pair<int, Layer>>& layers);
    std::shared_ptr<const CloudField> field(const char* call) const;

    std::shared_ptr<IdleSignal> idle_ = std::make_shared<IdleSignal>();
    SkySettings settings_;
    EllipsoidRenderer clouds_;
    std::shared_ptr<LayerAssets> assets_;
    std::unique_ptr<LayeredRenderer> layered_;  // made by prepare(), or at render()'s first scene with layers
    std::unique_ptr<NearLod> nearLod_;
    // The host API's state.
    bool prepared_ = false;
    Scene scene_;  // the prepared scene with the current weather's sun, sky and layers
    Scene frame_;  // scene_ with the near LOD's clouds after its explicit ones (what the compositor draws)
    std::size_t explicitClouds_ = 0;
    double time_ = 0;
    long long updates_ = 0;      // since prepare()
    std::map<int, Vec2> drift_;  // by CIGI layer id: how far its wind has moved it (m)
    // The weather transition: what is shown, where the transition started (what was shown then),
    // the weather it goes to (the last one given) and the time since it started.
    ShownWeather shown_, from_;
    Weather target_;
    double elapsed_ = 0;
    Scene nearScene_;            // the near LOD's layers: each at its own density, its clouds' weights
    std::vector<double> fades_;  // times its fade (the far field draws density x fade)
    PerViewCache<FrameDepth> depths_;
    // The cloud queries' state: the noise volume and the explicit clouds' matter (made by
    // prepare()), each layer's last textures (a layer whose new ones are being made is queried
    // with these, as it is drawn), and the field of the last update, swapped under the mutex.
    std::shared_ptr<const NoiseVolume> noise_;
    std::shared_ptr<const CloudMatter> explicitMatter_;
    std::map<int, CloudField::LayerEntry> queryLayers_;
    mutable std::mutex fieldMutex_;
    std::shared_ptr<const CloudField> field_;
};

SkyRenderer::Impl::Impl(SkySettings settings)
    : settings_(withBackground(std::move(settings), idle_)),
      clouds_(withTimings(settings_.ellipsoid, settings_.timings)),
      assets_(std::make_shared<LayerAssets>(settings_.layered)) {
    validate(settings_.layered);
    validate(settings_.nearLod, settings_.layered);
    if (settings_.cellsPerUpdate < 0) throw std::invalid_argument("SkySettings::cellsPerUpdate must be >= 0");
    nearLod_ = std::make_unique<NearLod>(settings_.nearLod, settings_.layered);
    nearLod_->shareAssets(assets_);
    idle_->pending = [this] { return pending(); };
}

SkyRenderer::Impl::~Impl() {
    std::lock_guard lock(idle_->mutex);  // a worker's signal from now on finds it closed
    idle_->open = false;
}

void SkyRenderer::Impl::makeLayered() {
    if (layered_) return;
    layered_ = std::make_unique<LayeredRenderer>(settings_.layered);
    layered_->shareAssets(assets_);
}

SkyStats SkyRenderer::Impl::render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds,
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

void SkyRenderer::Impl::prepare(const Scene& scene) {
    makeLayered();
    layered_->prepare();
    scene_ = scene;
    // The sun as update() takes it (normalised), so that the first update finds the grids made
    // here (a grid's key holds the sun's direction to the last bit).
    scene_.sun.direction = glm::normalize(scene.sun.direction);
    explicitClouds_ = scene.clouds.size();
    // The host draws its own objects (the scene's are not drawn; with object_light "all" the
    // compositor would draw them again, lit): lightAt() gives it their light.
    scene_.objects.clear();
    frame_ = scene_;
    time_ = 0;
    drift_.clear();
    updates_ = 0;
    target_ = Weather::of(scene);
    shown_ = from_ = shownOf(target_);
    elapsed_ = 0;
    nearScene_ = Scene{};
    nearScene_.medium = scene.medium;
    // The layers' lighting and modulation, made now (the one wait) or queued; later changes in
    // the background.
    assets_->setBackground(!settings_.prepareWaits);
    for (const Layer& layer : scene.layers) {
        assets_->lighting(lightingParameters(scene.medium, layer));
        assets_->modulation(layer.seed);
    }
    assets_->setBackground(true);
    const NoiseSettings& ns = settings_.ellipsoid.noise;
    noise_ = std::make_shared<const NoiseVolume>(makeNoiseVolume(ns));
    explicitMatter_ =
        std::make_shared<const CloudMatter>(scene, noise_.get(), scene.camera.position, kMaxOpticalDepth, true);
    queryLayers_.clear();
    std::vector<std::pair<int, Layer>> layers;
    for (std::size_t i = 0; i < scene.layers.size(); ++i)
        layers.emplace_back(cigiLayerId(int(i)), scene.layers[i]);  // as Weather::of
    std::vector<Cloud> noNear;
    publishField(noNear, scene.camera.position, layers);
    clouds_.updateLights(scene_, &scene.camera.position);
    if (settings_.prepareWaits) clouds_.waitForLights(scene_);  // the explicit clouds lit from the first frame
    warmUp(scene_);
    prepared_ = true;
}

SkyUpdateStats SkyRenderer::Impl::update(double dt, const Weather& weather, const Vec3& eye) {
    if (!prepared_) throw std::logic_error("SkyRenderer::update: call prepare(scene) first");
    if (!(dt >= 0 && std::isfinite(dt)))
        throw std::invalid_argument("SkyRenderer::update: dt must be a finite number >= 0 s");
    weather.validate();
    SkyUpdateStats stats;
    time_ += dt;
    // A weather unlike the last starts a transition from what is shown now (mid-way of another
    // one included: the frames stay continuous); its transitionSeconds says how long it takes.
    if (!weather.sameAs(target_)) {
        from_ = shown_;
        target_ = weather;
        elapsed_ = 0;
    } else {
        elapsed_ += dt;
    }
    const double duration = target_.transitionSeconds;
    stats.transition = duration > 0 ? std::min(elapsed_ / duration, 1.0) : 1.0;
    shown_ = blendShown(from_, target_, stats.transition);
    scene_.sun = shown_.sun;
    scene_.sun.direction = glm::normalize(shown_.sun.direction);
    scene_.sky = shown_.sky;
    scene_.medium.detail.drift = scene_.medium.detail.wind * time_;  // the detail carried by its wind
    // The layers: each one's drift integrated with the wind it has now (continuous when it
    // changes), a disabled one's too, so that it comes back where its wind has taken it.
    auto drift = [&](int id, const Layer& layer) -> const Vec2& {
        auto [it, added] = drift_.try_emplace(id, layer.windOffset + time_ * layer.wind);
        if (!added) it->second += dt * layer.wind;
        return it->second;
    };
    for (const auto& [id, l] : target_.layers)
        if (!shown_.layers.count(id)) drift(id, l.layer);
    scene_.layers.clear();
    nearScene_.layers.clear();
    fades_.clear();
    std::vector<std::pair<int, Layer>> layerIds;
    for (const auto& [id, shown] : shown_.layers) {
        Layer layer = shown.layer;
        layer.windOffset = drift(id, layer) - time_ * layer.wind;  // layerDrift(layer, time_) == the integrated drift
        nearScene_.layers.push_back(layer);
        fades_.push_back(shown.fade);
        layer = farLayer({layer, shown.fade});
        scene_.layers.push_back(layer);
        layerIds.emplace_back(id, layer);
        // Queue what the layer needs (the near LOD and the layered sky use it when it is ready);
        // mid-transition its lighting is that of the thickness it goes to (Layer::lightingThickness).
        assets_->lighting(lightingParameters(scene_.medium, layer));
        assets_->modulation(layer.seed);
    }
    stats.layers = int(scene_.layers.size());
    frame_.medium.detail.drift = scene_.medium.detail.drift;
    // The compositor's scene: the explicit clouds (kept, not copied again) and this frame's near ones.
    frame_.sun = scene_.sun;
    frame_.sky = scene_.sky;
    // Mid-transition the clouds' grids are made for the sun and sky it goes to: one grid per
    // cloud and change (a grid a frame would never finish while the sun moves). What it goes to is
    // what the last frame of the ramp shows, to the bit, so that its key is the ramp's.
    if (stats.transition < 1) {
        const ShownWeather end = blendShown(from_, target_, 1.0);
        frame_.lighting = Scene::Lighting{glm::normalize(end.sun.direction), end.sky};
    } else {
        frame_.lighting.reset();
    }
    frame_.layers = scene_.layers;
    frame_.clouds.resize(explicitClouds_);
    // The first update after prepare() makes every cell in reach; later ones spread them.
    std::vector<Cloud> near =
        nearLod_->update(nearScene_, eye, time_, &stats.nearLod, updates_++ > 0 ? settings_.cellsPerUpdate : 0, fades_);
    publishField(near, eye, layerIds);
    frame_.clouds.insert(frame_.clouds.end(), std::make_move_iterator(near.begin()),
                         std::make_move_iterator(near.end()));
    const auto t0 = std::chrono::steady_clock::now();
    stats.lightVolumes = clouds_.updateLights(frame_, &eye);
    const RadianceUpdateStats light = clouds_.lightStats();
    stats.lightPending = light.pending;
    stats.lightStandIns = light.standIns;
    stats.lightMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats.backgroundJobs = assets_->pending();
    return stats;
}

SkyStats SkyRenderer::Impl::draw(const ViewDesc& desc) {
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
void SkyRenderer::Impl::warmUp(const Scene& scene) {
    Camera camera = scene.camera;
    camera.width = camera.height = 64;
    const View view = makeView(camera);
    FrameTarget target(64, 64);
    HostFrame frame;
    frame.framebuffer = target.framebuffer();
    if (!scene.layers.empty()) layered_->render(scene, view, frame, 0);
    clouds_.render(scene, view, frame);
}

void SkyRenderer::Impl::publishField(std::vector<Cloud>& near, const Vec3& eye,
                                     const std::vector<std::pair<int, Layer>>& layers) {
    std::shared_ptr<const CloudMatter> nearMatter;
    if (!near.empty()) {
        Scene nearScene;  // the near clouds, borrowed for the matter's making
        nearScene.medium = scene_.medium;
        nearScene.clouds = std::move(near);
        nearMatter = std::make_shared<const CloudMatter>(nearScene, noise_.get(), eye, kMaxOpticalDepth, true);
        near = std::move(nearScene.clouds);
    }
    std::map<int, CloudField::LayerEntry> now;
    std::vector<CloudField::LayerEntry> entries;
    for (const auto& [id, layer] : layers) {
        CloudField::LayerEntry e;
        e.layer = layer;
        e.nearLod = layer.nearLod;
        e.light = assets_->lighting(lightingParameters(scene_.medium, layer));  // nullptr while being made
        e.modulation = assets_->modulation(layer.seed);
        if (auto last = queryLayers_.find(id); last != queryLayers_.end()) {
            if (!e.light) e.light = last->second.light;
            if (!e.modulation) e.modulation = last->second.modulation;
        }
        // A new layer, as the layered sky draws it: with the nearest made.
        if (!e.light) e.light = assets_->nearestLighting(lightingParameters(scene_.medium, layer));
        if (!e.modulation) e.modulation = assets_->nearestModulation(layer.seed);
        now[id] = e;
        entries.push_back(std::move(e));
    }
    queryLayers_ = std::move(now);
    auto field = std::make_shared<const CloudField>(explicitMatter_, std::move(nearMatter), scene_.medium,
                                                    settings_.layered, std::move(entries), eye, time_);
    std::lock_guard lock(fieldMutex_);
    field_ = std::move(field);
}

std::shared_ptr<const CloudField> SkyRenderer::Impl::field(const char* call) const {
    std::lock_guard lock(fieldMutex_);
    if (!field_) throw std::logic_error(std::string("SkyRenderer::") + call + ": call prepare(scene) first");
    return field_;
}

int SkyRenderer::Impl::backgroundJobs() const { return assets_->pending(); }

void SkyRenderer::Impl::waitForBackgroundWork() {
    assets_->wait();
    clouds_.waitForLights(frame_);
}

// ---- SkyRenderer: the public face of Impl.
SkyRenderer::SkyRenderer(SkySettings settings) : impl_(std::make_unique<Impl>(std::move(settings))) {}
SkyRenderer::~SkyRenderer() = default;
const SkySettings& SkyRenderer::settings() const { return impl_->settings_; }
void SkyRenderer::prepare(const Scene& scene) { impl_->prepare(scene); }
SkyUpdateStats SkyRenderer::update(double dt, const Weather& weather, const Vec3& eye) {
    return impl_->update(dt, weather, eye);
}
SkyStats SkyRenderer::draw(const ViewDesc& view) { return impl_->draw(view); }
double SkyRenderer::time() const { return impl_->time_; }
int SkyRenderer::backgroundJobs() const { return impl_->backgroundJobs(); }
int SkyRenderer::pending() const { return impl_->pending(); }
void SkyRenderer::waitForBackgroundWork() { impl_->waitForBackgroundWork(); }
SkyStats SkyRenderer::render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds,
                             bool opaqueDepth) {
    return impl_->render(scene, view, framebuffer, timeSeconds, opaqueDepth);
}
namespace {
void checkFinite(const Vec3& v, const char* call, const char* what) {
    if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)))
        throw std::invalid_argument(std::string("SkyRenderer::") + call + ": the " + what + " must be finite");
}
}  // namespace

double SkyRenderer::densityAt(const Vec3& point) const {
    checkFinite(point, "densityAt", "point");
    return impl_->field("densityAt")->extinction(point);
}

double SkyRenderer::transmittance(const Vec3& origin, const Vec3& direction, double length) const {
    checkFinite(origin, "transmittance", "origin");
    checkFinite(direction, "transmittance", "direction");
    const double norm = glm::length(direction);
    if (!(norm > 1e-6)) throw std::invalid_argument("SkyRenderer::transmittance: the direction needs a length > 1e-6");
    if (!(length >= 0))
        throw std::invalid_argument("SkyRenderer::transmittance: the length must be >= 0 m (or infinite)");
    return impl_->field("transmittance")->transmittance(origin, direction / norm, length);
}

CloudPresence SkyRenderer::insideCloud(const Vec3& point) const {
    checkFinite(point, "insideCloud", "point");
    return impl_->field("insideCloud")->presence(point);
}

SurfaceLight SkyRenderer::lightAt(const Vec3& point, const Vec3& normal) const {
    if (!impl_->prepared_) throw std::logic_error("SkyRenderer::lightAt: call prepare() first");
    checkFinite(point, "lightAt", "point");
    checkFinite(normal, "lightAt", "normal");
    const double norm = glm::length(normal);
    if (!(norm > 1e-6)) throw std::invalid_argument("SkyRenderer::lightAt: the normal needs a length > 1e-6");
    return impl_->clouds_.lightAt(impl_->frame_, point, normal / norm);
}

const EllipsoidRenderer& SkyRenderer::compositor() const { return impl_->clouds_; }
const NearLod* SkyRenderer::nearLod() const { return impl_->nearLod_.get(); }

}  // namespace nephele
