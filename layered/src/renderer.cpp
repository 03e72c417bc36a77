// The layered sky on the GPU: per scene layer, one instanced draw of N annuli (LOD1) and one
// of the billboard slices (LOD0), into the host's frame with "over" blending.
#include "nephele/frame_depth.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/layered.hpp"
#include "nephele/per_view.hpp"
#include "nephele/resources.hpp"
#include "nephele/shader.hpp"
#include "frame_change.hpp"
#include "layer_assets.hpp"
#include "layer_light.hpp"
#include "layered_hooks.hpp"
#include "reduced_target.hpp"
#include "shadow_pass.hpp"

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>

namespace nephele {
using namespace gl;

namespace {
// The flashes a layer is lit by at once (the first active ones of the scene's lightning): the
// size of layered_cloud.frag's uniform array, given to it as MAX_FLASHES.
constexpr int kMaxFlashes = 8;

// A lighting volume or modulation texture (LayerAssets' CPU data) and its GL texture, one per
// distinct data: every scene layer with the same parameters draws with the same one (100
// layers of one thickness and seed hold one of each, not 100).
template <class T>
struct SharedTexture {
    std::shared_ptr<const T> data;
    Texture texture;
    Texture columns;  // a lighting volume's column knots (2D); none for a modulation texture
};
template <class T>
using TexturePool = std::vector<std::weak_ptr<const SharedTexture<T>>>;

// What one scene layer draws with (kept until newer data is ready).
struct LayerSlot {
    std::shared_ptr<const SharedTexture<LightingVolume>> light;
    std::shared_ptr<const SharedTexture<ModulationTexture>> modulation;
    Texture sunTable, sunManyTable, skyTable;  // the frame's light tables (layer_light.hpp), refreshed every frame
    bool ready() const { return light && modulation; }
};

// An RGBA 2D texture, linear, repeating or clamped.
Texture makeTexture2D(GLenum format, int width, int height, int levels, bool repeat) {
    Texture t = Texture::create(GL_TEXTURE_2D);
    glTextureStorage2D(t.id(), levels, format, width, height);
    glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, levels > 1 ? GL_LINEAR_MIPMAP_NEAREST : GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_S, repeat ? GL_REPEAT : GL_CLAMP_TO_EDGE);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_T, repeat ? GL_REPEAT : GL_CLAMP_TO_EDGE);
    return t;
}

int mipLevels(int size) {
    int levels = 1;
    while ((size >>= 1) > 0) ++levels;
    return levels;
}

glm::vec2 fract2(const glm::dvec2& v) { return glm::vec2(v - glm::floor(v)); }

// Whether the far field is reused across frames: drawn at reduced resolution, with a period.
bool reusesFarField(const LayeredSettings& s) { return s.downsample > 1 && s.reusePeriod > 1; }

// Frames further apart in time than this (s) are not reused: slower than 2 frames a second the
// light, the wind and the eye move too much between them.
constexpr double kReuseMaxSeconds = 0.5;

}  // namespace

struct LayeredRenderer::Impl {
    Program program, programGlow;  // the layer shader without and with city glow (CITY_GLOW)
    IndexedMesh annulus, quad;
    std::shared_ptr<LayerAssets> assets;    // lighting volumes and modulation textures
    std::vector<LayerSlot> layers;          // by scene layer
    TexturePool<LightingVolume> lightPool;  // the distinct textures the slots hold
    TexturePool<ModulationTexture> modulationPool;
    ShadowPass shadows;
    ReducedTarget reduced;            // LayeredSettings::downsample > 1
    PerViewCache<FrameDepth> depths;  // copies of the host frame's depth, for the shadows and the upsampling
    Program floor;                    // the bench's floor (renderFloor)
    // What the last frame was drawn with, for the far field's reuse: its layers' weather and
    // textures (FrameRecord), the time, and whether a flash lit it.
    FrameRecord last;
    double lastTime = 0;
    bool lastFlash = false;
    int lightRoll = 0;  // frames left of rolling in replaced textures (kLightRollFrames)

    void updateSlot(LayerSlot& slot, const Scene& scene, const Layer& layer, const LayeredSettings& s,
                    LayeredStats& stats);
    ReuseFrame reuseFrame(const Scene& scene, const View& view, const LayeredSettings& s, double t);
};

