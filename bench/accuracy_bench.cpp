// `nephele bench --accuracy`: every method with a sweep of its settings, timed and compared
// with the path-traced reference on the shared scenes and on a distance series, with the
// exact field (medium.noise 0) and with the scene's noise. CSV, charts, a generated section for docs/benchmarks.md.
#include "bench_command.hpp"

#include "accuracy_reference.hpp"
#include "bench_util.hpp"
#include "render_command.hpp"

#include "nephele/ellipsoid.hpp"
#include "nephele/gardner.hpp"
#include "nephele/generate.hpp"
#include "nephele/gl.hpp"
#include "nephele/layered.hpp"
#include "nephele/metrics.hpp"
#include "nephele/pathtrace.hpp"
#include "nephele/png.hpp"
#include "nephele/raymarch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include <unistd.h>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

enum class Kind { Ellipsoid, Raymarch, GardnerExact, PathTrace };

const char* kindName(Kind k) {
    switch (k) {
        case Kind::Ellipsoid: return "ellipsoid";
        case Kind::Raymarch: return "raymarch";
        case Kind::GardnerExact: return "gardner-exact";
        case Kind::PathTrace: return "pathtrace";
    }
    return "?";
}

// One point of a method's sweep.
struct Config {
    Kind kind;
    std::string setting;  // "default", "max tile 64", ...
    EllipsoidSettings ellipsoid;
    RaymarchSettings raymarch;
    PathTraceSettings pathtrace;
    bool noiseOnly = false;  // only differs from the default when medium.noise > 0
};

std::vector<Config> sweep(bool quick) {
    std::vector<Config> c;
    auto ell = [&](std::string name, auto change) {
        Config k{Kind::Ellipsoid, std::move(name), {}, {}, {}};
        change(k.ellipsoid);
        c.push_back(k);
    };
    auto ray = [&](std::string name, auto change, bool noiseOnly = false) {
        Config k{Kind::Raymarch, std::move(name), {}, {}, {}};
        change(k.raymarch);
        k.noiseOnly = noiseOnly;
        c.push_back(k);
    };
    ell("default", [](EllipsoidSettings&) {});
    ray("default", [](RaymarchSettings&) {});
    if (!quick) {
        ell("max tile 128", [](EllipsoidSettings& s) { s.maxTile = 128; });
        ell("max tile 32", [](EllipsoidSettings& s) { s.maxTile = 32; });
        ell("min tile 64", [](EllipsoidSettings& s) { s.minTile = 64; });
        ell("8-bit atlas", [](EllipsoidSettings& s) { s.precision = AtlasPrecision::Unorm8; });
        ell("tessellation 6", [](EllipsoidSettings& s) { s.tessellation = 6; });
        ell("tessellation 48", [](EllipsoidSettings& s) { s.tessellation = 48; });
        ell("light grid 16",
            [](EllipsoidSettings& s) { s.light.size = 16, s.light.sunPhotons /= 4, s.light.skyPhotons /= 4; });
        ell("light grid not fitted", [](EllipsoidSettings& s) { s.light.fitToCloud = false; });
        ell("photons x 4", [](EllipsoidSettings& s) { s.light.sunPhotons *= 4, s.light.skyPhotons *= 4; });
        ell("polygon tiles", [](EllipsoidSettings& s) { s.geometry = TileGeometry::Polygon; });
        ell("weighted composite", [](EllipsoidSettings& s) { s.order = CompositeOrder::Weighted; });
        ell("moment composite", [](EllipsoidSettings& s) { s.order = CompositeOrder::Moments; });
        ray("step 10 m", [](RaymarchSettings& s) { s.step = 10; });
        ray("step 50 m", [](RaymarchSettings& s) { s.step = 50; });
        ray("step 100 m", [](RaymarchSettings& s) { s.step = 100; });
        ray("fixed step", [](RaymarchSettings& s) { s.lodDistance = 0; });
        ray("a ray per pixel", [](RaymarchSettings& s) { s.downsample = 1; });
        ray("light grid 16",
            [](RaymarchSettings& s) { s.light.size = 16, s.light.sunPhotons /= 4, s.light.skyPhotons /= 4; });
        ray(
            "octaves 2", [](RaymarchSettings& s) { s.octaves = 2; }, true);
    }
    c.push_back({Kind::GardnerExact, "CPU, float", {}, {}, {}});
    Config pt{Kind::PathTrace, "16 spp", {}, {}, {}};
    pt.pathtrace.spp = 16;
    pt.pathtrace.seed = 2;  // independent of the reference's seed
    c.push_back(pt);
    return c;
}

struct Case {
    std::string name;      // "single.json", "cumulus27.json at 6000 m"
    double distance = -1;  // m from the eye to the cloud's centroid, for the distance series
    Scene scene;
};

Vec3 centroid(const Cloud& cloud) {
    Vec3 c(0.0);
    for (const Ellipsoid& e : cloud.ellipsoids) c += e.center;
    return c / double(std::max<std::size_t>(1, cloud.ellipsoids.size()));
}

void scaleTo(Scene& s, int width) {
    const double aspect = double(s.camera.width) / s.camera.height;
    s.camera.width = width;
    s.camera.height = std::max(1, int(std::lround(width / aspect)));
}

