// The GPU ray-marcher (see nephele/raymarch.hpp for the method).
#include "nephele/raymarch.hpp"

#include "nephele/fingerprint.hpp"
#include "nephele/frame_depth.hpp"
#include "nephele/gl_state.hpp"
#include "nephele/projection.hpp"
#include "nephele/shader.hpp"

#include <glm/gtc/matrix_access.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace nephele {
using namespace gl;

namespace {

// Mirrors `struct RmEllipsoid` of shaders/raymarch_data.glsl (std430).
struct GpuEllipsoid {
    float eyeUnitSigma[4];
    float unit[3][4];
};
static_assert(sizeof(GpuEllipsoid) == 4 * 16);

// Mirrors `struct RmCloud`.
struct GpuCloud {
    float boxMin[4], boxMax[4], lightMin[4], lightScale[4], lightSlot[4];
    std::int32_t range[4];
};
static_assert(sizeof(GpuCloud) == 6 * 16);

void put(float* out, const Vec3& v, double w = 0) {
    out[0] = float(v.x), out[1] = float(v.y), out[2] = float(v.z), out[3] = float(w);
}


// A fingerprint of everything the light grids depend on: the clouds, the sun's direction,
// the medium and the settings the illumination pass uses (grid size, and with noise the
// octaves and the light march's step).
std::uint64_t lightKey(const Scene& scene, const RaymarchSettings& s) {
    return Fingerprint()
        .add(s.lightGrid)
        .add(s.octaves)
        .add(s.step)
        .add(scene.sun.direction)
        .addMedium(scene.medium)
        .addClouds(scene.clouds)
        .value();
}

}  // namespace

struct RaymarchRenderer::Impl {
    Program march;
    VertexArray empty;
    // The fBm volume, made on the first frame with medium.noise > 0: for the light march on
    // the CPU and as a 3D texture for the GPU, the same texels.
    NoiseVolume noiseCpu;
    Texture noise;
    int noiseOctaves = 0;
    Texture light;                      // the clouds' light grids side by side (slots)
    glm::ivec3 lightSlots{1, 1, 1};
    std::uint64_t lightKeyValue = 0;
    std::vector<CloudLight> lights;     // boxes of the cached grids (world)
    Sampler linearClamp;
    Buffer ellipsoids, clouds;
    std::size_t ellipsoidCapacity = 0, cloudCapacity = 0;
    FrameDepth depth;  // copy of the frame's depth (objects inside clouds)

    void ensureNoise(const RaymarchSettings& s);
    void updateLight(const Scene& scene, const RaymarchSettings& s, RaymarchStats& stats);
};

void validate(const RaymarchSettings& s) {
    if (!(s.step > 0) || !std::isfinite(s.step)) throw std::invalid_argument("raymarch step must be > 0 m");
    if (!(s.lodDistance >= 0) || !std::isfinite(s.lodDistance))
        throw std::invalid_argument("raymarch lodDistance must be >= 0 m (0 = fixed step)");
    if (s.lightGrid < 2 || s.lightGrid > 128) throw std::invalid_argument("raymarch lightGrid must be 2..128");
    if (s.octaves < 1 || s.octaves > 8) throw std::invalid_argument("raymarch octaves must be 1..8");
    if (s.maxSteps < 1 || s.maxSteps > 65536) throw std::invalid_argument("raymarch maxSteps must be 1..65536");
}

RaymarchRenderer::RaymarchRenderer(const RaymarchSettings& s) : settings_(s), impl_(std::make_unique<Impl>()) {
    validate(s);
    Impl& m = *impl_;
    m.march = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "raymarch.frag"}});
    m.empty = VertexArray::create();
    m.linearClamp = linearSampler(GL_CLAMP_TO_EDGE);
    checkAlways("creating the ray-marcher");
}

RaymarchRenderer::~RaymarchRenderer() = default;