namespace {
// Sets each uniform in both programs (they share every uniform).
struct ProgramPair {
    const Program& a;
    const Program& b;
    template <class T>
    void set(const char* name, const T& v) const {
        a.set(name, v);
        b.set(name, v);
    }
};

// The index of the first of the N annuli (at H_i = base + i thickness / (N - 1), eq. 12) above
// the eye's height; N when none is.
int firstAnnulusAbove(const Layer& layer, int n, double eyeZ) {
    for (int i = 0; i < n; ++i)
        if (layer.base + i * layer.thickness / (n - 1) > eyeZ) return i;
    return n;
}

// One scene layer's geometry with program `p` (its uniforms for the layer set): the N annuli
// (LOD1) in one instanced draw, then the billboards (LOD0, eq. 13) in another.
template <class P>
void drawLayerGeometry(const P& p, const IndexedMesh& annulus, const IndexedMesh& quad, const LayeredSettings& s,
                       const Layer& layer, int n, LayeredStats& stats) {
    p.set("mode", 0);
    p.set("annulusRadius", float(layer.extent));
    glBindVertexArray(annulus.vao.id());
    glDrawElementsInstanced(GL_TRIANGLES, annulus.indexCount, GL_UNSIGNED_INT, nullptr, n);
    ++stats.drawCalls;
    stats.instances += n;
    if (s.lod0Radius <= 0) return;
    p.set("mode", 1);
    const int slices = std::max(1, int(std::floor(s.lod0Radius / s.lod0Spacing)));
    const double hp = std::max(layer.thickness / (n - 1), s.lod0Spacing);  // H_p, eq. (13)
    const int pieces = std::max(1, int(std::lround(layer.thickness / hp)));
    p.set("slices", slices);
    p.set("pieces", pieces);
    glBindVertexArray(quad.vao.id());
    glDrawElementsInstanced(GL_TRIANGLES, quad.indexCount, GL_UNSIGNED_INT, nullptr, slices * pieces);
    ++stats.drawCalls;
    stats.instances += slices * pieces;
}

// An annulus of radius 1 around the origin: rings at r = (j / rings)^2, so that the triangles
// are small near the eye, where perspective makes them large on screen.
IndexedMesh makeAnnulus(int segments) {
    const int rings = 16;
    std::vector<float> v;
    std::vector<unsigned> idx;
    for (int j = 0; j <= rings; ++j) {
        const double r = double(j * j) / (rings * rings);
        for (int s = 0; s < segments; ++s) {
            const double a = 2 * glm::pi<double>() * s / segments;
            // The outer ring circumscribes the circle so the polygon covers the whole extent.
            const double rr = j == rings ? r / std::cos(glm::pi<double>() / segments) : r;
            v.insert(v.end(), {float(rr * std::cos(a)), float(rr * std::sin(a)), 0.0f});
        }
    }
    for (int j = 0; j < rings; ++j)
        for (int s = 0; s < segments; ++s) {
            const unsigned a = j * segments + s, b = j * segments + (s + 1) % segments;
            const unsigned c = a + segments, d = b + segments;
            idx.insert(idx.end(), {a, c, b, b, c, d});
        }
    return makeIndexedMesh(v, idx, 1);
}

// The directional lights: the sun and the skylight (none: irradiance 0), each with the side of
// the column it shines from and its elevation's sine (at least 0.01: the slant of tauSun).
void setLightUniforms(const ProgramPair& p, const Scene& scene) {
    auto light = [&](const char* direction, const char* fromAbove, const char* mu, const Vec3& l) {
        p.set(direction, glm::vec3(l));
        p.set(fromAbove, l.z >= 0 ? 1.0f : 0.0f);
        p.set(mu, float(std::max(std::abs(l.z), 0.01)));
    };
    light("sunDirection", "sunFromAbove", "sunMu", scene.sun.direction);
    p.set("sunIrradiance", glm::vec3(scene.sun.color * scene.sun.intensity));
    const glm::dvec2 h(scene.sun.direction.x, scene.sun.direction.y);
    p.set("sunHorizontal", glm::length(h) > 1e-9 ? glm::vec3(glm::normalize(h), 0.0f) : glm::vec3(1, 0, 0));
    light("skyDirection", "skyFromAbove", "skyMu",
          scene.skylight ? glm::normalize(scene.skylight->direction) : Vec3(0, 0, 1));
    p.set("skyIrradiance",
          scene.skylight ? glm::vec3(scene.skylight->color * scene.skylight->intensity) : glm::vec3(0));
}

// Billboards face the horizontal view direction (the camera's up when looking straight up or down).
glm::vec2 billboardAxis(const View& view) {
    glm::dvec2 axis(view.forward.x, view.forward.y);
    if (glm::length(axis) < 1e-3) axis = glm::dvec2(view.up.x, view.up.y) * (view.forward.z > 0 ? -1.0 : 1.0);
    return glm::vec2(glm::length(axis) > 0 ? glm::normalize(axis) : glm::dvec2(0, 1));
}

// The uniforms every layer of the frame shares.
void setFrameUniforms(const ProgramPair& p, const Scene& scene, const View& view, const LayeredSettings& s, double t) {
    p.set("viewProjection", glm::mat4(view.rotationViewProjection()));
    p.set("eyeHeight", float(view.eye.z));
    setLightUniforms(p, scene);
    p.set("extinction", float(scene.medium.extinction));
    p.set("albedo", float(scene.medium.albedo));
    p.set("hgG", float(scene.medium.hgG));
    p.set("glowHeightCoeff", float(s.glowHeight));
    p.set("lod0Radius", float(s.lod0Radius));
    p.set("lod0Spacing", float(s.lod0Spacing));
    p.set("lightVolume", 0);
    p.set("modulation", 1);
    p.set("columns", 2);
    p.set("sunTable", 3);
    p.set("skyTable", 4);
    p.set("sunManyTable", 5);
    p.set("gradScale", float(1.0 / s.downsample));
    int flashes = 0;
    for (const Lightning& l : scene.lightning)
        if (t >= l.start && t < l.start + l.duration && flashes < kMaxFlashes) {
            const std::string name = "flashes[" + std::to_string(flashes++) + "]";
            p.set(name.c_str(), glm::vec4(glm::vec3(l.position - view.eye), float(l.intensity)));
        }
    p.set("flashCount", flashes);
    p.set("sliceAxis", billboardAxis(view));
}

// The scene's layers far to near (by the distance of their band from the eye's height), those
// whose textures are ready, each with its own uniforms.
void drawLayers(const ProgramPair& p, const std::vector<LayerSlot>& slots, const IndexedMesh& annulus,
                const IndexedMesh& quad, const Scene& scene, const View& view, const LayeredSettings& s, double t,
                LayeredStats& stats) {
    std::vector<int> order;
    for (std::size_t i = 0; i < scene.layers.size(); ++i)
        if (slots[i].ready()) order.push_back(int(i));
    auto bandDistance = [&](int i) {
        const Layer& l = scene.layers[i];
        return std::max({l.base - view.eye.z, view.eye.z - (l.base + l.thickness), 0.0});
    };
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return bandDistance(a) > bandDistance(b); });
    const int n = s.layers;
    for (int li : order) {
        const Layer& layer = scene.layers[li];
        const LayerSlot& r = slots[li];
        const double lp = s.lighting.tilePeriod, mp = s.modulation.period;
        const glm::dvec2 eye(view.eye.x, view.eye.y), drift = layerDrift(layer, t);
        p.set("uvLightEye", fract2((eye - drift) / lp));
        p.set("uvModEye", fract2((eye - drift) / mp));
        p.set("uvCityEye", fract2(eye / mp));
        p.set("invLightPeriod", float(1 / lp));
        p.set("invModPeriod", float(1 / mp));
        p.set("base", float(layer.base));
        p.set("thickness", float(layer.thickness));
        p.set("coverage", float(layer.coverage));
        p.set("density", float(layer.density));
        // The near-LOD hand-off cuts only layers whose near clouds are drawn as ellipsoids
        // (near_lod); the others are drawn all the way in.
        p.set("nearRadius", float(layer.nearLod ? s.nearRadius : 0.0));
        p.set("blendBand", float(layer.nearLod ? s.blendBand : 0.0));
        p.set("layerCount", n);
        p.set("firstAbove", firstAnnulusAbove(layer, n, view.eye.z));
        p.set("layerSlab", float(layer.thickness / n));
        // Annuli and billboards sample equally well where a ray's horizontal run across one
        // annulus slab (slab / tan e) equals its vertical run across one slice (spacing tan e).
        p.set("steepTan", float(std::sqrt(layer.thickness / n / s.lod0Spacing)));
        p.set("extent", float(layer.extent));
        p.set("fadeStart", float(layer.extent * (1 - s.extentFade)));
        p.set("glow", layer.cityGlow ? glm::vec3(layer.cityGlow->color * layer.cityGlow->strength) : glm::vec3(0));
        glBindTextureUnit(0, r.light->texture.id());
        glBindTextureUnit(1, r.modulation->texture.id());
        glBindTextureUnit(2, r.light->columns.id());
        glBindTextureUnit(3, r.sunTable.id());
        glBindTextureUnit(4, r.skyTable.id());
        glBindTextureUnit(5, r.sunManyTable.id());
        glUseProgram(layer.cityGlow ? p.b.id() : p.a.id());
        // Annuli first: outside the billboard disc they lie beyond it along every ray; inside
        // it the two share the volume's optical depth and their order changes colour only.
        drawLayerGeometry(p, annulus, quad, s, layer, n, stats);
        check("drawing the layered sky");
    }
}
}  // namespace