// A unit vector at `elevationDeg` above the horizontal, `azimuthDeg` around z from the
// horizontal part of `forward`.
Vec3 sunAround(const Vec3& forward, double azimuthDeg, double elevationDeg) {
    const Vec3 h = glm::normalize(Vec3(forward.x, forward.y, 0.0));
    const double a = glm::radians(azimuthDeg), e = glm::radians(elevationDeg);
    const Vec3 side(-h.y, h.x, 0.0);
    return glm::normalize(std::cos(e) * (std::cos(a) * h + std::sin(a) * side) + Vec3(0, 0, std::sin(e)));
}

std::vector<Case> cases(const AccuracyOptions& o) {
    std::vector<Case> out;
    const std::vector<std::string> names =
        o.bench.quick ? std::vector<std::string>{"single.json"}
                      : std::vector<std::string>{"single.json", "two_clouds.json", "flythrough.json", "field1000.json"};
    for (const std::string& n : names) {
        Case c{n, -1, loadScene(o.bench.scenesDir + "/" + n)};
        scaleTo(c.scene, o.width);
        out.push_back(std::move(c));
    }
    // The distance series: cumulus27 seen along its camera's direction from inside out to 15 km.
    const Scene base = loadScene(o.bench.scenesDir + "/cumulus27.json");
    const Vec3 target = centroid(base.clouds.at(0));
    const Vec3 forward = base.camera.direction;
    const std::vector<double> distances =
        o.bench.quick ? std::vector<double>{6000} : std::vector<double>{0, 600, 2000, 6000, 15000};
    auto at = [&](const Scene& s, double d) {
        Scene c = s;
        c.camera.position = target - d * forward;
        c.camera.width = base.camera.width;
        c.camera.height = base.camera.height;
        // Inside, every path scatters hundreds of times: the reference costs ~50x a view from
        // outside, so that case is rendered at half the width.
        scaleTo(c, d == 0 ? o.width / 2 : o.width);
        return c;
    };
    for (double d : distances)
        out.push_back(
            {"cumulus27.json at " + (d == 0 ? std::string("0 m (inside)") : fmt("%.0f m", d)), d, at(base, d)});
    if (o.bench.quick) return out;
    // The light's hard cases. Back-lit: the sun 20 degrees off the view axis, behind the cloud
    // (the silver lining, and the dark core). A low sun (5 degrees) from the side.
    Scene backLit = at(base, 2000);
    backLit.sun.direction = sunAround(forward, 0, 20);
    out.push_back({"cumulus27.json back-lit (sun 20° off the view)", -1, backLit});
    Scene lowSun = at(base, 2000);
    lowSun.sun.direction = sunAround(forward, 90, 5);
    out.push_back({"cumulus27.json, low sun (5°, from the side)", -1, lowSun});
    // A small, thin cloud: one 80 x 60 x 50 m puff at density 0.3, 600 m away.
    Scene thin = loadScene(o.bench.scenesDir + "/single.json");
    for (Ellipsoid& e : thin.clouds.at(0).ellipsoids) e.radii = Vec3(80, 60, 50), e.density = 0.3;
    thin.camera.position = thin.clouds[0].ellipsoids[0].center - 600.0 * thin.camera.direction;
    scaleTo(thin, o.width);
    out.push_back({"small thin cloud (80 m, density 0.3) at 600 m", -1, thin});
    // A dense cumulus of 150 ellipsoids (the cumulus generator), seen from 300 m off its side.
    Scene dense = base;
    Generator g;
    g.center = target;
    g.count = 150;
    g.seed = 11;
    g.sigma = Vec3(220, 220, 90);
    g.maxRadius = 160;
    dense.clouds = {generateCumulus(g)};
    const Vec3 denseCentre = centroid(dense.clouds[0]);
    double reach = 0;  // the cloud's horizontal half-size along the view
    for (const Ellipsoid& e : dense.clouds[0].ellipsoids)
        reach = std::max(reach, glm::dot(e.center - denseCentre, -forward) + e.maxRadius());
    dense.camera.position = denseCentre - (reach + 300.0) * forward;
    scaleTo(dense, o.width);
    out.push_back(
        {"dense cumulus (" + std::to_string(dense.clouds[0].ellipsoids.size()) + " ellipsoids) from 300 m", -1, dense});
    return out;
}

struct Result {
    std::string noise;  // "0" or "scene"
    std::string caseName;
    double distance = -1;
    Kind kind;
    std::string setting;
    double ms = 0;
    double relRmse = 0;  // RMSE over cloud pixels / mean reference radiance there
    double psnrFit = 0, exposure = 1, ssim = 0;
    double alphaMae = 0;
    bool pareto = false;  // on the Pareto front of the aggregate (set later)
};

// What the reference of one case cost and how noisy it is.
struct ReferenceInfo {
    std::string noise, caseName;
    double relNoise = 0, seconds = 0;
    int traced = 0;                                     // path traces computed in this run (0: all from the cache)
    int spp = 0;                                        // the sun part's samples per pixel it took
    int highSpp = 0;                                    // of the scattering orders past kReferenceBounces
    double highShare = 0;                               // their share of the light
    double scratchSeconds = 0, highScratchSeconds = 0;  // made afresh here, estimated (Reference)
};

// One method's error on one case split by light (noise 0).
struct ComponentRow {
    std::string caseName, method;
    ReferenceShares shares;
    ComponentErrors errors;
};