void RaymarchRenderer::Impl::ensureNoise(const RaymarchSettings& s) {
    if (noise && noiseOctaves == s.octaves) return;
    const NoiseSettings ns = raymarchNoiseSettings(s);
    noiseCpu = makeNoiseVolume(ns.size, ns.cells, ns.octaves, ns.seed);
    noise = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(noise.id(), 1, GL_R32F, noiseCpu.size, noiseCpu.size, noiseCpu.size);
    glTextureSubImage3D(noise.id(), 0, 0, 0, 0, noiseCpu.size, noiseCpu.size, noiseCpu.size, GL_RED, GL_FLOAT,
                        noiseCpu.texels.data());
    glTextureParameteri(noise.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(noise.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) glTextureParameteri(noise.id(), w, GL_REPEAT);
    noiseOctaves = s.octaves;
    check("uploading the raymarch noise volume");
}

// The illumination pass, only when what it depends on changed.
void RaymarchRenderer::Impl::updateLight(const Scene& scene, const RaymarchSettings& s, RaymarchStats& stats) {
    const std::uint64_t key = lightKey(scene, s);
    if (light && key == lightKeyValue) return;
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<CloudLight> grids = makeRaymarchLights(scene, s, scene.medium.noise > 0 ? &noiseCpu : nullptr);
    stats.lightPrecomputeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

    // The grids side by side in one 3D texture: gx * gy * gz slots (as the compositor does).
    const int size = s.lightGrid;
    GLint max3d = 0;
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
    const int perAxis = std::max(1, int(max3d) / size);
    const int n = std::max(int(grids.size()), 1);
    const int gx = std::min(perAxis, int(std::ceil(std::sqrt(double(n)))));
    const int gy = std::min(perAxis, (n + gx - 1) / gx);
    const int gz = (n + gx * gy - 1) / (gx * gy);
    if (gz > perAxis)
        throw GlError("raymarch light grids: " + std::to_string(n) + " clouds of " + std::to_string(size) +
                      "^3 voxels do not fit GL_MAX_3D_TEXTURE_SIZE " + std::to_string(max3d) + "; lower lightGrid");
    lightSlots = glm::ivec3(gx, gy, gz);
    light = Texture::create(GL_TEXTURE_3D);
    glTextureStorage3D(light.id(), 1, GL_RGB16F, gx * size, gy * size, gz * size);
    checkAllocation("the ray-marcher's light grids",
                    std::uint64_t(gx * size) * std::uint64_t(gy * size) * std::uint64_t(gz * size) * 6);
    for (int c = 0; c < int(grids.size()); ++c)
        glTextureSubImage3D(light.id(), 0, (c % gx) * size, (c / gx % gy) * size, (c / (gx * gy)) * size, size, size, size,
                            GL_RGB, GL_FLOAT, grids[c].transmittance.data());
    for (CloudLight& g : grids) g.transmittance.clear();  // only the boxes are kept
    lights = std::move(grids);
    lightKeyValue = key;
    check("uploading the raymarch light grids");
}


RaymarchStats RaymarchRenderer::render(const Scene& scene, const View& view, GLuint framebuffer, bool opaqueDepth) {
    Impl& m = *impl_;
    const RaymarchSettings& s = settings_;
    RaymarchStats stats;
    stats.clouds = int(scene.clouds.size());
    for (const Cloud& c : scene.clouds) stats.ellipsoids += int(c.ellipsoids.size());
    if (stats.ellipsoids == 0) return stats;
    const Medium& medium = scene.medium;
    const double kappa = std::max(medium.noise, 0.0);

    if (kappa > 0) m.ensureNoise(s);
    m.updateLight(scene, s, stats);

    // ---- This frame's data, camera-relative (float precision stays at the eye).
    const int size = s.lightGrid;
    std::vector<GpuEllipsoid> ells;
    std::vector<GpuCloud> clouds;
    for (int c = 0; c < int(scene.clouds.size()); ++c) {
        const Cloud& cloud = scene.clouds[c];
        Vec3 lo, hi;
        if (!raymarchCloudBox(cloud, medium, lo, hi)) continue;
        GpuCloud g{};
        put(g.boxMin, lo - view.eye);
        put(g.boxMax, hi - view.eye);
        const CloudLight& l = m.lights[c];
        put(g.lightMin, l.boxMin - view.eye);
        put(g.lightScale, 1.0 / l.boxExtent);
        put(g.lightSlot, Vec3(c % m.lightSlots.x, c / m.lightSlots.x % m.lightSlots.y, c / (m.lightSlots.x * m.lightSlots.y)) *
                             double(size));
        g.range[0] = int(ells.size());
        for (const Ellipsoid& e : cloud.ellipsoids) {
            if (e.density <= 0) continue;  // no matter: never a candidate
            const glm::dmat3 unit = ellipsoidToUnit(e);
            GpuEllipsoid ge{};
            put(ge.eyeUnitSigma, unit * (view.eye - e.center), medium.extinction * e.density);
            for (int r = 0; r < 3; ++r) put(ge.unit[r], glm::row(unit, r));
            ells.push_back(ge);
        }
        g.range[1] = int(ells.size()) - g.range[0];
        if (g.range[1] > 0) clouds.push_back(g);
    }
    if (clouds.empty()) return stats;
    uploadDynamic(m.ellipsoids, m.ellipsoidCapacity, ells.data(), ells.size() * sizeof(GpuEllipsoid));
    uploadDynamic(m.clouds, m.cloudCapacity, clouds.data(), clouds.size() * sizeof(GpuCloud));

    const int width = view.camera.width, height = view.camera.height;
    GlStateGuard guard;
    if (opaqueDepth) m.depth.copy(framebuffer, width, height);

    const Program& p = m.march;
    p.set("forward", glm::vec3(view.forward));
    p.set("rightScaled", glm::vec3(view.right * view.tanHalfX));
    p.set("upScaled", glm::vec3(view.up * view.tanHalfY));
    p.set("nearClip", float(view.camera.nearClip));
    p.set("farClip", float(view.camera.farClip));
    p.set("useDepth", opaqueDepth ? 1 : 0);
    p.set("sceneDepth", 2);
    p.set("cloudCount", int(clouds.size()));
    p.set("stepBase", float(s.step));
    p.set("invLod", s.lodDistance > 0 ? float(1.0 / s.lodDistance) : 0.0f);
    p.set("maxSteps", s.maxSteps);
    p.set("kappa", float(kappa));
    p.set("noiseVolume", 0);
    const double period = raymarchNoisePeriod(medium, raymarchNoiseSettings(s));
    p.set("eyeNoise", glm::vec3(glm::fract(view.eye / period)));
    p.set("invNoisePeriod", float(1.0 / period));
    p.set("lightVolume", 1);
    p.set("lightSize", float(size));
    p.set("invLightTexels", glm::vec3(1.0 / (glm::dvec3(m.lightSlots) * double(size))));
    p.set("sunDirection", glm::vec3(scene.sun.direction));
    p.set("sunIrradiance", glm::vec3(scene.sun.color * scene.sun.intensity));
    p.set("skyUpper", glm::vec3(0.5 * (scene.sky.zenith + scene.sky.horizon)));
    p.set("ground", glm::vec3(scene.sky.ground));
    p.set("reduction", float(1 - medium.albedo * medium.hgG));
    p.set("hgG", float(medium.hgG));
    p.set("albedo", float(medium.albedo));

    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.ellipsoids.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, m.clouds.id());
    glBindTextureUnit(0, kappa > 0 ? m.noise.id() : 0);
    glBindTextureUnit(1, m.light.id());
    glBindTextureUnit(2, opaqueDepth ? m.depth.texture() : 0);
    glBindSampler(0, 0);
    glBindSampler(1, m.linearClamp.id());
    glBindSampler(2, 0);

    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    glViewport(0, 0, width, height);
    resetPassState();
    glDisable(GL_DEPTH_TEST);
    // The shader writes premultiplied (radiance, 1 - T): colour' = radiance + T colour,
    // alpha' = (1 - T) + T alpha.
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(p.id());
    glBindVertexArray(m.empty.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    check("ray-marching the clouds");
    return stats;
}

}  // namespace nephele