LayeredRenderer::LayeredRenderer(LayeredSettings settings)
    : settings_(std::move(settings)), impl_(std::make_unique<Impl>()) {
    validate(settings_);
    HostStateScope scope;  // the meshes' uploads and bindings
    // Reusing the far field, the layers also write their distance moments (ReducedTarget).
    const bool reuse = reusesFarField(settings_);
    const std::string defines =
        "#define MAX_FLASHES " + std::to_string(kMaxFlashes) + "\n" + (reuse ? "#define REUSE 1\n" : "");
    impl_->program =
        Program::build({{GL_VERTEX_SHADER, "layered_cloud.vert"}, {GL_FRAGMENT_SHADER, "layered_cloud.frag"}}, defines);
    // llvmpipe runs both sides of a branch, so the city map's fetch is compiled in only where a
    // layer glows (10% of the frame time without it on llvmpipe).
    impl_->programGlow =
        Program::build({{GL_VERTEX_SHADER, "layered_cloud.vert"}, {GL_FRAGMENT_SHADER, "layered_cloud.frag"}},
                       defines + "#define CITY_GLOW 1\n");
    impl_->annulus = makeAnnulus(settings_.segments);  // unit radius, scaled per layer by `annulusRadius`
    std::vector<float> q = {-0.5f, -0.5f, 0, 0.5f, -0.5f, 0, 0.5f, 0.5f, 0, -0.5f, 0.5f, 0};
    impl_->quad = makeIndexedMesh(q, {0, 1, 2, 0, 2, 3}, 1);
    impl_->floor =
        Program::build({{GL_VERTEX_SHADER, "layered_cloud.vert"}, {GL_FRAGMENT_SHADER, "layered_floor.frag"}});
    impl_->assets = std::make_shared<LayerAssets>(settings_);
}