// The defaults of the compositor (back to front, as --method auto composites; and weighted),
// the ray-marcher and gardner-exact, each split by light against the reference.
std::vector<ComponentRow> measureComponents(const Scene& scene, const View& view, const Reference& ref,
                                            const NoiseVolume& noise, const NoiseSettings& ns, const OpaquePass& opaque,
                                            int block) {
    const bool objects = !scene.objects.empty();
    FrameTarget target(scene.camera.width, scene.camera.height);
    RadianceGridSettings singleOnly;  // no photons: single scattering alone
    singleOnly.sunPhotons = singleOnly.skyPhotons = 0;
    auto gpu = [&](auto make) {
        return [&, make](const Scene& sc, bool single) {
            auto renderer = make(single ? singleOnly : RadianceGridSettings{});
            opaque.draw(sc, view, target.framebuffer());
            renderer->render(sc, view, target.framebuffer(), objects);
            return target.readColor();
        };
    };
    auto ellipsoid = [](CompositeOrder order) {
        return [order](const RadianceGridSettings& light) {
            EllipsoidSettings s;
            s.order = order;
            s.light = light;
            return std::make_unique<EllipsoidRenderer>(s);
        };
    };
    auto raymarch = [](const RadianceGridSettings& light) {
        RaymarchSettings s;
        s.light = light;
        return std::make_unique<RaymarchRenderer>(s);
    };
    auto exact = [&](const Scene& sc, bool single) {
        return renderGardnerExact(sc, view, noise, ns, CompositeOrder::PerEllipsoid, model::kWeightExponent,
                                  single ? singleOnly : RadianceGridSettings{});
    };
    std::vector<ComponentRow> rows;
    auto add = [&](const char* name, const std::function<Image(const Scene&, bool)>& render) {
        rows.push_back({"", name, {}, componentErrors(scene, view, ref, block, render)});
    };
    add("ellipsoid (auto)", gpu(ellipsoid(CompositeOrder::PerEllipsoid)));
    add("ellipsoid, weighted", gpu(ellipsoid(CompositeOrder::Weighted)));
    add("ellipsoid, moments", gpu(ellipsoid(CompositeOrder::Moments)));
    add("raymarch", gpu(raymarch));
    add("gardner-exact", exact);
    return rows;
}

struct Aggregate {
    std::string noise;
    Kind kind;
    std::string setting;
    double totalMs = 0, meanRelRmse = 0;
    int cases = 0;
    bool pareto = false;
};

// Marks the Pareto front per noise setting: no other point is both at most as slow and at most
// as wrong, and strictly better in one.
void markPareto(std::vector<Aggregate>& a) {
    for (Aggregate& p : a) {
        p.pareto = true;
        for (const Aggregate& q : a)
            if (&q != &p && q.noise == p.noise && q.totalMs <= p.totalMs && q.meanRelRmse <= p.meanRelRmse &&
                (q.totalMs < p.totalMs || q.meanRelRmse < p.meanRelRmse))
                p.pareto = false;
    }
}

// The layered sky's layer count N against its own converged limit (its error against the
// path tracer, which renders a layer as a volume, is `bench --layer-accuracy`'s): the same
// frame with kLayeredReferenceN layers, on the layer of
// near_and_far.json seen from below (the scene's camera), grazing (just under the base,
// looking at the horizon) and from above.
constexpr int kLayeredReferenceN = 128;

struct LayeredPoint {
    std::string view;
    int layers = 0;
    double ms = 0, relRmse = 0;
};

std::vector<LayeredPoint> layeredConvergence(const AccuracyOptions& o, const OpaquePass& opaque) {
    Scene base = loadScene(o.bench.scenesDir + "/near_and_far.json");
    base.clouds.clear();
    if (base.layers.empty()) throw UsageError(base.file + ": the layered convergence needs a scene with layers");
    scaleTo(base, o.width);
    const Layer& layer = base.layers.front();
    struct ViewCase {
        std::string name;
        Vec3 eye, lookAt;
    };
    const double mid = layer.base + 0.5 * layer.thickness;
    const std::vector<ViewCase> views = {
        {"below (the scene's camera)", base.camera.position, base.camera.position + base.camera.direction},
        {"grazing, 100 m under the base", Vec3(0, 0, layer.base - 100), Vec3(0, 10000, layer.base - 100 + 200)},
        {"above, looking 10° down", Vec3(0, 0, mid + 2000), Vec3(0, 10000, mid + 2000 - 1763)}};
    const std::vector<int> counts = o.bench.quick ? std::vector<int>{2, 8} : std::vector<int>{2, 4, 8, 16, 32};
    std::vector<LayeredPoint> out;
    // The lighting volume depends on the layer, not on N: computed once and shared through a
    // cache folder (a temporary one, removed at the end, under --no-cache).
    std::string cacheDir = o.bench.cacheDir;
    struct TempDir {
        std::string path;
        ~TempDir() {
            std::error_code ec;
            if (!path.empty()) fs::remove_all(path, ec);
        }
    } temp;
    if (cacheDir.empty()) {
        temp.path = (fs::temp_directory_path() / ("nephele-layered-" + std::to_string(::getpid()))).string();
        fs::create_directories(temp.path);
        cacheDir = temp.path;
    }
    std::vector<std::unique_ptr<LayeredRenderer>> renderers;
    for (int n : counts) {
        LayeredSettings ls;
        ls.layers = n;
        ls.cacheDir = cacheDir;
        renderers.push_back(std::make_unique<LayeredRenderer>(ls));
    }
    LayeredSettings refSettings;
    refSettings.layers = kLayeredReferenceN;
    refSettings.cacheDir = cacheDir;
    LayeredRenderer reference(refSettings);
    for (const ViewCase& vc : views) {
        Scene scene = base;
        scene.camera.position = vc.eye;
        scene.camera.direction = glm::normalize(vc.lookAt - vc.eye);
        scene.path.clear();
        const View view = makeView(scene.camera);
        FrameTarget target(scene.camera.width, scene.camera.height);
        opaque.draw(scene, view, target.framebuffer());
        reference.render(scene, view, target.framebuffer(), 0);
        const Image ref = blockMean(target.readColor(), o.block);
        std::vector<std::function<void()>> draws;
        for (auto& r : renderers)
            draws.push_back([&, rp = r.get()] { rp->render(scene, view, target.framebuffer(), 0); });
        gl::setChecks(false);
        const std::vector<double> ms = timeFrames(o.frames, target, opaque, scene, view, draws);
        gl::setChecks(true);
        for (std::size_t k = 0; k < renderers.size(); ++k) {
            opaque.draw(scene, view, target.framebuffer());
            draws[k]();
            out.push_back({vc.name, counts[k], ms[k], relativeRmse(blockMean(target.readColor(), o.block), ref)});
        }
        gl::checkAlways("bench --accuracy (layered)");
        std::cerr << "bench: accuracy: layered, " << vc.name << ": done\n";
    }
    return out;
}

