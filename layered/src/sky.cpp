#include "nephele/sky.hpp"

namespace nephele {

LayeredSettings autoLayeredSettings(LayeredSettings base) {
    if (base.nearRadius == 0) base.nearRadius = kAutoNearRadius;
    if (base.blendBand == 0) base.blendBand = kAutoBlendBand;
    base.lod0Radius = std::max(base.lod0Radius, base.nearRadius + base.blendBand + kAutoLod0Margin);
    return base;
}

EllipsoidSettings autoEllipsoidSettings(EllipsoidSettings base) {
    base.order = CompositeOrder::Weighted;
    return base;
}

namespace {
EllipsoidSettings withTimings(EllipsoidSettings s, bool timings) {
    s.timings = s.timings || timings;
    return s;
}
}  // namespace

SkyRenderer::SkyRenderer(SkySettings settings)
    : settings_(std::move(settings)), clouds_(withTimings(settings_.ellipsoid, settings_.timings)) {
    validate(settings_.layered);
    validate(settings_.nearLod, settings_.layered);
}

SkyRenderer::~SkyRenderer() = default;

SkyStats SkyRenderer::render(const Scene& scene, const View& view, GLuint framebuffer, double timeSeconds,
                             bool opaqueDepth) {
    SkyStats stats;
    if (scene.layers.empty()) {
        stats.ellipsoids = clouds_.render(scene, view, framebuffer, opaqueDepth);
        return stats;
    }
    if (!layered_) layered_ = std::make_unique<LayeredRenderer>(settings_.layered);
    if (!nearLod_) nearLod_ = std::make_unique<NearLod>(settings_.nearLod, settings_.layered);
    gl::PartTimer timer(settings_.timings);
    stats.layered = layered_->render(scene, view, framebuffer, timeSeconds);
    stats.farFieldMs = timer.lap();
    const std::vector<Cloud> near = nearLod_->update(scene, view.eye, timeSeconds, &stats.nearLod);
    stats.nearLodMs = timer.lap();
    stats.ellipsoids = clouds_.render(withNearClouds(scene, near), view, framebuffer, opaqueDepth);
    return stats;
}

}  // namespace nephele