LayeredRenderer::~LayeredRenderer() = default;

void LayeredRenderer::prepare() {
    HostStateScope scope;
    impl_->reduced.prepare();
    // llvmpipe builds its mipmap generation per texture kind at its first use, a stall of a
    // frame, then reuses it for every refill. Build both kinds now, in prepare().
    for (const auto& [target, format] : {std::pair{GL_TEXTURE_3D, GL_RGBA8}, std::pair{GL_TEXTURE_2D, GL_RGBA32F}}) {
        Texture t = Texture::create(target);
        if (target == GL_TEXTURE_3D) glTextureStorage3D(t.id(), 2, format, 2, 2, 2);
        else glTextureStorage2D(t.id(), 2, format, 2, 2);
        glGenerateTextureMipmap(t.id());
    }
    check("preparing the layered sky");
}

void LayeredRenderer::shareAssets(std::shared_ptr<LayerAssets> assets) { impl_->assets = std::move(assets); }

const LightingVolume* LayeredRenderer::lighting(int index) const {
    const bool has = index >= 0 && index < int(impl_->layers.size()) && impl_->layers[index].light;
    return has ? impl_->layers[index].light->data.get() : nullptr;
}
const ModulationTexture* LayeredRenderer::modulation(int index) const {
    const bool has = index >= 0 && index < int(impl_->layers.size()) && impl_->layers[index].modulation;
    return has ? impl_->layers[index].modulation->data.get() : nullptr;
}