// "64–1024": the range of the references' samples per pixel.
std::string sppRange(const std::vector<ReferenceInfo>& info, int ReferenceInfo::*spp = &ReferenceInfo::spp) {
    int lo = 0, hi = 0;
    for (const ReferenceInfo& i : info) lo = lo ? std::min(lo, i.*spp) : i.*spp, hi = std::max(hi, i.*spp);
    return lo == hi ? std::to_string(hi) : std::to_string(lo) + "–" + std::to_string(hi);
}

// The cases side by side with `medium.noise` 0, one row per case: the reference, the
// compositor (auto's defaults), the ray-marcher, each magnified by a whole factor into a cell
// of the largest case's size, on black.
struct ViewRow {
    Image reference, compositor, marcher;
};
Image viewsMontage(const std::vector<ViewRow>& rows) {
    int cellW = 1, cellH = 1;
    for (const ViewRow& r : rows)
        cellW = std::max(cellW, r.reference.width), cellH = std::max(cellH, r.reference.height);
    const int gap = 4;
    Image out(3 * cellW + 2 * gap, int(rows.size()) * (cellH + gap) - gap, 4);
    for (std::size_t p = 0; p < std::size_t(out.width) * out.height; ++p) out.pixels[4 * p + 3] = 1;
    for (std::size_t row = 0; row < rows.size(); ++row) {
        const Image* cells[3] = {&rows[row].reference, &rows[row].compositor, &rows[row].marcher};
        for (int c = 0; c < 3; ++c) {
            const Image& im = *cells[c];
            if (im.width == 0 || im.height == 0) continue;
            const int k = std::max(1, std::min(cellW / im.width, cellH / im.height));
            const int x0 = c * (cellW + gap) + (cellW - k * im.width) / 2,
                      y0 = int(row) * (cellH + gap) + (cellH - k * im.height) / 2;
            for (int y = 0; y < k * im.height; ++y)
                for (int x = 0; x < k * im.width; ++x)
                    for (int ch = 0; ch < 3; ++ch) out.at(x0 + x, y0 + y, ch) = im.at(x / k, y / k, ch);
        }
    }
    return out;
}

// The reference's settings from the options: its samples per pixel, pieces and noise target.
ReferenceSettings referenceSettings(const AccuracyOptions& o) {
    ReferenceSettings s;
    s.spp = o.referenceSpp;
    s.targetNoise = o.referenceNoise;
    s.pieceSpp = std::min(s.pieceSpp, std::max(1, o.referenceSpp / 2));
    s.skySpp = std::max(2, o.referenceSpp / 4);
    s.singleSpp = std::max(1, o.referenceSpp / 16);
    s.block = o.block;
    s.cacheDir = o.bench.cacheDir;
    return s;
}

// What a run measured: every case's reference, the methods against it, the layered sky's N.
struct Measured {
    std::vector<ReferenceInfo> refInfo;
    std::vector<ComponentRow> components;
    std::vector<Result> results;
    std::vector<LayeredPoint> layered;
    std::vector<ViewRow> views;  // noise 0, for accuracy_views.png
    std::string renderer;
};

// The sweep's renderers (a GPU config's own; none for a CPU one), the field's noise, the sky pass.
struct Methods {
    const std::vector<Config>& configs;
    const ReferenceSettings& refSettings;
    NoiseSettings ns;
    NoiseVolume noise;
    std::vector<std::unique_ptr<EllipsoidRenderer>> ellipsoids;
    std::vector<std::unique_ptr<RaymarchRenderer>> marchers;
    OpaquePass opaque;

    Methods(const std::vector<Config>& c, const ReferenceSettings& r)
        : configs(c), refSettings(r), noise(makeNoiseVolume(ns)), ellipsoids(c.size()), marchers(c.size()) {
        for (std::size_t i = 0; i < configs.size(); ++i) {
            if (configs[i].kind == Kind::Ellipsoid)
                ellipsoids[i] = std::make_unique<EllipsoidRenderer>(configs[i].ellipsoid);
            if (configs[i].kind == Kind::Raymarch)
                marchers[i] = std::make_unique<RaymarchRenderer>(configs[i].raymarch);
        }
    }
};

