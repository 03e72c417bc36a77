// The path-traced reference (see nephele/pathtrace.hpp for what it renders).
//
// Per ray: a BVH over the ellipsoids' world boxes yields the chords the ray crosses; each
// chord is cut into pieces (detail::chordPieces) whose extinction bound is exact for the smooth field
// (the largest (1-q)^2 on the piece, times the noise factor's bound); overlapping pieces sum
// into a piecewise-constant majorant (tracking.hpp) under which delta tracking samples free
// flights and ratio tracking estimates transmittance.
#include "nephele/pathtrace.hpp"

#include "layer_tracking.hpp"
#include "pathtrace_hooks.hpp"
#include "tracking.hpp"

#include "cache_file.hpp"
#include "nephele/cloud_matter.hpp"
#include "nephele/detail.hpp"
#include "nephele/ellipsoid_space.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/layer_volume.hpp"
#include "nephele/log.hpp"
#include "nephele/opaque.hpp"
#include "nephele/noise.hpp"
#include "parallel.hpp"
#include "phase_sampling.hpp"
#include "nephele/resources.hpp"

#include <atomic>
#include <cstdio>
#include <cstring>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <thread>
#include <tuple>

#include <time.h>

namespace nephele {

namespace detail {
namespace {
std::atomic<std::uint64_t> imagesComputed{0};
}
std::uint64_t pathTracedImagesComputed() { return imagesComputed.load(); }
}  // namespace detail

namespace {

using detail::hgPhase;
using detail::MajorantPiece;
using detail::MajorantSegment;
using detail::Pcg32;
using detail::sampleCosine;
using detail::sampleHg;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxImageSide = 16384;           // px: a cached image of more is not ours
constexpr double kEstimateAboveSamples = 1e6;  // renders of fewer samples are not estimated (they are short)
// Bump when the estimator or the field changes: invalidates caches. 2: the noise is read per
// ellipsoid at x / period + ellipsoidNoiseOffset(cloud, index, seed), as the compositor reads it.
// 3: the file ends with a checksum; dense media are clamped and graded (the same images below).
// (The scene's layers, when rendered, carry their own version in LayerVolumes::key(): scenes
// without rendered layers keep their keys.)
constexpr std::uint32_t kVersion = 3;

// Throws std::invalid_argument naming what of the scene the path tracer cannot render: a
// scene built in code has not been through the loader's checks.
void checkScene(const Scene& scene) {
    auto bad = [](const std::string& what) { throw std::invalid_argument("renderPathTraced: " + what); };
    const Medium& m = scene.medium;
    if (!(std::isfinite(m.extinction) && m.extinction >= 0)) bad("medium.extinction must be finite and >= 0");
    if (!(m.albedo >= 0 && m.albedo <= 1)) bad("medium.albedo must be in [0, 1]");
    if (!(m.hgG > -1 && m.hgG < 1)) bad("medium.hg_g must be in (-1, 1)");
    if (!(m.noise >= 0 && m.noise <= kMaxPathTraceNoise))
        bad("medium.noise must be in [0, " + std::to_string(int(kMaxPathTraceNoise)) +
            "] (above it the noise cuts empty holes into dense matter that free flights cannot cross in bounded time)");
    if (m.noise > 0 && !(std::isfinite(m.noiseScale) && m.noiseScale > 0))
        bad("medium.noise_scale must be finite and > 0");
    for (std::size_t c = 0; c < scene.clouds.size(); ++c)
        for (std::size_t i = 0; i < scene.clouds[c].ellipsoids.size(); ++i) {
            const Ellipsoid& e = scene.clouds[c].ellipsoids[i];
            auto finite = [](const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
            const bool ok = finite(e.center) && finite(e.rotationDeg) && finite(e.radii) && e.radii.x > 0 &&
                            e.radii.y > 0 && e.radii.z > 0 && std::isfinite(e.density) && e.density >= 0;
            if (!ok)
                bad("clouds[" + std::to_string(c) + "].ellipsoids[" + std::to_string(i) +
                    "]: needs a finite centre and rotation, radii > 0 and a finite density >= 0");
        }
}

// A ray prepared for tracking: its chords (by tIn) and its majorant.
struct RayData {
    std::vector<CloudMatter::Chord> cross;
    std::vector<double> breaks;  // scratch: one chord's piece ends
    std::vector<MajorantPiece> pieces;
    std::vector<std::pair<double, double>> events;
    std::vector<MajorantSegment> segs;
    detail::LayerRay layers;  // the layers' own majorant (layer_tracking.hpp), when the scene's layers are rendered
};

// Scratch space of one row of pixels (one thread at a time), reused from pixel to pixel.
struct Workspace {
    RayData primary, secondary, shadow;
};

class World {
public:
    // `layers` (may be null: no layers) centred on the eye `eye`, as the layered sky is.
    World(const Scene& scene, const NoiseVolume* noise, const LayerVolumes* layers = nullptr,
          const Vec3& eye = Vec3(0.0))
        : scene_(scene),
          layers_(layers && !layers->empty() ? layers : nullptr),
          eye_(eye),
          matter_(scene, noise, eye, kMaxOpticalDepth, false) {
        sunE_ = scene.sun.color * scene.sun.intensity;
    }

    const Scene& scene() const { return scene_; }
    // The primary rays' transmittance is estimated (noise or layers), not in closed form.
    bool estimatesTransmittance() const { return varies() || layers_; }
    bool varies() const { return matter_.varies(); }  // not the smooth field's closed form

    // The chords of the ray o + t d (unit d) within [t0, t1], sorted by entry.
    void collect(const Vec3& o, const Vec3& d, double t0, double t1, RayData& r) const {
        matter_.chords(o, d, t0, t1, r.cross);
    }

    // collect() and the ray's majorant (detail::chordPieces per chord).
    void prepare(const Vec3& o, const Vec3& d, double t0, double t1, RayData& r) const {
        collect(o, d, t0, t1, r);
        r.pieces.clear();
        for (const CloudMatter::Chord& c : r.cross)
            detail::chordPieces({c.tIn, c.tOut, c.len, c.tc, 1 - c.b2}, matter_.sigma(c.shape) * matter_.noiseBound(),
                                r.breaks, r.pieces);
        detail::buildMajorant(r.pieces, r.events, r.segs);
        prepareLayers(o, d, t0, t1, r);
    }

    void prepareLayers(const Vec3& o, const Vec3& d, double t0, double t1, RayData& r) const {
        if (layers_) detail::prepareLayerRay(*layers_, eye_, o, d, t0, t1, r.layers);
    }

    // Extinction (1/m) at o + t d, from the ray's chords (nephele/cloud_matter.hpp).
    double sigmaAt(const Vec3& o, const Vec3& d, double t, const RayData& r) const {
        return matter_.extinctionAlong(o, d, t, r.cross);
    }
    // Extinction (1/m) of the ellipsoids at the point x: what sigmaAt gives on any ray through x.
    double sigmaAtPoint(const Vec3& x) const { return matter_.extinction(x); }

    // The world box outside which the ellipsoids hold no matter (lo > hi when there is none).
    std::pair<Vec3, Vec3> bounds() const { return matter_.bounds(); }

    // The first collision: with the ellipsoids' matter, or nearer with the layers' (each sampled
    // in its own medium).
    double deltaTrack(const Vec3& o, const Vec3& d, const RayData& r, Pcg32& rng) const {
        const double t = detail::deltaTrack(
            r.segs, [&](double t) { return sigmaAt(o, d, t, r); }, rng);
        return layers_ ? std::min(t, detail::layerFreeFlight(*layers_, eye_, o, d, r.layers, rng)) : t;
    }

    // Cloud transmittance over [t0, t1] of a ray prepared in r: closed form (model::segmentDepth,
    // as exactDensityOpacity) without noise, ratio tracking with it.
    double transmittance(const Vec3& o, const Vec3& d, double t0, double t1, const RayData& r, Pcg32* rng) const {
        if (layers_)
            return ellipsoidTransmittance(o, d, t0, t1, r, rng) *
                   detail::layerTransmittance(*layers_, eye_, o, d, r.layers, *rng);
        return ellipsoidTransmittance(o, d, t0, t1, r, rng);
    }
    double ellipsoidTransmittance(const Vec3& o, const Vec3& d, double t0, double t1, const RayData& r,
                                  Pcg32* rng) const {
        if (varies())
            return detail::ratioTrack(
                r.segs, [&](double t) { return sigmaAt(o, d, t, r); }, *rng);
        const double tau = matter_.smoothDepth(o, d, t0, t1, r.cross);
        return std::exp(-tau);
    }

    // Fraction of the sun's irradiance reaching x: cloud transmittance, 0 behind an object.
    // tMinObjects (m): how far from x an object may block (> 0 on surfaces, against self-shadowing).
    double sunTransmittance(const Vec3& x, double tMinObjects, RayData& r, Pcg32& rng) const {
        const Vec3& l = scene_.sun.direction;
        if (intersectObjects(scene_, x, l, tMinObjects, kInf)) return 0;
        if (varies()) {
            prepare(x, l, 0, kInf, r);
        } else {
            collect(x, l, 0, kInf, r);  // the closed form needs only the chords
            prepareLayers(x, l, 0, kInf, r);
        }
        return transmittance(x, l, 0, kInf, r, &rng);
    }

    // Radiance leaving an object hit at x: Lambert under the sun, shadowed.
    Vec3 surfaceRadiance(const Vec3& x, const SurfaceHit& hit, RayData& r, Pcg32& rng) const {
        const Vec3 lambert = lambertRadiance(scene_.sun, hit.albedo, hit.normal);
        if (lambert == Vec3(0.0)) return lambert;
        const double eps = 1e-7 * (1 + glm::length(x));  // m, past the surface's round-off
        return lambert * sunTransmittance(x, eps, r, rng);
    }

    // One path's radiance estimate for the camera ray (eye, d) already prepared in ws.primary.
    // The contributions of the scattering orders firstBounce..maxBounces (a contribution's order:
    // the new directions its path took before it, the sun's next-event estimate at vertex v and
    // the sky or a surface reached after v of them both count as order v).
    Vec3 trace(const Vec3& eye, const Vec3& d0, const std::optional<SurfaceHit>& primaryHit, int firstBounce,
               int maxBounces, Pcg32& rng, Workspace& ws) const {
        const Medium& m = scene_.medium;
        Vec3 radiance(0.0), beta(1.0), o = eye, d = d0;
        const RayData* ray = &ws.primary;
        std::optional<SurfaceHit> hit = primaryHit;
        for (int vertex = 0;; ++vertex) {
            const double t = deltaTrack(o, d, *ray, rng);
            if (t == detail::kNoCollision) {  // the path leaves the medium: an object, or the sky
                if (!hit) return vertex < firstBounce ? radiance : radiance + beta * skyRadiance(scene_.sky, d);
                const Vec3 x = o + hit->distance * d;
                if (vertex >= firstBounce) radiance += beta * surfaceRadiance(x, *hit, ws.shadow, rng);
                // object_light "all": the object is a Lambertian receiver of every light, so the
                // path goes on from the surface in a cosine-distributed direction (the Lambert
                // BRDF albedo / pi times the cosine over that pdf, cos / pi, leaves the albedo as
                // the throughput) and collects the sky's, the ground's and the clouds' light.
                if (scene_.objectLight != ObjectLight::All || vertex >= maxBounces) return radiance;
                beta *= hit->albedo;
                if (beta == Vec3(0.0)) return radiance;
                d = sampleCosine(hit->normal, rng);
                const double eps = 1e-7 * (1 + glm::length(x));  // m, past the surface's round-off
                o = x + eps * hit->normal;
                hit = intersectObjects(scene_, o, d, eps, kInf);
                prepare(o, d, 0, hit ? hit->distance : kInf, ws.secondary);
                ray = &ws.secondary;
                continue;
            }
            const Vec3 x = o + t * d;
            beta *= m.albedo;  // sigma_s / sigma_t
            if (sunE_ != Vec3(0.0) &&
                vertex >= firstBounce)  // next-event estimation: sun irradiance * phase * transmittance
                radiance +=
                    beta * sunE_ *
                    (hgPhase(glm::dot(d, scene_.sun.direction), m.hgG) * sunTransmittance(x, 0, ws.shadow, rng));
            if (vertex >= maxBounces || beta == Vec3(0.0)) return radiance;
            d = sampleHg(d, m.hgG, rng);
            o = x;
            hit = intersectObjects(scene_, o, d, 0, kInf);
            prepare(o, d, 0, hit ? hit->distance : kInf, ws.secondary);
            ray = &ws.secondary;
        }
    }

private:
    const Scene& scene_;
    const LayerVolumes* layers_;
    Vec3 eye_;
    CloudMatter matter_;  // the ellipsoids' matter, capped at kMaxOpticalDepth, every cloud whole
    Vec3 sunE_{0.0};      // sun irradiance, colour * intensity
};

// Progress through the host's progress callback (nephele/log.hpp), as rows finish.
class Progress {
public:
    Progress(bool on, int total) : on_(on), total_(total) { report(0); }
    void rowDone() {
        if (!on_) return;
        const int done = ++done_;
        const int percent = int(100LL * done / total_);
        std::lock_guard lock(mutex_);
        if (percent != shown_) report(percent);
    }

private:
    void report(int percent) {
        if (!on_) return;
        shown_ = percent;
        reportProgress("pathtrace", percent / 100.0);
    }
    bool on_;
    int total_, shown_ = -1;
    std::atomic<int> done_{0};
    std::mutex mutex_;
};

}  // namespace

namespace {

void checkSettings(const PathTraceSettings& s) {
    if (s.spp < 1) throw std::invalid_argument("renderPathTraced: spp must be >= 1");
    if (s.maxBounces < 0) throw std::invalid_argument("renderPathTraced: maxBounces must be >= 0");
    if (s.firstBounce < 0 || s.firstBounce > s.maxBounces)
        throw std::invalid_argument("renderPathTraced: firstBounce must be in 0..maxBounces");
}

// The pixels of rows [y0, y1) step `stride` (and columns step `stride`) at `spp` samples into
// `image` (RGBA); the same estimate per pixel as the full render.
void tracePixels(const World& world, const View& view, int spp, int firstBounce, int maxBounces, unsigned seed, int y,
                 int stride, Image& image, Workspace& ws) {
    const Scene& scene = world.scene();
    const int width = view.camera.width;
    for (int x = 0; x < width; x += stride) {
        const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
        // The GPU clips at the near/far planes, at distance near / cos(angle to forward).
        const double c = glm::dot(d, view.forward);
        const double tNear = view.camera.nearClip / c, tFar = view.camera.farClip / c;
        const std::optional<SurfaceHit> hit = intersectObjects(scene, view.eye, d, tNear, tFar);
        const double tEnd = hit ? hit->distance : tFar;
        world.prepare(view.eye, d, tNear, tEnd, ws.primary);  // shared by every sample of the pixel
        const std::uint64_t pixel = std::uint64_t(y) * width + x;
        Vec3 sum(0.0);
        double transmittance = 0;
        for (int k = 0; k < spp; ++k) {
            Pcg32 rng = detail::sampleRng(seed, pixel, std::uint64_t(k));
            sum += world.trace(view.eye, d, hit, firstBounce, maxBounces, rng, ws);
            if (world.estimatesTransmittance())
                transmittance += world.transmittance(view.eye, d, tNear, tEnd, ws.primary, &rng);
        }
        transmittance = world.estimatesTransmittance()
                            ? transmittance / spp
                            : world.transmittance(view.eye, d, tNear, tEnd, ws.primary, nullptr);
        for (int k = 0; k < 3; ++k) image.at(x, y, k) = float(sum[k] / spp);
        image.at(x, y, 3) = float(1 - transmittance);
    }
}

constexpr int kPilotStride = 8;            // the estimate traces every 8th pixel of every 8th row
constexpr int kPilotSpp = 2;               // at up to 2 samples
constexpr double kMinPilotSamples = 8192;  // a denser grid below this

// CPU time of the calling thread (s): what a piece of work costs, whatever else the machine runs.
double threadCpuSeconds() {
    timespec t{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Seconds the full render would take on an otherwise idle machine: a pilot over a sparse grid
// of pixels, each row's CPU time measured on the thread that ran it (a busy machine's
// preemption and thread start-up do not count: a 100 ms stall of a 1 ms row would be scaled
// by the pilot's 1/683), scaled by the samples it stands for and shared among the threads the
// render will use.
double pilotSeconds(const World& world, const View& view, const PathTraceSettings& s) {
    const int width = view.camera.width, height = view.camera.height;
    const int spp = std::min(s.spp, kPilotSpp);
    // A denser grid for small renders: at least kMinPilotSamples (or all of them), so that
    // what a first call costs once (page faults, lazy binding) is not scaled up with the rest.
    auto samples = [&](int stride) {
        return double((height + stride - 1) / stride) * ((width + stride - 1) / stride) * spp;
    };
    int stride = kPilotStride;
    while (stride > 1 && samples(stride) < std::min(kMinPilotSamples, double(width) * height * spp)) stride /= 2;
    Image scratch(width, height, 4);
    {
        Workspace ws;  // warm-up, untimed
        tracePixels(world, view, spp, s.firstBounce, s.maxBounces, s.seed, height / 2, stride, scratch, ws);
    }
    const int rows = (height + stride - 1) / stride;
    std::vector<double> rowSeconds(std::size_t(rows), 0.0);
    parallelFor(rows, [&](int r) {
        const double start = threadCpuSeconds();
        Workspace ws;
        tracePixels(world, view, spp, s.firstBounce, s.maxBounces, s.seed, r * stride, stride, scratch, ws);
        rowSeconds[std::size_t(r)] = threadCpuSeconds() - start;
    });
    double seconds = 0;
    for (double v : rowSeconds) seconds += v;
    const double traced = samples(stride);
    const int threads = std::max(1, std::min<int>(height, int(std::thread::hardware_concurrency())));
    return seconds * (double(width) * height * s.spp) / traced / threads;
}

std::string durationText(double seconds) {
    char text[64];
    if (seconds < 120) std::snprintf(text, sizeof text, "%.0f s", std::ceil(seconds));
    else if (seconds < 7200) std::snprintf(text, sizeof text, "%.0f min", std::ceil(seconds / 60));
    else std::snprintf(text, sizeof text, "%.1f h", seconds / 3600);
    return text;
}

}  // namespace

double estimatePathTraceSeconds(const Scene& scene, const View& view, const PathTraceSettings& s,
                                const NoiseVolume* noise) {
    checkSettings(s);
    checkScene(scene);
    const World world(scene, noise, s.layers.get(), view.eye);
    return pilotSeconds(world, view, s);
}

Image renderPathTraced(const Scene& scene, const View& view, const PathTraceSettings& s, const NoiseVolume* noise) {
    checkSettings(s);
    checkScene(scene);
    const World world(scene, noise, s.layers.get(), view.eye);
    const int width = view.camera.width, height = view.camera.height;
    requireMemory("the path tracer's " + std::to_string(width) + "x" + std::to_string(height) + " RGBA float image",
                  std::uint64_t(width) * std::uint64_t(height) * 16);
    // Long work says how long before it starts (a pilot of about 1/64 of the pixels at 2 spp).
    if (double(width) * height * s.spp >= kEstimateAboveSamples) {
        const double seconds = pilotSeconds(world, view, s);
        if (seconds >= 2)
            logMessage(LogLevel::Info, "pathtrace: " + std::to_string(width) + "x" + std::to_string(height) + " at " +
                                           std::to_string(s.spp) + " spp: about " + durationText(seconds));
    }
    Image image(width, height, 4);
    Progress progress(s.progress, height);
    parallelFor(height, [&](int y) {
        Workspace ws;
        tracePixels(world, view, s.spp, s.firstBounce, s.maxBounces, s.seed, y, 1, image, ws);
        progress.rowDone();
    });
    ++detail::imagesComputed;
    return image;
}

struct ExtinctionField::Impl {
    Scene scene;  // World keeps a reference to it
    std::shared_ptr<const LayerVolumes> layers;
    Vec3 eye;
    World world;
    Impl(const Scene& s, const NoiseVolume* noise, std::shared_ptr<const LayerVolumes> l, const Vec3& e)
        : scene(s), layers(std::move(l)), eye(e), world(scene, noise, layers.get(), eye) {}
};

ExtinctionField::ExtinctionField(const Scene& scene, const NoiseVolume* noise,
                                 std::shared_ptr<const LayerVolumes> layers, const Vec3& eye) {
    checkScene(scene);
    impl_ = std::make_unique<Impl>(scene, noise, layers && !layers->empty() ? std::move(layers) : nullptr, eye);
    std::tie(lo_, hi_) = impl_->world.bounds();
    if (impl_->layers && impl_->scene.medium.extinction > 0)
        for (const Layer& l : impl_->scene.layers) {
            if (!(l.density > 0 && l.coverage > 0)) continue;
            lo_ = glm::min(lo_, Vec3(eye.x - l.extent, eye.y - l.extent, l.base));
            hi_ = glm::max(hi_, Vec3(eye.x + l.extent, eye.y + l.extent, l.base + l.thickness));
        }
}

ExtinctionField::~ExtinctionField() = default;

double ExtinctionField::operator()(const Vec3& p) const {
    const double clouds = impl_->world.sigmaAtPoint(p);
    return impl_->layers ? clouds + impl_->layers->extinction(p, impl_->eye) : clouds;
}

// ---- The cache.
namespace {

// The cache key: every input that affects the image, as raw bytes in a fixed order.
class Key {
public:
    void add(const void* p, std::size_t n) { bytes_.append(static_cast<const char*>(p), n); }
    void num(double v) { add(&v, sizeof v); }
    void num(std::int64_t v) { add(&v, sizeof v); }
    void vec(const Vec3& v) { num(v.x), num(v.y), num(v.z); }
    void tag(const char* t) { add(t, std::strlen(t) + 1); }
    const std::string& bytes() const { return bytes_; }

private:
    std::string bytes_;
};

std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001B3ull;
    return h;
}

std::string cacheKey(const Scene& sc, const View& view, const PathTraceSettings& s, const NoiseVolume* noise) {
    Key k;
    k.tag("nephele-pathtrace");
    k.num(std::int64_t(kVersion));
    const Camera& c = view.camera;
    k.tag("camera");
    k.vec(c.position), k.vec(c.direction), k.vec(c.up), k.num(c.fovYDeg), k.num(c.nearClip), k.num(c.farClip);
    k.num(std::int64_t(c.width)), k.num(std::int64_t(c.height));
    k.tag("sun");
    k.vec(sc.sun.direction), k.vec(sc.sun.color), k.num(sc.sun.intensity);
    k.tag("sky");
    k.vec(sc.sky.zenith), k.vec(sc.sky.horizon), k.vec(sc.sky.ground);
    const Medium& m = sc.medium;
    k.tag("medium");
    k.num(m.extinction), k.num(m.albedo), k.num(m.hgG), k.num(m.noise), k.num(m.noiseScale);
    if (m.detail.on()) {  // keys without the detail stay as they were
        k.tag("detail");
        k.num(std::int64_t(m.detail.kind)), k.num(m.detail.erosion), k.num(m.detail.scale), k.num(m.detail.smallest);
        k.vec(m.detail.drift);
        if (m.detail.kind == Medium::Detail::Kind::Nephele) {  // its texture is the project's to change
            const DetailVolume& v = detailVolume();
            k.num(std::int64_t(fnv1a(v.texels.data(), v.texels.size() * sizeof(glm::vec3), 0xCBF29CE484222325ull)));
        }
    }
    if (m.noise > 0 && noise) {  // the noise field only matters when it is used
        k.num(std::int64_t(noise->size));
        k.num(std::int64_t(fnv1a(noise->texels.data(), noise->texels.size() * sizeof(float), 0xCBF29CE484222325ull)));
    }
    k.tag("clouds");
    for (const Cloud& cl : sc.clouds) {
        k.num(std::int64_t(cl.ellipsoids.size()));
        if (cl.noiseId && m.noise > 0)
            k.tag("noise-id"), k.num(std::int64_t(cl.noiseId));  // (absent when unused: keys stay)
        for (const Ellipsoid& e : cl.ellipsoids)
            k.vec(e.center), k.vec(e.radii), k.vec(e.rotationDeg), k.num(e.density);
    }
    k.tag("objects");
    for (const Object& o : sc.objects) {
        k.num(std::int64_t(o.type)), k.vec(o.center), k.vec(o.rotationDeg), k.vec(o.color);
        if (o.type == Object::Type::Box) k.vec(o.size);
        else k.num(o.radius);
    }
    if (sc.objectLight != ObjectLight::Sun)
        k.tag("object-light-all");         // (absent by default: the keys of before stay valid)
    if (s.layers && !s.layers->empty()) {  // only rendered layers change the image
        k.tag("layers");
        const std::string layers = s.layers->key();
        k.add(layers.data(), layers.size());
    }
    k.tag("settings");
    k.num(std::int64_t(s.spp)), k.num(std::int64_t(s.maxBounces)), k.num(std::int64_t(s.seed));
    if (s.firstBounce > 0) k.num(std::int64_t(s.firstBounce));  // (absent when 0: the keys of before stay valid)
    return k.bytes();
}

constexpr char kMagic[8] = {'N', 'E', 'P', 'H', 'P', 'T', '3', '\n'};

// File (before the checksum of core/internal/cache_file.hpp): magic, key length (u64), key, width,
// height, channels (i32), floats. A damaged or implausible file is never used: the caller
// renders again, with a warning when there was a file.
std::optional<Image> readCache(const std::filesystem::path& file, const std::string& key) {
    std::string why;
    const std::size_t maxBytes = 8 + 8 + key.size() + 12 + std::size_t(kMaxImageSide) * kMaxImageSide * 16;
    const std::optional<std::string> bytes = cache::read(file.string(), maxBytes, why);
    auto reject = [&](const std::string& what) -> std::optional<Image> {
        logMessage(LogLevel::Warning,
                   "ignoring the path tracer's cache file " + file.string() + ": " + what + "; rendering again");
        return std::nullopt;
    };
    if (!bytes) return why.empty() ? std::nullopt : reject(why);
    const std::string& b = *bytes;
    std::uint64_t keyLength = 0;
    if (b.size() < 16 || std::memcmp(b.data(), kMagic, 8) != 0) return reject("not a cache file of this version");
    std::memcpy(&keyLength, b.data() + 8, 8);
    if (keyLength != key.size() || b.size() < 16 + keyLength + 12 || b.compare(16, keyLength, key) != 0)
        return std::nullopt;  // another image under the same name (a hash collision): a plain miss
    std::int32_t dims[3];
    std::memcpy(dims, b.data() + 16 + keyLength, sizeof dims);
    if (dims[0] < 1 || dims[1] < 1 || dims[2] != 4 || dims[0] > kMaxImageSide || dims[1] > kMaxImageSide)
        return reject("implausible image size");
    Image image(dims[0], dims[1], dims[2]);
    const std::size_t offset = 16 + keyLength + 12, floats = image.pixels.size() * sizeof(float);
    if (b.size() != offset + floats) return reject("wrong length");
    std::memcpy(image.pixels.data(), b.data() + offset, floats);
    for (std::size_t i = 0; i < image.pixels.size(); ++i) {
        const float v = image.pixels[i];
        if (!std::isfinite(v) || v < 0 || (i % 4 == 3 && v > 1))
            return reject("a value that is not a radiance or an opacity");
    }
    return image;
}

void writeCache(const std::filesystem::path& file, const std::string& key, const Image& image) {
    const std::uint64_t keyLength = key.size();
    const std::int32_t dims[3] = {image.width, image.height, image.channels};
    std::string bytes(kMagic, 8);
    bytes.append(reinterpret_cast<const char*>(&keyLength), sizeof keyLength);
    bytes += key;
    bytes.append(reinterpret_cast<const char*>(dims), sizeof dims);
    bytes.append(reinterpret_cast<const char*>(image.pixels.data()), image.pixels.size() * sizeof(float));
    const std::string why = cache::write(file.string(), bytes);
    // The image is still good: say so and go on without caching it.
    if (!why.empty()) logMessage(LogLevel::Warning, "could not write the path tracer's cache file: " + why);
}

}  // namespace

Image renderPathTracedCached(const Scene& scene, const View& view, const PathTraceSettings& s, const NoiseVolume* noise,
                             const std::string& cacheDir) {
    const std::string key = cacheKey(scene, view, s, noise);
    char name[64];
    std::snprintf(name, sizeof name, "pathtrace-%016llx%016llx.bin",
                  static_cast<unsigned long long>(fnv1a(key.data(), key.size(), 0xCBF29CE484222325ull)),
                  static_cast<unsigned long long>(fnv1a(key.data(), key.size(), 0x84222325CBF29CE4ull)));
    const std::filesystem::path file = std::filesystem::path(cacheDir) / name;
    if (auto cached = readCache(file, key)) return *cached;
    Image image = renderPathTraced(scene, view, s, noise);
    std::error_code ec;
    std::filesystem::create_directories(cacheDir, ec);
    writeCache(file, key, image);
    return image;
}

}  // namespace nephele