namespace {

// The 3D texture of a lighting volume and its columns' 2D texture, with mipmaps (sizes checked
// against the driver's).
SharedTexture<LightingVolume> uploadLighting(const LightingVolume& v) {
    const LightingSettings& ls = v.settings;
    checkTextureSize("the layered lighting volume", ls.width, ls.height, ls.depth);
    SharedTexture<LightingVolume> shared;
    Texture& t = shared.texture;
    t = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(t.id(), mipLevels(std::max({ls.width, ls.height, ls.depth})), GL_RGBA8, ls.width, ls.height,
                       ls.depth);
    checkAllocation("the layered lighting volume's texture", v.texels.size() * 8 / 7);
    glTextureSubImage3D(t.id(), 0, 0, 0, 0, ls.width, ls.height, ls.depth, GL_RGBA, GL_UNSIGNED_BYTE, v.texels.data());
    glGenerateTextureMipmap(t.id());
    // One mip level per fetch (8 texels, not 16): llvmpipe pays per texel.
    glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_NEAREST);
    glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_T, GL_REPEAT);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
    shared.columns = makeTexture2D(GL_RGBA8, ls.width, ls.height, mipLevels(std::max(ls.width, ls.height)), true);
    checkAllocation("the layered lighting volume's columns", v.columns.size() * 4 / 3);
    glTextureSubImage2D(shared.columns.id(), 0, 0, 0, ls.width, ls.height, GL_RGBA, GL_UNSIGNED_BYTE, v.columns.data());
    glGenerateTextureMipmap(shared.columns.id());
    return shared;
}

SharedTexture<ModulationTexture> uploadModulation(const ModulationTexture& m) {
    const int n = m.size;
    SharedTexture<ModulationTexture> shared;
    Texture& t = shared.texture;
    t = Texture::create(GL_TEXTURE_2D);
    // r, the city map, r^2: a mip level's texel holds the mean of r^2 over its footprint, so the
    // shader knows the spread of the thresholds that a far fetch averages.
    glTextureStorage2D(t.id(), mipLevels(n), GL_RGBA32F, n, n);
    checkAllocation("the layered modulation texture",
                    std::uint64_t(n) * n * 16 * 7 / 3);  // the copy uploaded, the texture with mipmaps
    {
        std::vector<float> rgba(std::size_t(n) * n * 4, 0.0f);
        for (std::size_t i = 0; i < std::size_t(n) * n; ++i) {
            const float r = m.texels[2 * i];
            rgba[4 * i] = r, rgba[4 * i + 1] = m.texels[2 * i + 1], rgba[4 * i + 2] = r * r;
        }
        glTextureSubImage2D(t.id(), 0, 0, 0, n, n, GL_RGBA, GL_FLOAT, rgba.data());
    }
    glGenerateTextureMipmap(t.id());
    glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_T, GL_REPEAT);
    return shared;
}

// The pool's texture of `data`, uploaded (and counted in `uploads`) when no layer holds one.
template <class T, class Upload>
std::shared_ptr<const SharedTexture<T>> shareTexture(TexturePool<T>& pool, std::shared_ptr<const T> data,
                                                     Upload&& upload, int& uploads) {
    std::erase_if(pool, [](const auto& w) { return w.expired(); });
    for (const auto& w : pool)
        if (auto held = w.lock(); held && held->data == data) return held;
    SharedTexture<T> uploaded = upload(*data);
    uploaded.data = std::move(data);
    auto made = std::make_shared<const SharedTexture<T>>(std::move(uploaded));
    pool.push_back(made);
    ++uploads;
    return made;
}