// One config's image of a case against the reference, as a Result (and, with noise 0, a
// default's image for the views montage).
void record(const AccuracyOptions& o, const Config& config, const Case& c, const std::string& noiseMode,
            const Reference& reference, double ms, const Image& img, Measured& m) {
    if (noiseMode == "0" && config.setting == "default") {
        if (config.kind == Kind::Ellipsoid) m.views.back().compositor = img;
        if (config.kind == Kind::Raymarch) m.views.back().marcher = img;
    }
    Result r;
    r.noise = noiseMode;
    r.caseName = c.name;
    r.distance = c.distance;
    r.kind = config.kind;
    r.setting = config.setting;
    r.ms = ms;
    // Both at the block grid: the reference's Monte Carlo noise averages down (block^2 pixels a
    // block), the methods' structure stays.
    const Image& referenceBlocks = reference.total;
    const Image mine = blockMean(img, o.block);
    r.relRmse = relativeRmse(mine, referenceBlocks);
    const Image a = channels(mine, 3, 1), b = channels(referenceBlocks, 3, 1);
    const RenderComparison cmp = compareRenders(channels(mine, 0, 3), channels(referenceBlocks, 0, 3), &a, &b);
    r.psnrFit = cmp.psnr, r.exposure = cmp.exposure, r.ssim = cmp.ssim, r.alphaMae = cmp.alphaMae;
    m.results.push_back(r);
}

// The sweep's configs on one case: the GPU ones timed together, frame by frame in turn, then
// one more frame each for the image; the CPU ones one timed run each.
void measureConfigs(const AccuracyOptions& o, Methods& methods, const Case& c, const std::string& noiseMode,
                    const Scene& scene, const Reference& reference, Measured& m) {
    using Clock = std::chrono::steady_clock;
    const std::vector<Config>& configs = methods.configs;
    const View view = makeView(scene.camera);
    const bool objects = !scene.objects.empty();
    FrameTarget target(scene.camera.width, scene.camera.height);
    std::vector<std::size_t> gpu;
    std::vector<std::function<void()>> draws;
    for (std::size_t i = 0; i < configs.size(); ++i) {
        if (configs[i].noiseOnly && scene.medium.noise == 0) continue;
        if (methods.ellipsoids[i]) {
            gpu.push_back(i);
            draws.push_back([&, i] { methods.ellipsoids[i]->render(scene, view, target.framebuffer(), objects); });
        } else if (methods.marchers[i]) {
            gpu.push_back(i);
            draws.push_back([&, i] { methods.marchers[i]->render(scene, view, target.framebuffer(), objects); });
        }
    }
    gl::setChecks(false);
    const std::vector<double> ms = timeFrames(o.frames, target, methods.opaque, scene, view, draws);
    gl::setChecks(true);
    for (std::size_t k = 0; k < gpu.size(); ++k) {
        methods.opaque.draw(scene, view, target.framebuffer());
        draws[k]();
        record(o, configs[gpu[k]], c, noiseMode, reference, ms[k], target.readColor(), m);
    }
    gl::checkAlways("bench --accuracy");
    for (std::size_t i = 0; i < configs.size(); ++i) {
        if (configs[i].kind != Kind::GardnerExact && configs[i].kind != Kind::PathTrace) continue;
        const auto t0 = Clock::now();
        const Image img = configs[i].kind == Kind::GardnerExact
                              ? renderGardnerExact(scene, view, methods.noise, methods.ns)
                              : renderPathTraced(scene, view, configs[i].pathtrace, &methods.noise);
        record(o, configs[i], c, noiseMode, reference,
               std::chrono::duration<double, std::milli>(Clock::now() - t0).count(), img, m);
    }
}

// One case with one noise mode: its reference, the split by light (noise 0), the sweep.
void measureCase(const AccuracyOptions& o, Methods& methods, const Case& c, const std::string& noiseMode, Measured& m) {
    Scene scene = c.scene;
    if (noiseMode == "0") scene.medium.noise = 0;
    if (noiseMode == "scene" && scene.medium.noise == 0) return;
    const View view = makeView(scene.camera);
    const ReferenceSettings& refSettings = methods.refSettings;
    std::cerr << "bench: accuracy: " << c.name << ", noise " << scene.medium.noise << ": reference (to "
              << fmt("%.0f%%", 100 * refSettings.targetNoise) << " noise, at most " << refSettings.spp
              << " spp, cached)...\n";
    const Reference reference = makeReference(scene, view, methods.noise, refSettings);
    if (noiseMode == "0") m.views.push_back({reference.full, {}, {}});
    m.refInfo.push_back({noiseMode, c.name, reference.noise, reference.seconds, reference.traced, reference.spp,
                         reference.highSpp, reference.highShare, reference.scratchSeconds,
                         reference.highScratchSeconds});
    if (noiseMode == "0")
        for (ComponentRow& row :
             measureComponents(scene, view, reference, methods.noise, methods.ns, methods.opaque, o.block)) {
            row.caseName = c.name;
            row.shares = referenceShares(reference);
            m.components.push_back(std::move(row));
        }
    measureConfigs(o, methods, c, noiseMode, scene, reference, m);
}

// Every case in every noise mode, then the layered sky's convergence. Throws.
Measured measure(const AccuracyOptions& o, const std::vector<Case>& all, const std::vector<Config>& configs,
                 const ReferenceSettings& refSettings) {
    Measured m;
    ContextOptions co;
    co.backend = o.bench.backend;
    auto context = Context::create(co);
    m.renderer = context->description();
    Methods methods(configs, refSettings);
    for (const std::string& noiseMode : o.noiseModes)
        for (const Case& c : all) measureCase(o, methods, c, noiseMode, m);
    m.layered = layeredConvergence(o, methods.opaque);
    return m;
}

