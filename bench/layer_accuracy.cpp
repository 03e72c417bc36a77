// The layered sky and auto's hand-off against the path tracer (bench/layer_accuracy.hpp).
#include "layer_accuracy.hpp"

#include "accuracy_reference.hpp"
#include "bench_util.hpp"
#include "render_command.hpp"

#include "hand_off.hpp"  // private to Nephele::layered: the bench measures it (nephele_internal)

#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/layer_volume.hpp"
#include "nephele/png.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

namespace nephele::cli {

namespace {

struct LayerView {
    std::string name;
    Vec3 eye;
    double elevationDeg;   // of the view direction (looking along +y)
    double coverage = -1;  // the layer's, if >= 0
};

// Below the base looking up, grazing just under the base, inside the layer, above looking down;
// and just under a deck (coverage 0.9) looking up, where a near cumulus lit as a cloud alone is
// far brighter than the layer.
std::vector<LayerView> layerViews(const Scene& scene, bool quick) {
    const Layer& l = scene.layers.front();
    const double mid = l.base + 0.5 * l.thickness;
    std::vector<LayerView> v = {
        {"below, looking up 20°", scene.camera.position, 20},
        {"grazing, 100 m under the base", Vec3(0, 0, l.base - 100), 1.1},
        {"inside the layer, level", Vec3(0, 0, mid), 0},
        {"above, looking 10° down", Vec3(0, 0, mid + 2000), -10},
        {"100 m under a deck (coverage 0.9), looking up 20°", Vec3(0, 0, l.base - 100), 20, 0.9}};
    if (quick) v.resize(1);
    return v;
}

Scene viewScene(const Scene& base, const LayerView& v, int width) {
    Scene s = base;
    s.camera.position = v.eye;
    const double e = glm::radians(v.elevationDeg);
    s.camera.direction = Vec3(0, std::cos(e), std::sin(e));
    s.camera.up = Vec3(0, 0, 1);
    s.camera.fovYDeg = 60;
    s.camera.width = width;
    s.camera.height = std::max(1, width * 9 / 16);
    s.path.clear();
    if (v.coverage >= 0) s.layers.front().coverage = v.coverage;
    return s;
}

// The mean radiance of `mine` over the reference's, over the blocks where either has cloud
// (relativeRmse()'s blocks); 1 when there are none.
double meanRatio(const Image& mine, const Image& reference) {
    double sumMine = 0, sumRef = 0;
    for (std::size_t p = 0; p < std::size_t(mine.width) * mine.height; ++p) {
        if (!(mine.pixels[4 * p + 3] > 0.02f || reference.pixels[4 * p + 3] > 0.02f)) continue;
        for (int k = 0; k < 3; ++k) sumMine += mine.pixels[4 * p + k], sumRef += reference.pixels[4 * p + k];
    }
    return sumRef > 0 ? sumMine / sumRef : 1;
}

double meanAlpha(const Image& a) {
    double sum = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) sum += a.at(x, y, 3);
    return sum / (double(a.width) * a.height);
}

struct Renderers {
    LayeredSettings layered;
    std::unique_ptr<LayeredRenderer> sky;     // --method layered
    std::unique_ptr<LayeredRenderer> single;  // --method layered lit by single scattering alone (no photons)
    std::unique_ptr<SkyRenderer> autoSky;     // --method auto
    std::unique_ptr<SkyRenderer> autoAlone;   // --method auto, each near cumulus lit as a cloud alone
    OpaquePass opaque;
};


// The path-traced reference split by light as the accuracy bench's (accuracy_reference.hpp:
// the sun's light and the sky's each in two halves of independent seeds, the sun's single
// scattering), the layer a volume of the renderers' density, at block means.
Reference layerReference(const Scene& scene, const View& view, const LayerAccuracyOptions& o, const LayeredSettings& ls,
                         const NoiseVolume& noise) {
    const auto start = std::chrono::steady_clock::now();
    auto trace = [&](const Scene& sc, int spp, int bounces, unsigned seed) {
        PathTraceSettings ps;
        ps.spp = std::max(1, spp), ps.maxBounces = bounces, ps.seed = seed;
        ps.layers = std::make_shared<LayerVolumes>(sc, ls, 0.0);
        const Image image = o.bench.cacheDir.empty() ? renderPathTraced(sc, view, ps, &noise)
                                                     : renderPathTracedCached(sc, view, ps, &noise, o.bench.cacheDir);
        return blockMean(image, o.block);
    };
    const int spp = o.bench.quick ? 4 : o.referenceSpp, skySpp = std::max(2, spp / 4),
              bounces = PathTraceSettings{}.maxBounces;
    const Scene sun = sunOnly(scene), sky = skyOnly(scene);
    const Image sunA = trace(sun, spp / 2, bounces, 1), sunB = trace(sun, spp / 2, bounces, 2);
    const Image skyA = trace(sky, skySpp / 2, bounces, 1), skyB = trace(sky, skySpp / 2, bounces, 2);
    Reference r;
    r.sun = sunA, r.sky = skyA;
    Image a = sunA, b = sunB;
    for (std::size_t i = 0; i < sunA.pixels.size(); ++i) {
        r.sun.pixels[i] = 0.5f * (sunA.pixels[i] + sunB.pixels[i]);
        r.sky.pixels[i] = 0.5f * (skyA.pixels[i] + skyB.pixels[i]);
        if (i % 4 != 3) a.pixels[i] += skyA.pixels[i], b.pixels[i] += skyB.pixels[i];
    }
    r.total = r.sun;
    for (std::size_t i = 0; i < r.total.pixels.size(); ++i)
        if (i % 4 != 3) r.total.pixels[i] += r.sky.pixels[i];
    r.single = trace(sun, std::max(1, spp / 4), 0, 3);
    r.noise = 0.5 * relativeRmse(a, b);  // the mean of two independent halves: half their difference
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
}

// The near LOD against the layer it stands for within auto's reach (hand_off.hpp).
void measureHandOff(const Scene& scene, const View& view, const Renderers& r, LayerViewAccuracy& out) {
    const HandOff h = nephele::measureHandOff(scene, view, r.layered, kAutoNearRadius, kAutoNearRadius + kAutoBlendBand,
                                              autoEllipsoidSettings());
    out.reachPixels = h.reachPixels, out.bandPixels = h.bandPixels;
    out.nearOpacity = h.nearOpacity, out.layerOpacity = h.layerOpacity, out.volumeOpacity = h.volumeOpacity;
    out.nearRadiance = h.nearRadiance, out.layerRadiance = h.layerRadiance;
}

LayerViewAccuracy measureView(const Scene& scene, const LayerAccuracyOptions& o, Renderers& r, const NoiseVolume& noise,
                              int index) {
    LayerViewAccuracy a;
    const View view = makeView(scene.camera);
    const Reference ref = layerReference(scene, view, o, r.layered, noise);
    a.referenceSeconds = ref.seconds, a.referenceNoise = ref.noise;
    a.referenceOpacity = meanAlpha(ref.total);
    a.shares = referenceShares(ref);
    const auto layered = [&](GLuint fb) { r.sky->render(scene, view, fb, 0); };
    const auto autoDraw = [&](GLuint fb) { r.autoSky->render(scene, view, fb, 0, false); };
    const Image layeredFrame = drawOver(scene, view, r.opaque, layered);
    const Image autoFrame = drawOver(scene, view, r.opaque, autoDraw);
    const Image layeredBlocks = blockMean(layeredFrame, o.block), autoBlocks = blockMean(autoFrame, o.block);
    a.layeredError = relativeRmse(layeredBlocks, ref.total), a.layeredRatio = meanRatio(layeredBlocks, ref.total);
    a.autoError = relativeRmse(autoBlocks, ref.total), a.autoRatio = meanRatio(autoBlocks, ref.total);
    a.layeredOpacity = meanAlpha(layeredBlocks);
    {  // within auto's reach
        const Image aloneBlocks = blockMean(
            drawOver(scene, view, r.opaque, [&](GLuint fb) { r.autoAlone->render(scene, view, fb, 0, false); }),
            o.block);
        const Layer& l = scene.layers.front();
        const double top = l.base + l.thickness, reach = kAutoNearRadius + kAutoBlendBand;
        std::vector<char> inReach(std::size_t(layeredBlocks.width) * layeredBlocks.height), inBand = inReach;
        for (int y = 0; y < layeredBlocks.height; ++y)
            for (int x = 0; x < layeredBlocks.width; ++x) {
                const Vec3 d = view.rayDirection((x + 0.5) * o.block, (y + 0.5) * o.block);
                const std::size_t p = std::size_t(y) * layeredBlocks.width + x;
                inReach[p] = meetsSlab(view.eye, d, l.base, top, 0, reach);
                inBand[p] = meetsSlab(view.eye, d, l.base, top, kAutoNearRadius, reach);
                a.nearBlocks += inReach[p];
            }
        auto masked = [&](const Image& blocks,
                          const std::vector<char>& mask) {  // alpha 0 outside: relativeRmse() and meanRatio() skip it
            Image out = blocks;
            for (std::size_t p = 0; p < mask.size(); ++p)
                if (!mask[p]) out.pixels[4 * p + 3] = 0;
            return out;
        };
        const Image refNear = masked(ref.total, inReach), refBand = masked(ref.total, inBand);
        // Error and mean ratio within the reach, and the mean ratio across the band alone.
        auto measure = [&](const Image& blocks, double& nearError, double& nearRatio, double& bandRatio) {
            const Image near = masked(blocks, inReach);
            nearError = relativeRmse(near, refNear), nearRatio = meanRatio(near, refNear);
            bandRatio = meanRatio(masked(blocks, inBand), refBand);
        };
        measure(layeredBlocks, a.layeredNearError, a.layeredNearRatio, a.layeredBandRatio);
        measure(autoBlocks, a.autoNearError, a.autoNearRatio, a.autoBandRatio);
        measure(aloneBlocks, a.aloneNearError, a.aloneNearRatio, a.aloneBandRatio);
        // The band by light: which light the two disagree in. Auto from a renderer of its own per
        // light: the shared one keeps its tiles across frames, and a light's change renders them
        // again only within its budget.
        for (int light = 0; light < 2; ++light) {
            const Scene lit = light == 0 ? sunOnly(scene) : skyOnly(scene);
            Image part = light == 0 ? ref.sun : ref.sky;  // over the total's cloud blocks in the band
            for (std::size_t p = 0; p < inBand.size(); ++p)
                part.pixels[4 * p + 3] = inBand[p] ? ref.total.pixels[4 * p + 3] : 0;
            const Image l =
                blockMean(drawOver(lit, view, r.opaque, [&](GLuint fb) { r.sky->render(lit, view, fb, 0); }), o.block);
            SkyRenderer fresh(SkySettings{autoLayeredSettings(r.layered), {}, autoEllipsoidSettings()});
            const Image au = blockMean(
                drawOver(lit, view, r.opaque, [&](GLuint fb) { fresh.render(lit, view, fb, 0, false); }), o.block);
            double* ratios = light == 0 ? a.bandSunRatio : a.bandSkyRatio;
            ratios[0] = meanRatio(masked(l, inBand), part), ratios[1] = meanRatio(masked(au, inBand), part);
        }
    }
    a.layeredParts = componentErrors(scene, view, ref, o.block, [&](const Scene& sc, bool single) {
        return drawOver(sc, view, r.opaque, [&](GLuint fb) { (single ? r.single : r.sky)->render(sc, view, fb, 0); });
    });
    if (!o.imageDir.empty()) {  // the block means side by side: reference, layered, auto
        const std::string stem = o.imageDir + "/layer-view" + std::to_string(index);
        writePng(stem + "-reference.png", ref.total);
        writePng(stem + "-layered.png", layeredBlocks);
        writePng(stem + "-auto.png", autoBlocks);
    }
    FrameTarget target(scene.camera.width, scene.camera.height);
    const GLuint fb = target.framebuffer();
    const std::vector<double> ms = timeFrames(o.bench.quick ? 1 : o.frames, target, r.opaque, scene, view,
                                              {[&] { layered(fb); }, [&] { autoDraw(fb); }});
    a.layeredMs = ms[0], a.autoMs = ms[1];
    measureHandOff(scene, view, r, a);
    return a;
}

}  // namespace