// Refuses (ResourceError, before anything is made) a scene whose distinct lighting volumes
// (one per thickness and medium) and modulation textures (one per seed) need more memory, on
// the CPU and in GL with mipmaps, than LayeredSettings::resourceMegabytes.
void checkLayerBudget(const Scene& scene, const LayeredSettings& s) {
    std::vector<LightingParameters> keys;
    std::vector<unsigned> seeds;
    for (const Layer& layer : scene.layers) {
        const LightingParameters key = lightingParameters(scene.medium, layer);
        if (std::find(keys.begin(), keys.end(), key) == keys.end()) keys.push_back(key);
        if (std::find(seeds.begin(), seeds.end(), layer.seed) == seeds.end()) seeds.push_back(layer.seed);
    }
    const LightingSettings& ls = s.lighting;
    // A volume's texels and columns on the CPU and in GL with mipmaps (the light tables are small).
    const std::uint64_t columns = std::uint64_t(ls.width) * std::uint64_t(ls.height);
    const std::uint64_t volumeBytes = columns * std::uint64_t(ls.depth) * 4 * 15 / 7 + columns * 4 * 7 / 3;
    const std::uint64_t texels = std::uint64_t(s.modulation.size) * std::uint64_t(s.modulation.size);
    const std::uint64_t modulationBytes = texels * 8 + texels * 16 * 4 / 3;
    const std::uint64_t need = keys.size() * volumeBytes + seeds.size() * modulationBytes;
    if (need > (std::uint64_t(s.resourceMegabytes) << 20))
        throw ResourceError(
            "layered sky: the scene's " + std::to_string(scene.layers.size()) + " layers need " +
            std::to_string(keys.size()) + " lighting volumes (one per thickness) and " + std::to_string(seeds.size()) +
            " modulation textures (one per seed), " + formatBytes(need) + ", over the budget of " +
            std::to_string(s.resourceMegabytes) +
            " MB (LayeredSettings::resourceMegabytes); layers that share a thickness and a seed share them");
}

}  // namespace

// The slot's textures for the layer: new ones when LayerAssets has newer data for it (at once,
// or when its background job is done: until then the nearest made, LayerAssets::nearestLighting,
// which for a changed layer is the volume it had and for a new one the light of the nearest
// thickness, so that no layer is withheld while its own is made).
void LayeredRenderer::Impl::updateSlot(LayerSlot& r, const Scene& scene, const Layer& layer, const LayeredSettings&,
                                       LayeredStats& stats) {
    const LightingParameters key = lightingParameters(scene.medium, layer);
    std::shared_ptr<const LightingVolume> light = assets->lighting(key);
    if (!light) {
        stats.pendingLayers += 1;  // its job runs
        light = assets->nearestLighting(key);
    }
    if (light && (!r.light || r.light->data != light))
        r.light = shareTexture(lightPool, std::move(light), uploadLighting, stats.uploads);
    std::shared_ptr<const ModulationTexture> modulation = assets->nearestModulation(layer.seed);
    if (modulation && (!r.modulation || r.modulation->data != modulation))
        r.modulation = shareTexture(modulationPool, std::move(modulation), uploadModulation, stats.uploads);
    if (r.light) {  // the light tables of this frame's sun and sky (cheap: bins x bins nodes)
        const LayerFrameTables tables = layerFrameTables(r.light->data->tables, scene);
        if (!r.sunTable) {
            r.sunTable = makeTexture2D(GL_RGBA32F, tables.bins, tables.bins, 1, false);
            r.skyTable = makeTexture2D(GL_RGBA32F, tables.bins, tables.bins, 1, false);
            r.sunManyTable = makeTexture2D(GL_RGBA32F, tables.bins, tables.bins, 1, false);
        }
        glTextureSubImage2D(r.sunTable.id(), 0, 0, 0, tables.bins, tables.bins, GL_RGBA, GL_FLOAT, tables.sun.data());
        glTextureSubImage2D(r.skyTable.id(), 0, 0, 0, tables.bins, tables.bins, GL_RGBA, GL_FLOAT, tables.sky.data());
        glTextureSubImage2D(r.sunManyTable.id(), 0, 0, 0, tables.bins, tables.bins, GL_RGBA, GL_FLOAT,
                            tables.sunMany.data());
    }
}

