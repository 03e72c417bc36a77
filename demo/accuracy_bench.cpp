// `nephele bench --accuracy`: every method with a sweep of its settings, timed and compared
// with the path-traced reference on the shared scenes and on a distance series, with the
// exact field (medium.noise 0) and with the scene's noise. CSV, charts, a README section.
#include "bench_command.hpp"

#include "bench_util.hpp"
#include "render_command.hpp"

#include "nephele/ellipsoid.hpp"
#include "nephele/gardner.hpp"
#include "nephele/gl.hpp"
#include "nephele/layered.hpp"
#include "nephele/metrics.hpp"
#include "nephele/pathtrace.hpp"
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
        ell("light volume 8", [](EllipsoidSettings& s) { s.lightVolume = 8; });
        ell("no self-shadowing", [](EllipsoidSettings& s) { s.lightVolume = 0; });
        ell("polygon tiles", [](EllipsoidSettings& s) { s.geometry = TileGeometry::Polygon; });
        ell("weighted composite", [](EllipsoidSettings& s) { s.order = CompositeOrder::Weighted; });
        ray("step 10 m", [](RaymarchSettings& s) { s.step = 10; });
        ray("step 50 m", [](RaymarchSettings& s) { s.step = 50; });
        ray("step 100 m", [](RaymarchSettings& s) { s.step = 100; });
        ray("fixed step", [](RaymarchSettings& s) { s.lodDistance = 0; });
        ray("light grid 8", [](RaymarchSettings& s) { s.lightGrid = 8; });
        ray("light grid 64", [](RaymarchSettings& s) { s.lightGrid = 64; });
        ray("octaves 2", [](RaymarchSettings& s) { s.octaves = 2; }, true);
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

std::vector<Case> cases(const AccuracyOptions& o) {
    std::vector<Case> out;
    const std::vector<std::string> names =
        o.quick ? std::vector<std::string>{"single.json"}
                : std::vector<std::string>{"single.json", "two_clouds.json", "flythrough.json", "field1000.json"};
    for (const std::string& n : names) {
        Case c{n, -1, loadScene(o.scenesDir + "/" + n)};
        scaleTo(c.scene, o.width);
        out.push_back(std::move(c));
    }
    // The distance series: cumulus27 seen along its camera's direction from inside out to 15 km.
    const Scene base = loadScene(o.scenesDir + "/cumulus27.json");
    const Vec3 target = centroid(base.clouds.at(0));
    const Vec3 forward = base.camera.direction;
    const std::vector<double> distances = o.quick ? std::vector<double>{6000}
                                                  : std::vector<double>{0, 600, 2000, 6000, 15000};
    for (double d : distances) {
        Case c{"cumulus27.json at " + (d == 0 ? std::string("0 m (inside)") : fmt("%.0f m", d)), d, base};
        c.scene.camera.position = target - d * forward;
        c.scene.camera.width = base.camera.width;
        c.scene.camera.height = base.camera.height;
        // Inside, every path scatters hundreds of times: the reference costs ~50x a view from
        // outside, so that case is rendered at half the width.
        scaleTo(c.scene, d == 0 ? o.width / 2 : o.width);
        out.push_back(std::move(c));
    }
    return out;
}

struct Result {
    std::string noise;  // "0" or "scene"
    std::string caseName;
    double distance = -1;
    Kind kind;
    std::string setting;
    double ms = 0;
    double relRmse = 0;        // RMSE over cloud pixels / mean reference radiance there
    double psnrFit = 0, exposure = 1, ssim = 0;
    double alphaMae = 0;
    double referenceRelRmse = -1;  // estimate of the reference's own noise (from the 16 spp run)
    bool pareto = false;       // on the Pareto front of the aggregate (set later)
};

// The mean of each block x block square of pixels (RGBA), the last partial ones dropped.
Image blockMean(const Image& a, int block) {
    Image out(a.width / block, a.height / block, 4);
    for (int y = 0; y < out.height; ++y)
        for (int x = 0; x < out.width; ++x)
            for (int k = 0; k < 4; ++k) {
                double sum = 0;
                for (int j = 0; j < block; ++j)
                    for (int i = 0; i < block; ++i) sum += a.at(x * block + i, y * block + j, k);
                out.at(x, y, k) = float(sum / (block * block));
            }
    return out;
}

