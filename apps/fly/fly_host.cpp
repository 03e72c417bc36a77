#include "fly_host.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/opaque.hpp"
#include "nephele/raymarch.hpp"
#include "nephele/shader.hpp"
#include "nephele/sky.hpp"

namespace nephele::fly {

using namespace gl;

namespace {
constexpr const char* kNames[] = {"auto", "ellipsoid", "raymarch", "layered"};
}

const char* flyMethodName(FlyMethod m) { return kNames[int(m)]; }

std::optional<FlyMethod> parseFlyMethod(const std::string& name) {
    for (FlyMethod m : kFlyMethods)
        if (name == flyMethodName(m)) return m;
    return std::nullopt;
}

CompositeOrder defaultOrder(FlyMethod m) {
    return m == FlyMethod::Auto ? autoEllipsoidSettings().order : EllipsoidSettings().order;
}

namespace {

// SkyRenderer's settings for a method: auto's, or the plain compositor's and layered sky's
// (no near LOD), as `nephele render --method` has them.
SkySettings skySettings(FlyMethod m, const FlyHostSettings& fs, CompositeOrder order) {
    SkySettings ss;
    if (m != FlyMethod::Auto) ss.layered = LayeredSettings{}, ss.ellipsoid = EllipsoidSettings{};
    ss.layered.cacheDir = fs.cacheDir;
    ss.ellipsoid.order = order;
    ss.ellipsoid.timings = fs.timings;
    ss.timings = fs.timings;
    ss.cellsPerUpdate = fs.cellsPerUpdate;
    return ss;
}

// What a method draws of the scene: ellipsoid its clouds only, layered its layers only.
Scene skyScene(FlyMethod m, Scene scene) {
    if (m == FlyMethod::Ellipsoid) scene.layers.clear();
    if (m == FlyMethod::Layered) scene.clouds.clear();
    return scene;
}

}  // namespace

struct FlyHost::Renderers {
    struct Sky {
        std::unique_ptr<SkyRenderer> renderer;  // made at the method's first draw
        bool prepared = false;
    };
    OpaquePass opaque;
    std::unique_ptr<FrameTarget> target;
    Sky skies[std::size(kFlyMethods)];  // by method: auto, ellipsoid, layered (the host API)
    std::unique_ptr<RaymarchRenderer> raymarch;
    Program present = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "fly_present.frag"}});
    VertexArray empty = VertexArray::create();
    Sampler linear = linearSampler(GL_CLAMP_TO_EDGE);
    SkyRenderer* sky(FlyMethod m) const { return skies[int(m)].renderer.get(); }
};

FlyHost::FlyHost(FlyHostSettings settings) : settings_(std::move(settings)), r_(std::make_unique<Renderers>()) {}
FlyHost::~FlyHost() = default;

void FlyHost::setMethod(FlyMethod m) {
    if (m == settings_.method) return;
    const CompositeOrder keep = order();
    settings_.method = m;
    settings_.order = keep;
}

void FlyHost::setOrder(CompositeOrder o) {
    if (o == order()) return;
    settings_.order = o;
    for (Renderers::Sky& sky : r_->skies) sky = {};
}

void FlyHost::sceneChanged() {
    for (Renderers::Sky& sky : r_->skies) sky.prepared = false;
}

FlyFrameStats FlyHost::draw(const Scene& scene, const Camera& camera, double t) {
    Renderers& r = *r_;
    const View view = makeView(camera);
    if (!r.target || r.target->width() != camera.width || r.target->height() != camera.height)
        r.target = std::make_unique<FrameTarget>(camera.width, camera.height);
    const GLuint fbo = r.target->framebuffer();
    const bool objects = !scene.objects.empty();
    FlyFrameStats st;
    PartTimer total(settings_.timings), part(settings_.timings);
    r.opaque.draw(scene, view, fbo);
    st.opaqueMs = part.lap();
    if (settings_.method == FlyMethod::Raymarch) {
        if (!r.raymarch) r.raymarch = std::make_unique<RaymarchRenderer>(RaymarchSettings{});
        st.marchDownsample = r.raymarch->render(scene, view, fbo, objects).downsample;
        st.volumeMs = part.lap();
    } else {
        drawSky(scene, view, t, st);
    }
    st.totalMs = total.lap();
    return st;
}

// The host API's frame: prepare when needed, update by the time since the last frame (the
// scene's sun, sky and layers as the weather), draw into the frame over the opaque pass.
void FlyHost::drawSky(const Scene& scene, const View& view, double t, FlyFrameStats& st) {
    const FlyMethod m = settings_.method;
    Renderers::Sky& sky = r_->skies[int(m)];
    if (!sky.renderer) sky.renderer = std::make_unique<SkyRenderer>(skySettings(m, settings_, order()));
    // Time only runs forward for a host: a jump back (the path looping) starts again at 0.
    constexpr double kRewind = 1e-6;  // s: time() sums the steps, so it may pass t by rounding
    if (!sky.prepared || t < sky.renderer->time() - kRewind) {
        sky.renderer->prepare(skyScene(m, scene));
        sky.prepared = true;
    }
    PartTimer part(settings_.timings);
    Weather weather = Weather::of(scene);
    if (m == FlyMethod::Ellipsoid) weather.layers.clear();
    st.nearLod = sky.renderer->update(std::max(0.0, t - sky.renderer->time()), weather, view.eye).nearLod;
    if (settings_.waitEachFrame) sky.renderer->waitForBackgroundWork();
    st.nearLodMs = part.lap();
    const SkyStats s = sky.renderer->draw(viewDescOf(view, r_->target->framebuffer(), !scene.objects.empty()));
    st.layered = s.layered, st.ellipsoids = s.ellipsoids;
    st.farFieldMs = s.farFieldMs, st.tilesMs = s.ellipsoids.tilesMs, st.compositeMs = s.ellipsoids.compositeMs;
}

void FlyHost::present(GLuint framebuffer, int w, int h) {
    if (!r_->target) return;
    GlStateGuard guard;
    resetPassState();
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    glViewport(0, 0, w, h);
    glDisable(GL_BLEND);
    glUseProgram(r_->present.id());
    r_->present.set("frame", 0);
    glBindTextureUnit(0, r_->target->colorTexture());
    glBindSampler(0, r_->linear.id());
    glBindVertexArray(r_->empty.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    check("presenting the frame");
}

Image FlyHost::readColor() const { return r_->target ? r_->target->readColor() : Image(); }

const EllipsoidRenderer* FlyHost::compositor() const {
    const FlyMethod m = settings_.method;
    if (m != FlyMethod::Auto && m != FlyMethod::Ellipsoid) return nullptr;
    const SkyRenderer* sky = r_->sky(m);
    return sky ? &sky->compositor() : nullptr;
}

std::vector<const NearCell*> FlyHost::nearCells() const {
    const SkyRenderer* sky = settings_.method == FlyMethod::Auto ? r_->sky(FlyMethod::Auto) : nullptr;
    if (!sky || !sky->nearLod()) return {};
    return sky->nearLod()->cells();
}

double FlyHost::nearRadius() const {
    return settings_.method == FlyMethod::Auto ? autoLayeredSettings().nearRadius : 0;
}
double FlyHost::blendBand() const { return settings_.method == FlyMethod::Auto ? autoLayeredSettings().blendBand : 0; }

}  // namespace nephele::fly

namespace nephele::fly {
double FlyHost::nearCellSize() const { return NearLodSettings().cellSize; }
}  // namespace nephele::fly