// What the reduced target's reuse of the last frame's far field needs to know of this frame
// (ReducedTarget::begin): nothing is kept when the weather stepped past the reuse bound in one
// frame (compareFrames: a dense layer come or gone, or drawing with textures not made before,
// is such a step), time ran back or jumped, or a flash lit either frame; a smaller step adds to
// every kept texel's bound, and textures replaced by others are rolled in.
ReuseFrame LayeredRenderer::Impl::reuseFrame(const Scene& scene, const View& view, const LayeredSettings& s, double t) {
    std::vector<LayerTextures> textures;
    for (const LayerSlot& r : layers) textures.push_back({r.light.get(), r.modulation.get()});
    FrameRecord now = frameRecord(scene, textures);
    bool flash = false;
    for (const Lightning& l : scene.lightning) flash = flash || (t >= l.start && t < l.start + l.duration);
    const double dt = t - lastTime;
    ReuseFrame f;
    const FrameChange change = compareFrames(now, last, s.reuseError / kWeatherErrorPerUnit);
    if (change.texturesReplaced) lightRoll = kLightRollFrames;
    f.period = lightRoll > 0 ? std::min(s.reusePeriod, kLightRollFrames) : s.reusePeriod;
    lightRoll = std::max(lightRoll - 1, 0);
    f.maxError = s.reuseError;
    f.weatherError = kWeatherErrorPerUnit * change.step;
    f.invalidate = !(f.weatherError <= s.reuseError) || flash || lastFlash || !(dt >= 0 && dt <= kReuseMaxSeconds);
    // The wind moves each layer's matter; the reprojection follows the layers' mean drift (a
    // layer blowing otherwise is bounded by the period).
    glm::dvec3 drift(0);
    for (const Layer& l : scene.layers) drift += glm::dvec3(layerDrift(l, t) - layerDrift(l, lastTime), 0);
    f.drift = drift / double(scene.layers.size());
    // The nearest matter where the last image had none: the nearest layer's band, past the near LOD's cut.
    double nearest = 1e30;
    for (const Layer& l : scene.layers) {
        const double vertical = std::max({l.base - view.eye.z, view.eye.z - (l.base + l.thickness), 0.0});
        nearest = std::min(nearest, std::max(vertical, l.nearLod ? s.nearRadius : 0.0));
    }
    f.nearest = std::max(nearest, 1.0);
    last = std::move(now);
    lastTime = t;
    lastFlash = flash;
    return f;
}

LayeredStats LayeredRenderer::render(const Scene& scene, const View& view, GLuint framebuffer, double t) {
    return render(scene, view, HostFrame{framebuffer}, t);
}