std::vector<LayerViewAccuracy> measureLayerAccuracy(const LayerAccuracyOptions& o) {
    if (o.width < 16 || o.width > 4096) throw std::invalid_argument("layer accuracy: width must be 16..4096");
    if (o.referenceSpp < 1 || o.block < 1 || o.frames < 1)
        throw std::invalid_argument("layer accuracy: spp, block and frames must be >= 1");
    if (!o.imageDir.empty()) std::filesystem::create_directories(o.imageDir);
    Scene base = loadScene(o.bench.scenesDir + "/near_and_far.json");
    if (base.layers.empty()) throw UsageError(base.file + ": the layer accuracy needs a scene with layers");
    base.clouds.clear();
    base.layers.resize(1);
    Renderers r;
    r.layered.cacheDir = o.bench.cacheDir;
    r.sky = std::make_unique<LayeredRenderer>(r.layered);
    LayeredSettings single = r.layered;
    single.lighting.photons = 0;  // no diffuse light
    r.single = std::make_unique<LayeredRenderer>(single);
    r.autoSky = std::make_unique<SkyRenderer>(SkySettings{autoLayeredSettings(r.layered), {}, autoEllipsoidSettings()});
    NearLodSettings alone;
    alone.tiledLight = false;
    r.autoAlone =
        std::make_unique<SkyRenderer>(SkySettings{autoLayeredSettings(r.layered), alone, autoEllipsoidSettings()});
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns);
    std::vector<LayerViewAccuracy> out;
    for (const LayerView& v : layerViews(base, o.bench.quick)) {
        const Scene scene = viewScene(base, v, o.bench.quick ? 64 : o.width);
        LayerViewAccuracy a = measureView(scene, o, r, noise, int(out.size()));
        a.view = v.name;
        gl::checkAlways("layer accuracy");
        std::cerr << "bench: layer accuracy, " << v.name << ": layered " << fmt("%.1f%%", 100 * a.layeredError)
                  << ", auto " << fmt("%.1f%%", 100 * a.autoError) << " (reference noise "
                  << fmt("%.1f%%", 100 * a.referenceNoise) << ", " << fmt("%.0f s", a.referenceSeconds) << ")\n";
        out.push_back(a);
    }
    return out;
}

