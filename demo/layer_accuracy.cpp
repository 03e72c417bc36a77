// The layered sky and auto's hand-off against the path tracer (demo/layer_accuracy.hpp).
#include "layer_accuracy.hpp"

#include "bench_util.hpp"
#include "render_command.hpp"

#include "nephele/camera.hpp"
#include "nephele/gl.hpp"
#include "nephele/layer_volume.hpp"
#include "nephele/parallel.hpp"

#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>

namespace nephele::cli {

namespace {

struct LayerView {
    std::string name;
    Vec3 eye;
    double elevationDeg;  // of the view direction (looking along +y)
};

// Below the base looking up, grazing just under the base, inside the layer, above looking down.
std::vector<LayerView> layerViews(const Scene& scene, bool quick) {
    const Layer& l = scene.layers.front();
    const double mid = l.base + 0.5 * l.thickness;
    std::vector<LayerView> v = {{"below, looking up 20°", scene.camera.position, 20},
                                {"grazing, 100 m under the base", Vec3(0, 0, l.base - 100), 1.1},
                                {"inside the layer, level", Vec3(0, 0, mid), 0},
                                {"above, looking 10° down", Vec3(0, 0, mid + 2000), -10}};
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
    return s;
}

// The mean of each block x block square of pixels (RGBA); partial blocks at the edges dropped.
Image blockMeans(const Image& a, int block) {
    Image out(a.width / block, a.height / block, 4);
    for (int y = 0; y < out.height * block; ++y)
        for (int x = 0; x < out.width * block; ++x)
            for (int k = 0; k < 4; ++k) out.at(x / block, y / block, k) += a.at(x, y, k) / float(block * block);
    return out;
}

// The accuracy bench's error (its relativeRmse()'s contract): RMSE of rgb over the pixels where
// either image has alpha > 0.02, over the reference's mean radiance there; and the ratio of the
// means. 0 and 1 when no pixel has cloud.
struct Error {
    double relative = 0, ratio = 1;
};
Error errorAgainst(const Image& mine, const Image& reference) {
    double squares = 0, sumMine = 0, sumRef = 0;
    std::size_t n = 0;
    for (int y = 0; y < mine.height; ++y)
        for (int x = 0; x < mine.width; ++x) {
            if (!(mine.at(x, y, 3) > 0.02f || reference.at(x, y, 3) > 0.02f)) continue;
            for (int k = 0; k < 3; ++k) {
                const double d = double(mine.at(x, y, k)) - reference.at(x, y, k);
                squares += d * d, sumMine += mine.at(x, y, k), sumRef += reference.at(x, y, k);
            }
            n += 3;
        }
    if (n == 0 || sumRef <= 0) return {};
    return {std::sqrt(squares / n) / (sumRef / n), sumMine / sumRef};
}

double meanAlpha(const Image& a) {
    double sum = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) sum += a.at(x, y, 3);
    return sum / (double(a.width) * a.height);
}

// The ray o + s d meets the slab [base, top] at some horizontal distance from o in [from, to].
bool meetsSlab(const Vec3& o, const Vec3& d, double base, double top, double from, double to) {
    double s0 = 0, s1 = 1e300;
    if (std::abs(d.z) > 1e-12) {
        double a = (base - o.z) / d.z, b = (top - o.z) / d.z;
        if (a > b) std::swap(a, b);
        s0 = std::max(s0, a), s1 = b;
    } else if (o.z < base || o.z > top) {
        return false;
    }
    const double h = std::hypot(d.x, d.y);
    if (h < 1e-12) return s1 > s0 && from <= 0;
    return std::min(s1, to / h) > std::max(s0, from / h);
}

struct Renderers {
    LayeredSettings layered;
    std::unique_ptr<LayeredRenderer> sky;  // --method layered
    std::unique_ptr<SkyRenderer> autoSky;  // --method auto
    OpaquePass opaque;
};

Image drawFrame(const Scene& scene, const View& view, const OpaquePass& opaque, const std::function<void(GLuint)>& draw) {
    FrameTarget target(scene.camera.width, scene.camera.height);
    opaque.draw(scene, view, target.framebuffer());
    draw(target.framebuffer());
    return target.readColor();
}

// The path-traced reference at `spp` with `seed`, the layer a volume of the renderers' density.
Image reference(const Scene& scene, const View& view, const LayerAccuracyOptions& o, const LayeredSettings& ls, int spp,
                unsigned seed, const NoiseVolume& noise) {
    PathTraceSettings ps;
    ps.spp = spp, ps.seed = seed;
    ps.layers = std::make_shared<LayerVolumes>(scene, ls, 0.0);
    return o.cacheDir.empty() ? renderPathTraced(scene, view, ps, &noise)
                              : renderPathTracedCached(scene, view, ps, &noise, o.cacheDir);
}

// The near LOD against the layer it stands for within auto's reach: the near cumulus alone with
// every cell at weight 1, the layer alone cut at the reach (extent = reach, no rim fade).
void measureHandOff(const Scene& scene, const View& view, const Renderers& r, LayerViewAccuracy& out) {
    const double reach = kAutoNearRadius + kAutoBlendBand;
    LayeredSettings nearSettings = r.layered;
    nearSettings.nearRadius = reach, nearSettings.blendBand = 0;
    NearLod nearLod(NearLodSettings{}, nearSettings);
    const std::vector<Cloud> cumulus = nearLod.update(scene, view.eye, 0);
    EllipsoidRenderer compositor(autoEllipsoidSettings());
    const Image nearOnly = drawFrame(scene, view, r.opaque, [&](GLuint fb) {
        compositor.render(withNearClouds(scene, cumulus), view, fb, false);
    });
    Scene cut = scene;
    cut.layers.front().extent = reach;
    LayeredSettings cutSettings = r.layered;
    cutSettings.extentFade = 0;
    LayeredRenderer cutSky(cutSettings);
    const Image layerOnly = drawFrame(cut, view, r.opaque, [&](GLuint fb) { cutSky.render(cut, view, fb, 0); });
    const Layer& l = scene.layers.front();
    const double extinction = scene.medium.extinction;
    double sums[5] = {0, 0, 0, 0, 0};  // near alpha, layer alpha, volume alpha; near, layer luminance in the band
    auto luminance = [](const Image& im, int x, int y) {
        return 0.2126 * im.at(x, y, 0) + 0.7152 * im.at(x, y, 1) + 0.0722 * im.at(x, y, 2);
    };
    for (int y = 0; y < nearOnly.height; ++y)
        for (int x = 0; x < nearOnly.width; ++x) {
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            if (!meetsSlab(view.eye, d, l.base, l.base + l.thickness, 0, reach)) continue;
            ++out.reachPixels;
            sums[0] += nearOnly.at(x, y, 3), sums[1] += layerOnly.at(x, y, 3);
            const double tau = extinction * layerDensityIntegral(l, *cutSky.modulation(0), r.layered.modulation,
                                                                 *cutSky.lighting(0), view.eye, d, reach, 0);
            sums[2] += 1 - std::exp(-tau);
            if (!meetsSlab(view.eye, d, l.base, l.base + l.thickness, kAutoNearRadius, reach)) continue;
            ++out.bandPixels;
            sums[3] += luminance(nearOnly, x, y), sums[4] += luminance(layerOnly, x, y);
        }
    const double n = std::max(out.reachPixels, 1), b = std::max(out.bandPixels, 1);
    out.nearOpacity = sums[0] / n, out.layerOpacity = sums[1] / n, out.volumeOpacity = sums[2] / n;
    out.nearRadiance = sums[3] / b, out.layerRadiance = sums[4] / b;
}

LayerViewAccuracy measureView(const Scene& scene, const LayerAccuracyOptions& o, Renderers& r, const NoiseVolume& noise) {
    LayerViewAccuracy a;
    const View view = makeView(scene.camera);
    const int spp = o.quick ? 4 : o.referenceSpp, lowSpp = std::max(1, spp / 4);
    const auto start = std::chrono::steady_clock::now();
    const Image ref = reference(scene, view, o, r.layered, spp, 1, noise);
    const Image low = reference(scene, view, o, r.layered, lowSpp, 2, noise);
    a.referenceSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const Image refBlocks = blockMeans(ref, o.block);
    // RMSE(low, ref)^2 = s^2 (1/n + 1/N) for per-sample noise s: the reference's own share is s^2 / N.
    a.referenceNoise = errorAgainst(blockMeans(low, o.block), refBlocks).relative *
                       std::sqrt((1.0 / spp) / (1.0 / lowSpp + 1.0 / spp));
    a.referenceOpacity = meanAlpha(ref);
    const auto layered = [&](GLuint fb) { r.sky->render(scene, view, fb, 0); };
    const auto autoDraw = [&](GLuint fb) { r.autoSky->render(scene, view, fb, 0, false); };
    const Image layeredFrame = drawFrame(scene, view, r.opaque, layered);
    const Image autoFrame = drawFrame(scene, view, r.opaque, autoDraw);
    const Error le = errorAgainst(blockMeans(layeredFrame, o.block), refBlocks);
    const Error ae = errorAgainst(blockMeans(autoFrame, o.block), refBlocks);
    a.layeredError = le.relative, a.layeredRatio = le.ratio, a.autoError = ae.relative, a.autoRatio = ae.ratio;
    a.layeredOpacity = meanAlpha(layeredFrame);
    FrameTarget target(scene.camera.width, scene.camera.height);
    const GLuint fb = target.framebuffer();
    const std::vector<double> ms = timeFrames(o.quick ? 1 : o.frames, target, r.opaque, scene, view,
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
    Scene base = loadScene(o.scenesDir + "/near_and_far.json");
    if (base.layers.empty()) throw UsageError(base.file + ": the layer accuracy needs a scene with layers");
    base.clouds.clear();
    base.layers.resize(1);
    Renderers r;
    r.layered.cacheDir = o.cacheDir;
    r.sky = std::make_unique<LayeredRenderer>(r.layered);
    r.autoSky = std::make_unique<SkyRenderer>(SkySettings{autoLayeredSettings(r.layered), {}, autoEllipsoidSettings()});
    const NoiseSettings ns;
    const NoiseVolume noise = makeNoiseVolume(ns.size, ns.cells, ns.octaves, ns.seed);
    std::vector<LayerViewAccuracy> out;
    for (const LayerView& v : layerViews(base, o.quick)) {
        const Scene scene = viewScene(base, v, o.quick ? 64 : o.width);
        LayerViewAccuracy a = measureView(scene, o, r, noise);
        a.view = v.name;
        gl::checkAlways("layer accuracy");
        std::cerr << "bench: layer accuracy, " << v.name << ": layered " << fmt("%.1f%%", 100 * a.layeredError) << ", auto "
                  << fmt("%.1f%%", 100 * a.autoError) << " (reference noise " << fmt("%.1f%%", 100 * a.referenceNoise)
                  << ", " << fmt("%.0f s", a.referenceSeconds) << ")\n";
        out.push_back(a);
    }
    return out;
}

std::string layerAccuracyMarkdown(const std::vector<LayerViewAccuracy>& results, const LayerAccuracyOptions& o) {
    std::ostringstream md;
    md << "The layer of near_and_far.json (its explicit clouds removed) at " << (o.quick ? 64 : o.width)
       << " px wide against `--method pathtrace` at " << (o.quick ? 4 : o.referenceSpp)
       << " spp (the layer as a volume of the layered sky's density); error = RMSE of linear RGB after averaging "
       << o.block << "×" << o.block
       << " pixel blocks, over the blocks where either image has cloud (α > 0.02), relative to the reference's mean "
          "radiance there; mean = the method's mean radiance there over the reference's.\n\n";
    md << "| view | layered error | layered mean | auto error | auto mean | reference noise | opacity (reference / "
          "layered) | layered ms | auto ms |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const LayerViewAccuracy& a : results)
        md << "| " << a.view << " | " << fmt("%.1f%%", 100 * a.layeredError) << " | " << fmt("%.2f", a.layeredRatio) << " | "
           << fmt("%.1f%%", 100 * a.autoError) << " | " << fmt("%.2f", a.autoRatio) << " | "
           << fmt("%.1f%%", 100 * a.referenceNoise) << " | " << fmt("%.3f", a.referenceOpacity) << " / "
           << fmt("%.3f", a.layeredOpacity) << " | " << fmt("%.1f", a.layeredMs) << " | " << fmt("%.1f", a.autoMs) << " |\n";
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

int runLayerAccuracyBench(const LayerAccuracyOptions& o, GlBackend backend) {
    std::vector<LayerViewAccuracy> results;
    try {
        ContextOptions co;
        co.backend = backend;
        auto context = Context::create(co);
        gl::setChecks(true);
        results = measureLayerAccuracy(o);
    } catch (const std::exception& e) {
        return reportError(e, "bench --layer-accuracy");
    }
    std::cout << layerAccuracyMarkdown(results, o);
    return 0;
}

}  // namespace nephele::cli