// Relative RMSE of `a` against reference `b` over the pixels where either has cloud
// (alpha > 0.02), normalised by the reference's mean radiance there. 0 when no pixel has cloud.
double relativeRmse(const Image& a, const Image& b) {
    double se = 0, sum = 0;
    std::size_t n = 0;
    for (std::size_t p = 0; p < std::size_t(a.width) * a.height; ++p) {
        if (!(a.pixels[4 * p + 3] > 0.02f || b.pixels[4 * p + 3] > 0.02f)) continue;
        for (int k = 0; k < 3; ++k) {
            const double d = double(a.pixels[4 * p + k]) - b.pixels[4 * p + k];
            se += d * d;
            sum += b.pixels[4 * p + k];
        }
        n += 3;
    }
    return n == 0 || sum <= 0 ? 0 : std::sqrt(se / n) / (sum / n);
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

// The layered sky has no path-traced reference: the format's density field (what the path
// tracer renders) has no layers. Its layer count N is charted against its own converged
// limit instead: the same frame with kLayeredReferenceN layers, on the layer of
// near_and_far.json seen from below (the scene's camera), grazing (just under the base,
// looking at the horizon) and from above.
constexpr int kLayeredReferenceN = 128;

struct LayeredPoint {
    std::string view;
    int layers = 0;
    double ms = 0, relRmse = 0;
};

std::vector<LayeredPoint> layeredConvergence(const AccuracyOptions& o, const OpaquePass& opaque) {
    Scene base = loadScene(o.scenesDir + "/near_and_far.json");
    base.clouds.clear();
    if (base.layers.empty()) throw UsageError(base.file + ": the layered convergence needs a scene with layers");
    scaleTo(base, o.width);
    const Layer& layer = base.layers.front();
    struct ViewCase { std::string name; Vec3 eye, lookAt; };
    const double mid = layer.base + 0.5 * layer.thickness;
    const std::vector<ViewCase> views = {
        {"below (the scene's camera)", base.camera.position, base.camera.position + base.camera.direction},
        {"grazing, 100 m under the base", Vec3(0, 0, layer.base - 100), Vec3(0, 10000, layer.base - 100 + 200)},
        {"above, looking 10° down", Vec3(0, 0, mid + 2000), Vec3(0, 10000, mid + 2000 - 1763)}};
    const std::vector<int> counts = o.quick ? std::vector<int>{2, 8} : std::vector<int>{2, 4, 8, 16, 32};
    std::vector<LayeredPoint> out;
    // The lighting volume depends on the layer, not on N: computed once and shared through a
    // cache folder (a temporary one, removed at the end, under --no-cache).
    std::string cacheDir = o.cacheDir;
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
        for (auto& r : renderers) draws.push_back([&, rp = r.get()] { rp->render(scene, view, target.framebuffer(), 0); });
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

}  // namespace

int runAccuracyBench(const AccuracyOptions& o) {
    if (!prepareBenchOutputs(o.outDir, o.readme)) return 2;
    std::vector<Case> all;
    try {
        all = cases(o);
    } catch (const std::exception& e) {
        return reportError(e, "loading the scenes");
    }
    const std::vector<Config> configs = sweep(o.quick);
    std::vector<Result> results;
    std::vector<LayeredPoint> layered;
    std::string renderer;
    using Clock = std::chrono::steady_clock;
    try {
        ContextOptions co;
        co.backend = o.backend;
        auto context = Context::create(co);
        renderer = context->description();
        const NoiseSettings ns;
        const NoiseVolume noise = makeNoiseVolume(ns.size, ns.cells, ns.octaves, ns.seed);
        std::vector<std::unique_ptr<EllipsoidRenderer>> ellipsoids(configs.size());
        std::vector<std::unique_ptr<RaymarchRenderer>> marchers(configs.size());
        for (std::size_t i = 0; i < configs.size(); ++i) {
            if (configs[i].kind == Kind::Ellipsoid) ellipsoids[i] = std::make_unique<EllipsoidRenderer>(configs[i].ellipsoid);
            if (configs[i].kind == Kind::Raymarch) marchers[i] = std::make_unique<RaymarchRenderer>(configs[i].raymarch);
        }
        OpaquePass opaque;
        for (const std::string noiseMode : {"0", "scene"}) {
            for (const Case& c0 : all) {
                Scene scene = c0.scene;
                if (noiseMode == "0") scene.medium.noise = 0;
                if (noiseMode == "scene" && scene.medium.noise == 0) continue;
                const View view = makeView(scene.camera);
                const bool objects = !scene.objects.empty();
                std::cerr << "bench: accuracy: " << c0.name << ", noise " << scene.medium.noise << ": reference ("
                          << o.referenceSpp << " spp, cached)...\n";
                PathTraceSettings ref;
                ref.spp = o.referenceSpp;
                ref.progress = false;
                const Image reference = o.cacheDir.empty() ? renderPathTraced(scene, view, ref, &noise)
                                                           : renderPathTracedCached(scene, view, ref, &noise, o.cacheDir);
                const Image referenceBlocks = blockMean(reference, o.block);
                FrameTarget target(scene.camera.width, scene.camera.height);
                // GPU configs: timed together, frame by frame in turn.
                std::vector<std::size_t> gpu;
                std::vector<std::function<void()>> draws;
                for (std::size_t i = 0; i < configs.size(); ++i) {
                    if (configs[i].noiseOnly && scene.medium.noise == 0) continue;
                    if (ellipsoids[i]) {
                        gpu.push_back(i);
                        draws.push_back([&, i] { ellipsoids[i]->render(scene, view, target.framebuffer(), objects); });
                    } else if (marchers[i]) {
                        gpu.push_back(i);
                        draws.push_back([&, i] { marchers[i]->render(scene, view, target.framebuffer(), objects); });
                    }
                }
                gl::setChecks(false);
                const std::vector<double> ms = timeFrames(o.frames, target, opaque, scene, view, draws);
                gl::setChecks(true);
                auto record = [&](std::size_t i, double t, const Image& img) {
                    Result r;
                    r.noise = noiseMode;
                    r.caseName = c0.name;
                    r.distance = c0.distance;
                    r.kind = configs[i].kind;
                    r.setting = configs[i].setting;
                    r.ms = t;
                    // Both at the block grid: the reference's Monte Carlo noise averages down
                    // (block^2 pixels a block), the methods' structure stays.
                    const Image mine = blockMean(img, o.block);
                    r.relRmse = relativeRmse(mine, referenceBlocks);
                    const Image a = channels(mine, 3, 1), b = channels(referenceBlocks, 3, 1);
                    const RenderComparison cmp =
                        compareRenders(channels(mine, 0, 3), channels(referenceBlocks, 0, 3), &a, &b);
                    r.psnrFit = cmp.psnr, r.exposure = cmp.exposure, r.ssim = cmp.ssim, r.alphaMae = cmp.alphaMae;
                    results.push_back(r);
                };
                for (std::size_t k = 0; k < gpu.size(); ++k) {  // one more frame each, for the image
                    opaque.draw(scene, view, target.framebuffer());
                    draws[k]();
                    record(gpu[k], ms[k], target.readColor());
                }
                gl::checkAlways("bench --accuracy");
                for (std::size_t i = 0; i < configs.size(); ++i) {  // CPU configs: one timed run each
                    if (configs[i].kind != Kind::GardnerExact && configs[i].kind != Kind::PathTrace) continue;
                    const auto t0 = Clock::now();
                    const Image img = configs[i].kind == Kind::GardnerExact
                                          ? renderGardnerExact(scene, view, noise, ns)
                                          : renderPathTraced(scene, view, configs[i].pathtrace, &noise);
                    record(i, std::chrono::duration<double, std::milli>(Clock::now() - t0).count(), img);
                    if (configs[i].kind == Kind::PathTrace) {
                        // RMSE(low, ref)^2 = s^2 (1/n + 1/N): the reference's own share is s^2 / N.
                        const double n = configs[i].pathtrace.spp, N = o.referenceSpp;
                        const double refNoise = results.back().relRmse * std::sqrt((1 / N) / (1 / n + 1 / N));
                        for (Result& r : results)
                            if (r.noise == noiseMode && r.caseName == c0.name) r.referenceRelRmse = refNoise;
                    }
                }
            }
        }
        layered = layeredConvergence(o, opaque);
    } catch (const std::exception& e) {
        return reportError(e, "bench --accuracy");
    }

    // Aggregate per method and setting over the cases each noise mode has.
    std::vector<Aggregate> agg;
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
    // A noise-only setting lacks the noise-0 cases: compare like with like.
    std::map<std::string, int> casesPerNoise;
    for (const Aggregate& a : agg) casesPerNoise[a.noise] = std::max(casesPerNoise[a.noise], a.cases);
    agg.erase(std::remove_if(agg.begin(), agg.end(), [&](const Aggregate& a) { return a.cases != casesPerNoise[a.noise]; }),
              agg.end());
    for (Aggregate& a : agg) a.meanRelRmse /= a.cases;
    markPareto(agg);
    for (Result& r : results)
        for (const Aggregate& a : agg)
            if (a.noise == r.noise && a.kind == r.kind && a.setting == r.setting) r.pareto = a.pareto;

    const std::string when = utcNow();
    const std::string machine = machineLine(renderer);
    std::ostringstream csv;
    csv << "noise,case,distance_m,method,setting,ms,rel_rmse,psnr_exposure_fitted,exposure,ssim,alpha_mae,"
           "reference_rel_rmse,pareto\n";
    for (const Result& r : results)
        csv << r.noise << ",\"" << r.caseName << "\"," << (r.distance < 0 ? std::string() : fmt("%.0f", r.distance)) << ","
            << kindName(r.kind) << ",\"" << r.setting << "\"," << fmt("%.3f", r.ms) << "," << fmt("%.5f", r.relRmse) << ","
            << fmt("%.2f", r.psnrFit) << "," << fmt("%.4f", r.exposure) << "," << fmt("%.4f", r.ssim) << ","
            << fmt("%.4f", r.alphaMae) << "," << fmt("%.5f", r.referenceRelRmse) << "," << (r.pareto ? 1 : 0) << "\n";

    std::set<std::string> caseNames;
    double refNoise[2] = {0, 0};
    int refCount[2] = {0, 0};
    for (const Result& r : results)
        if (r.kind == Kind::PathTrace) {
            const int k = r.noise == "0" ? 0 : 1;
            refNoise[k] += r.referenceRelRmse;
            refCount[k] += 1;
        }
    std::ostringstream md;
    md << "Measured by `nephele bench --accuracy` on " << when << ", " << machine << ". Every scene rendered at "
       << o.width << " px wide (the camera inside the cloud at " << o.width / 2 << "); error = RMSE of linear RGB, "
       << "after averaging " << o.block << "×" << o.block << " pixel blocks, over the blocks where either image has "
          "cloud (α > 0.02), relative to the reference's mean radiance there, against `--method pathtrace` at "
       << o.referenceSpp << " spp (no exposure fit: a colour calibration error counts). The reference's own noise, "
          "estimated from the 16 spp run, is "
       << fmt("%.1f%%", refCount[0] ? 100 * refNoise[0] / refCount[0] : 0) << " with noise 0 and "
       << fmt("%.1f%%", refCount[1] ? 100 * refNoise[1] / refCount[1] : 0)
       << " with the scenes' noise: errors below that are not resolved. Time = median ms per frame over "
       << o.frames << " frames for the GPU methods (interleaved), one run for the CPU ones; summed over the "
       << casesPerNoise["0"] << " cases (" ;
    bool first = true;
    for (const Case& c : all) {
        md << (first ? "" : ", ") << c.name;
        first = false;
    }
    md << "). ✓ = on the Pareto front (nothing else is both faster and more accurate).\n\n";
    md << "![ms per frame against error, per method and setting](docs/accuracy_chart.png)\n\n";
    for (const std::string noiseMode : {"0", "scene"}) {
        md << (noiseMode == "0" ? "With `medium.noise: 0` (the exact analytic field):\n\n"
                                : "With the scenes' noise (`medium.noise` 0.3; the path tracer uses the project's "
                                  "noise field, the ray-marcher the paper's pseudo-spheroids):\n\n");
        md << "| method | setting | total ms | mean error | Pareto |\n|---|---|---:|---:|:---:|\n";
        std::vector<Aggregate> rows;
        for (const Aggregate& a : agg)
            if (a.noise == noiseMode) rows.push_back(a);
        std::sort(rows.begin(), rows.end(), [](const Aggregate& a, const Aggregate& b) { return a.totalMs < b.totalMs; });
        for (const Aggregate& a : rows)
            md << "| " << kindName(a.kind) << " | " << a.setting << " | " << fmt("%.1f", a.totalMs) << " | "
               << fmt("%.1f%%", 100 * a.meanRelRmse) << " | " << (a.pareto ? "✓" : "") << " |\n";
        md << "\n";
    }
    md << "By distance (cumulus27 seen along its camera's axis; defaults; error / ms per frame), with the scenes' noise:\n\n"
          "| distance | ellipsoid | raymarch | gardner-exact | pathtrace 16 spp |\n|---|---:|---:|---:|---:|\n";
    for (const Case& c : all) {
        if (c.distance < 0) continue;
        md << "| " << (c.distance == 0 ? std::string("inside") : fmt("%.0f m", c.distance));
        for (Kind k : {Kind::Ellipsoid, Kind::Raymarch, Kind::GardnerExact, Kind::PathTrace}) {
            const auto it = std::find_if(results.begin(), results.end(), [&](const Result& r) {
                return r.noise == "scene" && r.caseName == c.name && r.kind == k &&
                       (r.setting == "default" || k == Kind::GardnerExact || k == Kind::PathTrace);
            });
            md << " | " << (it == results.end() ? std::string("—") : fmt("%.1f%%", 100 * it->relRmse) + " / " + fmt("%.1f", it->ms));
        }
        md << " |\n";
    }
    md << "\n![error and time against distance](docs/accuracy_distance.png)\n";
    md << "\nThe layered sky has no path-traced reference (the format's density field, which the path tracer "
          "renders, has no layers), so its layer count N is measured against its own converged limit, N = "
       << kLayeredReferenceN << ", on the layer of `near_and_far.json` (error as above; ms per frame):\n\n"
          "| view |";
    std::vector<int> layerCounts;
    for (const LayeredPoint& p : layered)
        if (std::find(layerCounts.begin(), layerCounts.end(), p.layers) == layerCounts.end()) layerCounts.push_back(p.layers);
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
                if (p.view == v && p.layers == n) md << " | " << fmt("%.1f%%", 100 * p.relRmse) << " / " << fmt("%.0f", p.ms);
        md << " |\n";
    }
    std::ostringstream layeredCsv;
    layeredCsv << "view,layers,reference_layers,ms,rel_rmse\n";
    for (const LayeredPoint& p : layered)
        layeredCsv << "\"" << p.view << "\"," << p.layers << "," << kLayeredReferenceN << "," << fmt("%.3f", p.ms) << ","
                   << fmt("%.5f", p.relRmse) << "\n";

    const std::string csvPath = (fs::path(o.outDir) / "accuracy.csv").string();
    const std::string mdPath = (fs::path(o.outDir) / "accuracy.md").string();
    const std::string layeredPath = (fs::path(o.outDir) / "accuracy_layered.csv").string();
    try {
        writeTextFiles({{csvPath, csv.str()}, {mdPath, md.str()}, {layeredPath, layeredCsv.str()}});
        runPlot("plot_accuracy.py", {csvPath, kChartsFolder, when}, o.outDir, {"accuracy_chart.png", "accuracy_distance.png"});
        if (!o.readme.empty()) replaceGeneratedSection(o.readme, "accuracy bench", md.str());
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench --accuracy: " << e.what() << "\n";
        return 1;
    }
    std::cout << md.str();
    std::cerr << "nephele: bench --accuracy wrote " << csvPath << ", " << mdPath << ", "
              << (fs::path(o.outDir) / "accuracy_chart.png").string() << ", "
              << (fs::path(o.outDir) / "accuracy_distance.png").string() << (o.readme.empty() ? "" : ", " + o.readme)
              << "\n";
    return 0;
}

}  // namespace nephele::cli