std::string layerAccuracyMarkdown(const std::vector<LayerViewAccuracy>& results, const LayerAccuracyOptions& o) {
    std::ostringstream md;
    md << "The layer of near_and_far.json (its explicit clouds removed) at " << (o.bench.quick ? 64 : o.width)
       << " px wide against `--method pathtrace` at " << (o.bench.quick ? 4 : o.referenceSpp)
       << " spp (the layer as a volume of the layered sky's density); error = RMSE of linear RGB after averaging "
       << o.block << "×" << o.block
       << " pixel blocks, over the blocks where either image has cloud (α > 0.02), relative to the reference's mean "
          "radiance there; mean = the method's mean radiance there over the reference's.\n\n";
    md << "| view | layered error | layered mean | auto error | auto mean | reference noise | opacity (reference / "
          "layered) | layered ms | auto ms |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const LayerViewAccuracy& a : results)
        md << "| " << a.view << " | " << fmt("%.1f%%", 100 * a.layeredError) << " | " << fmt("%.2f", a.layeredRatio)
           << " | " << fmt("%.1f%%", 100 * a.autoError) << " | " << fmt("%.2f", a.autoRatio) << " | "
           << fmt("%.1f%%", 100 * a.referenceNoise) << " | " << fmt("%.3f", a.referenceOpacity) << " / "
           << fmt("%.3f", a.layeredOpacity) << " | " << fmt("%.1f", a.layeredMs) << " | " << fmt("%.1f", a.autoMs)
           << " |\n";
    md << "\nThe layered sky's error split by light (componentErrors(): the sun's single scattering, its multiple "
          "scattering, the sky's and the ground's light, the opacity alone; each relative to the reference's mean "
          "radiance) and the reference's radiance by light:\n\n";
    md << "| view | single | multiple | sky | opacity | reference: single / multiple / sky "
          "|\n|---|---:|---:|---:|---:|---:|\n";
    for (const LayerViewAccuracy& a : results) {
        const ComponentErrors& e = a.layeredParts;
        md << "| " << a.view << " | " << fmt("%.1f%%", 100 * e.single) << " | " << fmt("%.1f%%", 100 * e.multiple)
           << " | " << fmt("%.1f%%", 100 * e.sky) << " | " << fmt("%.1f%%", 100 * e.opacity) << " | "
           << fmt("%.2f", a.shares.single) << " / " << fmt("%.2f", a.shares.multiple) << " / "
           << fmt("%.2f", a.shares.sky) << " |\n";
    }
    md << "\nWithin auto's reach (" << fmt("%.0f", kAutoNearRadius + kAutoBlendBand)
       << " m), where auto draws the near LOD: the blocks whose centre's ray meets the layer there, error / mean "
          "radiance over the reference's, of the layered sky, of auto, and of auto with each near cumulus lit as a "
          "cloud "
          "alone in clear air (`NearLodSettings::tiledLight` off; on, each is lit as one tile of an endless layer of "
          "copies of itself):\n\n";
    md << "| view | blocks | layered | auto | auto, near clouds lit alone | blend band only: mean of layered / auto / "
          "lit "
          "alone | band, the sun's light: layered / auto | band, the sky's: layered / auto "
          "|\n|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const LayerViewAccuracy& a : results)
        md << "| " << a.view << " | " << a.nearBlocks << " | " << fmt("%.1f%%", 100 * a.layeredNearError) << " / "
           << fmt("%.2f", a.layeredNearRatio) << " | " << fmt("%.1f%%", 100 * a.autoNearError) << " / "
           << fmt("%.2f", a.autoNearRatio) << " | " << fmt("%.1f%%", 100 * a.aloneNearError) << " / "
           << fmt("%.2f", a.aloneNearRatio) << " | " << fmt("%.2f", a.layeredBandRatio) << " / "
           << fmt("%.2f", a.autoBandRatio) << " / " << fmt("%.2f", a.aloneBandRatio) << " | "
           << fmt("%.2f", a.bandSunRatio[0]) << " / " << fmt("%.2f", a.bandSunRatio[1]) << " | "
           << fmt("%.2f", a.bandSkyRatio[0]) << " / " << fmt("%.2f", a.bandSkyRatio[1]) << " |\n";
    md << "\nThe near LOD against the layer within auto's reach (" << fmt("%.0f", kAutoNearRadius + kAutoBlendBand)
       << " m): the near cumulus alone (every cell at weight 1) and the layered sky cut at the reach, over the pixels "
          "whose ray meets the layer within the reach (opacity; the volume's is the CPU integral of its density) and "
          "over those meeting it across the blend band (mean luminance of the frame, sky behind):\n\n";
    md << "| view | reach pixels | opacity: near / layered / volume | band pixels | band radiance: near / layered | "
          "near / layered |\n|---|---:|---:|---:|---:|---:|\n";
    for (const LayerViewAccuracy& a : results)
        md << "| " << a.view << " | " << a.reachPixels << " | " << fmt("%.3f", a.nearOpacity) << " / "
           << fmt("%.3f", a.layerOpacity) << " / " << fmt("%.3f", a.volumeOpacity) << " | " << a.bandPixels << " | "
           << fmt("%.3f", a.nearRadiance) << " / " << fmt("%.3f", a.layerRadiance) << " | "
           << (a.layerRadiance > 0 ? fmt("%.3f", a.nearRadiance / a.layerRadiance) : std::string("—")) << " |\n";
    return md.str();
}

int runLayerAccuracyBench(const LayerAccuracyOptions& o) {
    const char* tag = "layer accuracy bench";
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    const std::string mdPath = (std::filesystem::path(o.bench.outDir) / "layer_accuracy.md").string();
    std::vector<LayerViewAccuracy> results;
    std::string renderer;
    try {
        ContextOptions co;
        co.backend = o.bench.backend;
        auto context = Context::create(co);
        renderer = context->description();
        gl::setChecks(true);
        results = measureLayerAccuracy(o);
        const std::string md = layerAccuracyMarkdown(results, o);
        std::cout << md;
        const std::string dated =
            "Measured by `nephele bench --layer-accuracy` on " + utcNow() + ", " + machineLine(renderer) + ". " + md;
        writeTextFiles({{mdPath, generatedSection(tag, dated)}});
    } catch (const std::exception& e) {
        return reportError(e, "bench --layer-accuracy");
    }
    std::cerr << "nephele: bench --layer-accuracy wrote " << mdPath << "\n";
    return 0;
}

}  // namespace nephele::cli