// Per method and setting over the cases each noise mode has (a noise-only setting, which lacks
// the noise-0 cases, is left out: like is compared with like), the Pareto front marked, and
// each result marked as its aggregate is. Returns the cases per noise mode.
std::map<std::string, int> aggregate(std::vector<Result>& results, std::vector<Aggregate>& agg) {
    for (const Result& r : results) {
        auto it = std::find_if(agg.begin(), agg.end(), [&](const Aggregate& a) {
            return a.noise == r.noise && a.kind == r.kind && a.setting == r.setting;
        });
        if (it == agg.end()) {
            agg.push_back({r.noise, r.kind, r.setting});
            it = agg.end() - 1;
        }
        it->totalMs += r.ms;
        it->meanRelRmse += r.relRmse;
        it->cases += 1;
    }
    std::map<std::string, int> casesPerNoise;
    for (const Aggregate& a : agg) casesPerNoise[a.noise] = std::max(casesPerNoise[a.noise], a.cases);
    agg.erase(
        std::remove_if(agg.begin(), agg.end(), [&](const Aggregate& a) { return a.cases != casesPerNoise[a.noise]; }),
        agg.end());
    for (Aggregate& a : agg) a.meanRelRmse /= a.cases;
    markPareto(agg);
    for (Result& r : results)
        for (const Aggregate& a : agg)
            if (a.noise == r.noise && a.kind == r.kind && a.setting == r.setting) r.pareto = a.pareto;
    return casesPerNoise;
}

std::string resultsCsv(const Measured& m) {
    auto referenceNoiseOf = [&](const Result& r) {
        for (const ReferenceInfo& i : m.refInfo)
            if (i.noise == r.noise && i.caseName == r.caseName) return i.relNoise;
        return -1.0;
    };
    std::ostringstream csv;
    csv << "noise,case,distance_m,method,setting,ms,rel_rmse,psnr_exposure_fitted,exposure,ssim,alpha_mae,"
           "reference_rel_rmse,pareto\n";
    for (const Result& r : m.results)
        csv << r.noise << ",\"" << r.caseName << "\"," << (r.distance < 0 ? std::string() : fmt("%.0f", r.distance))
            << "," << kindName(r.kind) << ",\"" << r.setting << "\"," << fmt("%.3f", r.ms) << ","
            << fmt("%.5f", r.relRmse) << "," << fmt("%.2f", r.psnrFit) << "," << fmt("%.4f", r.exposure) << ","
            << fmt("%.4f", r.ssim) << "," << fmt("%.4f", r.alphaMae) << "," << fmt("%.5f", referenceNoiseOf(r)) << ","
            << (r.pareto ? 1 : 0) << "\n";
    return csv.str();
}

// The section's first paragraph: how the figures were made, the references' cost and noise.
void writeIntro(std::ostream& md, const AccuracyOptions& o, const Measured& m, const ReferenceSettings& refSettings,
                const std::string& when, const std::vector<Case>& all, int cases) {
    double refNoise[2] = {0, 0}, refWorst[2] = {0, 0}, refSeconds = 0;
    std::pair<double, double> highShareRange{1, 0};
    double scratch = 0, highScratch = 0;
    for (const ReferenceInfo& r : m.refInfo) {
        highShareRange = {std::min(highShareRange.first, r.highShare), std::max(highShareRange.second, r.highShare)};
        scratch += r.scratchSeconds, highScratch += r.highScratchSeconds;
    }
    int refCount[2] = {0, 0}, traced = 0;
    for (const ReferenceInfo& r : m.refInfo) {
        const int k = r.noise == "0" ? 0 : 1;
        refNoise[k] += r.relNoise;
        refWorst[k] = std::max(refWorst[k], r.relNoise);
        refCount[k] += 1;
        refSeconds += r.seconds;
        traced += r.traced;
    }
    md << "Measured by `nephele bench --accuracy` on " << when << ", " << machineLine(m.renderer)
       << ". Every scene rendered at " << o.width << " px wide (the camera inside the cloud at " << o.width / 2
       << "); error = RMSE of linear RGB, "
       << "after averaging " << o.block << "×" << o.block
       << " pixel blocks, over the blocks where either image has "
          "cloud (α > 0.02), relative to the reference's mean radiance there (no exposure fit: a colour calibration "
          "error counts). The reference is `--method pathtrace`, the sun's light and the sky's and the ground's "
          "traced apart and summed (the sky with a quarter of the sun's samples), in pieces of "
       << refSettings.pieceSpp
       << " spp of independent seeds added until the noise of their mean, measured by their "
          "spread, is at most "
       << fmt("%.0f%%", 100 * refSettings.targetNoise) << " or the sun's light has " << refSettings.spp << " spp ("
       << sppRange(m.refInfo) << " spp per case here); the scattering orders past " << kReferenceBounces << " (up to "
       << PathTraceSettings{}.maxBounces << ") traced apart in pieces of their own, "
       << "to a quarter of that noise or a quarter of the samples (" << sppRange(m.refInfo, &ReferenceInfo::highSpp)
       << " spp here; they carry " << fmt("%.1f%%", 100 * highShareRange.first) << "–"
       << fmt("%.1f%%", 100 * highShareRange.second) << " of the light): its own noise is "
       << fmt("%.1f%%", refCount[0] ? 100 * refNoise[0] / refCount[0] : 0) << " on average (at most "
       << fmt("%.1f%%", 100 * refWorst[0]) << ") with noise 0"
       << (refCount[1] ? " and " + fmt("%.1f%%", 100 * refNoise[1] / refCount[1]) + " (at most " +
                             fmt("%.1f%%", 100 * refWorst[1]) + ") with the scenes' noise. "
                       : std::string("; the scenes' noise was not run (--noise-modes 0). "))
       << (traced > 0 ? "Making the references took " + fmt("%.0f", refSeconds / 60) + " min in this run (" +
                            std::to_string(traced) + " path traces; they are cached for later runs). "
                      : std::string("The references came from the cache. "))
       << "Made from scratch on this machine, all " << m.refInfo.size() << " would take about "
       << fmt("%.1f", scratch / 3600) << " h (" << fmt("%.0f", highScratch / 60) << " min of it the orders past "
       << kReferenceBounces << "; estimated per kind of trace by a pilot of 1/64 of its pixels, times its pieces). "
       << "Time = median ms per frame over " << o.frames
       << " frames for the GPU methods (interleaved), one run for the CPU ones; summed over the " << cases
       << " cases (";
    bool first = true;
    for (const Case& c : all) {
        md << (first ? "" : ", ") << c.name;
        first = false;
    }
    md << "). ✓ = on the Pareto front (nothing else is both faster and more accurate).\n\n";
}

