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

struct FlyHost::Renderers {
    OpaquePass opaque;
    std::unique_ptr<FrameTarget> target;
    std::unique_ptr<SkyRenderer> sky;              // auto
    std::unique_ptr<EllipsoidRenderer> clouds;     // ellipsoid
    std::unique_ptr<RaymarchRenderer> raymarch;
    std::unique_ptr<LayeredRenderer> layered;
    Program present = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "fly_present.frag"}});
    VertexArray empty = VertexArray::create();
    Sampler linear = linearSampler(GL_CLAMP_TO_EDGE);
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
    r_->sky.reset();
    r_->clouds.reset();
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
    EllipsoidSettings es;
    es.order = order();
    es.timings = settings_.timings;
    switch (settings_.method) {
        case FlyMethod::Auto: {
            if (!r.sky) {
                SkySettings ss;
                ss.layered.cacheDir = settings_.cacheDir;
                ss.ellipsoid = es;
                ss.timings = settings_.timings;
                r.sky = std::make_unique<SkyRenderer>(ss);
            }
            const SkyStats s = r.sky->render(scene, view, fbo, t, objects);
            st.layered = s.layered, st.nearLod = s.nearLod, st.ellipsoids = s.ellipsoids;
            st.farFieldMs = s.farFieldMs, st.nearLodMs = s.nearLodMs;
            break;
        }
        case FlyMethod::Ellipsoid:
            if (!r.clouds) r.clouds = std::make_unique<EllipsoidRenderer>(es);
            st.ellipsoids = r.clouds->render(scene, view, fbo, objects);
            break;
        case FlyMethod::Raymarch:
            if (!r.raymarch) r.raymarch = std::make_unique<RaymarchRenderer>(RaymarchSettings{});
            r.raymarch->render(scene, view, fbo, objects);
            st.volumeMs = part.lap();
            break;
        case FlyMethod::Layered:
            if (!r.layered) {
                LayeredSettings ls;
                ls.cacheDir = settings_.cacheDir;
                r.layered = std::make_unique<LayeredRenderer>(ls);
            }
            st.layered = r.layered->render(scene, view, fbo, t);
            st.farFieldMs = part.lap();
            break;
    }
    st.tilesMs = st.ellipsoids.tilesMs, st.compositeMs = st.ellipsoids.compositeMs;
    st.totalMs = total.lap();
    return st;
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
    if (settings_.method == FlyMethod::Auto && r_->sky) return &r_->sky->compositor();
    if (settings_.method == FlyMethod::Ellipsoid && r_->clouds) return r_->clouds.get();
    return nullptr;
}

std::vector<const NearCell*> FlyHost::nearCells() const {
    if (settings_.method != FlyMethod::Auto || !r_->sky || !r_->sky->nearLod()) return {};
    return r_->sky->nearLod()->cells();
}

double FlyHost::nearRadius() const { return settings_.method == FlyMethod::Auto ? autoLayeredSettings().nearRadius : 0; }
double FlyHost::blendBand() const { return settings_.method == FlyMethod::Auto ? autoLayeredSettings().blendBand : 0; }

}  // namespace nephele::fly

namespace nephele::fly {
double FlyHost::nearCellSize() const { return NearLodSettings().cellSize; }
}  // namespace nephele::fly