LayeredStats LayeredRenderer::render(const Scene& scene, const View& view, const HostFrame& frame, double t) {
    LayeredStats stats;
    stats.sceneLayers = int(scene.layers.size());
    if (scene.layers.empty()) return stats;
    Impl& m = *impl_;
    const LayeredSettings& s = settings_;
    const bool shadows = s.shadows && frame.cloudShadows;

    HostStateScope scope;
    // ---- Per layer resources, shared by layers of the same parameters, new only when those change.
    checkLayerBudget(scene, s);
    m.layers.resize(scene.layers.size());
    for (std::size_t i = 0; i < scene.layers.size(); ++i) m.updateSlot(m.layers[i], scene, scene.layers[i], s, stats);
    stats.precomputeMs = m.assets->takeComputeMs();
    check("uploading the layered sky's textures");

    // ---- The frame's depth (none without one), for the shadows and the upsampling.
    const DepthSource frameDepth = shadows || s.downsample > 1
                                       ? m.depths.get({view.camera.width, view.camera.height}).source(frame, view)
                                       : DepthSource{};
    // ---- Cloud shadows (19) on the surfaces already in the frame, before the layers cover them:
    // fused into the upsampling at reduced resolution, else a pass of their own.
    std::vector<int> shadowing;
    if (shadows)
        for (int li : ShadowPass::shadowingLayers(scene))
            if (m.layers[li].ready()) shadowing.push_back(li);
    const bool fuseShadows = s.downsample > 1 && int(shadowing.size()) <= ShadowPass::kLayersPerPass;
    std::vector<GLuint> modulationTextures;
    for (const LayerSlot& r : m.layers) modulationTextures.push_back(r.modulation ? r.modulation->texture.id() : 0);
    stats.shadowLayers = int(shadowing.size());
    if (!fuseShadows)
        stats.shadowDrawCalls = m.shadows.draw(scene, view, frame, frameDepth, t, shadowing, modulationTextures,
                                               s.modulation, s.groundHeight);

    const ProgramPair p{m.program, m.programGlow};
    setFrameUniforms(p, scene, view, s, t);
    const bool reuse = reusesFarField(s);
    if (s.downsample > 1) {  // into the reduced target (bound, viewport set), upsampled at the end
        const ReuseFrame reuseFrame = reuse ? m.reuseFrame(scene, view, s, t) : ReuseFrame{};
        m.reduced.begin(frameDepth, view, s.downsample, reuse ? &reuseFrame : nullptr);
        stats.reusedFrame = m.reduced.reused();
        stats.reusedPixels = reuse ? m.reduced.lastReusedPixels() : -1;
        stats.reducedPixels = (long long)m.reduced.size().x * m.reduced.size().y;
    } else {
        bindFrame(frame, view);
    }
    resetPassState();
    glDisable(GL_FRAMEBUFFER_SRGB);
    if (s.downsample == 1 && frame.srgb) glEnable(GL_FRAMEBUFFER_SRGB);
    frameDepthTest(view);  // behind the opaque objects already in the frame
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    for (GLuint unit = 0; unit <= 5; ++unit) glBindSampler(unit, 0);
    drawLayers(p, m.layers, m.annulus, m.quad, scene, view, s, t, stats);
    if (s.downsample > 1) {
        const int fused = fuseShadows ? int(shadowing.size()) : 0;
        ShadowPass::setUniforms(m.reduced.program(fused, frameDepth.texture != 0), scene, view, t,
                                fuseShadows ? shadowing : std::vector<int>{}, 0, modulationTextures, s.modulation,
                                s.groundHeight);
        m.reduced.composite(frame, frameDepth, view, fused);
        ++stats.upsampleDrawCalls;
    }
    return stats;
}

LayeredStats LayeredBenchHooks::renderFloor(LayeredRenderer& r, const Scene& scene, const View& view,
                                            GLuint framebuffer, double t) {
    LayeredStats stats;
    stats.sceneLayers = int(scene.layers.size());
    LayeredRenderer::Impl& m = *r.impl_;
    if (m.layers.size() != scene.layers.size())
        throw std::logic_error("LayeredRenderer::renderFloor: call render() first");
    const LayeredSettings& s = r.settings_;
    HostStateScope scope;
    const Program& p = m.floor;
    p.set("viewProjection", glm::mat4(view.rotationViewProjection()));
    p.set("eyeHeight", float(view.eye.z));
    p.set("lod0Radius", float(s.lod0Radius));
    p.set("lod0Spacing", float(s.lod0Spacing));
    p.set("modulation", 1);
    p.set("invModPeriod", float(1 / s.modulation.period));
    p.set("sliceAxis", billboardAxis(view));
    bindFrame(HostFrame{framebuffer}, view);
    frameDepthTest(view);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(p.id());
    glBindSampler(1, 0);
    const int n = s.layers;
    for (std::size_t li = 0; li < scene.layers.size(); ++li) {
        const Layer& layer = scene.layers[li];
        const glm::dvec2 uv = (glm::dvec2(view.eye.x, view.eye.y) - layerDrift(layer, t)) / s.modulation.period;
        p.set("uvModEye", glm::vec2(uv - glm::floor(uv)));
        p.set("base", float(layer.base));
        p.set("thickness", float(layer.thickness));
        p.set("layerCount", n);
        p.set("firstAbove", firstAnnulusAbove(layer, n, view.eye.z));
        if (!m.layers[li].modulation) continue;
        glBindTextureUnit(1, m.layers[li].modulation->texture.id());
        drawLayerGeometry(p, m.annulus, m.quad, s, layer, n, stats);
    }
    check("drawing the layered bench's floor");
    return stats;
}

}  // namespace nephele