// Per noise mode, every method and setting's total time and mean error, fastest first.
void writeAggregates(std::ostream& md, const AccuracyOptions& o, const std::vector<Aggregate>& agg) {
    for (const std::string& noiseMode : o.noiseModes) {
        md << (noiseMode == "0"
                   ? "With `medium.noise: 0` (the exact analytic field):\n\n"
                   : "With the scenes' noise (`medium.noise` 0.3; the path tracer uses the project's "
                     "noise field per ellipsoid, the ray-marcher one noise field over the sum, the compositor "
                     "one sample of that field per chord):\n\n");
        md << "| method | setting | total ms | mean error | Pareto |\n|---|---|---:|---:|:---:|\n";
        std::vector<Aggregate> rows;
        for (const Aggregate& a : agg)
            if (a.noise == noiseMode) rows.push_back(a);
        std::sort(rows.begin(), rows.end(),
                  [](const Aggregate& a, const Aggregate& b) { return a.totalMs < b.totalMs; });
        for (const Aggregate& a : rows)
            md << "| " << kindName(a.kind) << " | " << a.setting << " | " << fmt("%.1f", a.totalMs) << " | "
               << fmt("%.1f%%", 100 * a.meanRelRmse) << " | " << (a.pareto ? "✓" : "") << " |\n";
        md << "\n";
    }
}

// Per case, the defaults of each method (the compositor's default is what --method auto draws).
void writePerCase(std::ostream& md, const AccuracyOptions& o, const Measured& m, const std::vector<Case>& all) {
    for (const std::string& noiseMode : o.noiseModes) {
        md << "Per case, " << (noiseMode == "0" ? "with `medium.noise: 0`" : "with the scenes' noise")
           << " (error / ms per frame; the reference's own noise last):\n\n"
              "| case | ellipsoid (auto) | weighted composite | raymarch | gardner-exact | pathtrace 16 spp | "
              "reference noise |\n"
              "|---|---:|---:|---:|---:|---:|---:|\n";
        for (const Case& c : all) {
            md << "| " << c.name;
            const std::pair<Kind, std::string> columns[] = {{Kind::Ellipsoid, "default"},
                                                            {Kind::Ellipsoid, "weighted composite"},
                                                            {Kind::Raymarch, "default"},
                                                            {Kind::GardnerExact, ""},
                                                            {Kind::PathTrace, ""}};
            for (const auto& column : columns) {
                const auto& [k, setting] = column;
                const auto it =
                    std::find_if(m.results.begin(), m.results.end(), [&, k = k, &setting = setting](const Result& r) {
                        return r.noise == noiseMode && r.caseName == c.name && r.kind == k &&
                               (setting.empty() || r.setting == setting);
                    });
                md << " | "
                   << (it == m.results.end() ? std::string("—")
                                             : fmt("%.1f%%", 100 * it->relRmse) + " / " + fmt("%.1f", it->ms));
            }
            double refNoiseHere = -1;
            for (const ReferenceInfo& i : m.refInfo)
                if (i.noise == noiseMode && i.caseName == c.name) refNoiseHere = i.relNoise;
            md << " | " << (refNoiseHere < 0 ? std::string("—") : fmt("%.1f%%", 100 * refNoiseHere)) << " |\n";
        }
        md << "\n";
    }
}

// Where the error is (noise 0): the reference and each method split by light.
void writeComponents(std::ostream& md, const std::vector<ComponentRow>& components) {
    md << "\nWhere the error is (`medium.noise: 0`): the reference's radiance over the cloud split by light (the "
          "sun's single scattering, its multiple scattering, the sky's and the ground's light including the "
          "background seen through), and each method's error split the same way, each traced or rendered on its "
          "own (errors relative to the reference's mean total radiance; opacity = the background seen through the "
          "method's opacity instead of the reference's):\n\n"
          "| case | reference: single / multiple / sky | method | error | single | multiple | sky | opacity |\n"
          "|---|---|---|---:|---:|---:|---:|---:|\n";
    for (const ComponentRow& r : components) {
        const bool firstOfCase = &r == &components.front() || (&r)[-1].caseName != r.caseName;
        md << "| " << (firstOfCase ? r.caseName : "") << " | "
           << (firstOfCase ? fmt("%.0f%% / ", 100 * r.shares.single) + fmt("%.0f%% / ", 100 * r.shares.multiple) +
                                 fmt("%.0f%%", 100 * r.shares.sky)
                           : std::string())
           << " | " << r.method << " | " << fmt("%.1f%%", 100 * r.errors.total) << " | "
           << fmt("%.1f%%", 100 * r.errors.single) << " | " << fmt("%.1f%%", 100 * r.errors.multiple) << " | "
           << fmt("%.1f%%", 100 * r.errors.sky) << " | " << fmt("%.1f%%", 100 * r.errors.opacity) << " |\n";
    }
}

// The layered sky's N against N = kLayeredReferenceN: a view per row, N per column.
void writeLayered(std::ostream& md, const std::vector<LayeredPoint>& layered) {
    md << "\nThe layered sky's layer count N, measured against its own converged limit, N = " << kLayeredReferenceN
       << ", on the layer of `near_and_far.json` (error as above; ms per frame; its error against the path tracer, "
          "which renders the layer as a volume, is `nephele bench --layer-accuracy`'s, under \"The layered sky\"):\n\n"
          "| view |";
    std::vector<int> layerCounts;
    for (const LayeredPoint& p : layered)
        if (std::find(layerCounts.begin(), layerCounts.end(), p.layers) == layerCounts.end())
            layerCounts.push_back(p.layers);
    for (int n : layerCounts) md << " N = " << n << " |";
    md << "\n|---|";
    for (std::size_t k = 0; k < layerCounts.size(); ++k) md << "---:|";
    md << "\n";
    std::vector<std::string> layerViews;
    for (const LayeredPoint& p : layered)
        if (std::find(layerViews.begin(), layerViews.end(), p.view) == layerViews.end()) layerViews.push_back(p.view);
    for (const std::string& v : layerViews) {
        md << "| " << v;
        for (int n : layerCounts)
            for (const LayeredPoint& p : layered)
                if (p.view == v && p.layers == n)
                    md << " | " << fmt("%.1f%%", 100 * p.relRmse) << " / " << fmt("%.0f", p.ms);
        md << " |\n";
    }
}

std::string layeredCsv(const std::vector<LayeredPoint>& layered) {
    std::ostringstream csv;
    csv << "view,layers,reference_layers,ms,rel_rmse\n";
    for (const LayeredPoint& p : layered)
        csv << "\"" << p.view << "\"," << p.layers << "," << kLayeredReferenceN << "," << fmt("%.3f", p.ms) << ","
            << fmt("%.5f", p.relRmse) << "\n";
    return csv.str();
}

// The CSVs, the section, the views montage and the charts into outDir; the section on stdout.
int writeResults(const AccuracyOptions& o, const Measured& m, const std::string& md, const std::string& when) {
    const fs::path dir(o.bench.outDir);
    const std::string csvPath = (dir / "accuracy.csv").string(), mdPath = (dir / "accuracy.md").string();
    const std::string layeredPath = (dir / "accuracy_layered.csv").string();
    const std::string chartPath = (dir / "accuracy_chart.png").string(),
                      distancePath = (dir / "accuracy_distance.png").string();
    const std::string viewsPath = (dir / "accuracy_views.png").string();
    try {
        writeTextFiles({{csvPath, resultsCsv(m)},
                        {mdPath, generatedSection("accuracy bench", md)},
                        {layeredPath, layeredCsv(m.layered)}});
        writePng(viewsPath, viewsMontage(m.views));
        runPlot("plot_accuracy.py", {csvPath, kChartsFolder, when}, o.bench.outDir,
                {"accuracy_chart.png", "accuracy_distance.png"});
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench --accuracy: " << e.what() << "\n";
        return 1;
    }
    std::cout << md;
    std::cerr << "nephele: bench --accuracy wrote " << csvPath << ", " << mdPath << ", " << chartPath << ", "
              << distancePath << ", " << viewsPath << "\n";
    return 0;
}

}  // namespace

int runAccuracyBench(const AccuracyOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    std::vector<Case> all;
    try {
        all = cases(o);
    } catch (const std::exception& e) {
        return reportError(e, "loading the scenes");
    }
    const std::vector<Config> configs = sweep(o.bench.quick);
    const ReferenceSettings refSettings = referenceSettings(o);
    Measured m;
    try {
        m = measure(o, all, configs, refSettings);
    } catch (const std::exception& e) {
        return reportError(e, "bench --accuracy");
    }
    std::vector<Aggregate> agg;
    std::map<std::string, int> casesPerNoise = aggregate(m.results, agg);

    const std::string when = utcNow();
    std::ostringstream md;
    writeIntro(md, o, m, refSettings, when, all, casesPerNoise["0"]);
    md << "![ms per frame against error, per method and setting](accuracy_chart.png)\n\n";
    writeAggregates(md, o, agg);
    writePerCase(md, o, m, all);
    md << "\n![error and time against distance](accuracy_distance.png)\n";
    writeComponents(md, m.components);
    writeLayered(md, m.layered);
    return writeResults(o, m, md.str(), when);
}

}  // namespace nephele::cli
