// `nephele bench --flicker`: how much each method's image changes from frame to frame along
// camera paths, against the exact model's change along the same path. Popping (a tile
// jumping to the next power of two, back-to-front order flipping, an LOD switch) is change
// the exact evaluation does not have: it shows up as a positive flicker index and as spikes
// in the per-frame excess.
#include "bench_command.hpp"

#include "bench_util.hpp"
#include "flythrough_command.hpp"
#include "render_command.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

struct Sequence {
    std::string name;  // the scene file
    Scene scene;
    int frames = 0;
    double t0 = 0, fps = 1;
};

struct Run {
    std::string method, setting;
    RenderOptions options;
};

struct Outcome {
    std::string sequence, method, setting;
    int frames = 0;
    double meanChange = 0, referenceMeanChange = 0, flickerIndex = 0;
    double maxExcess = 0;  // max over frame pairs of (change - the reference's change)
    int worstPair = 0;     // the pair (k-1, k) where it happens: k
    double msPerFrame = 0;
    std::vector<double> changes;
};

// The sequence's frame-to-frame changes (frames are not kept: one in memory at a time).
std::vector<double> renderSequence(const Sequence& s, const RenderOptions& o, double& msPerFrame) {
    FrameRenderer renderer(o);
    FrameChanges changes;
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < s.frames; ++k) changes.add(renderer.render(s.scene, s.t0 + k / s.fps).color);
    msPerFrame = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / s.frames;
    return changes.changes();
}

// The paths: flythrough.json's and approach.json's (approach.json alone, at 0.5 fps, quick).
std::vector<Sequence> loadSequences(const FlickerOptions& o) {
    std::vector<Sequence> sequences;
    const std::vector<std::string> names = o.bench.quick ? std::vector<std::string>{"approach.json"}
                                                         : std::vector<std::string>{"flythrough.json", "approach.json"};
    for (const std::string& n : names) {
        Sequence s{n, loadScene(o.bench.scenesDir + "/" + n)};
        if (s.scene.path.size() < 2) throw UsageError(s.scene.file + ": path: the flicker bench needs a camera path");
        const double aspect = double(s.scene.camera.width) / s.scene.camera.height;
        s.scene.camera.width = o.width;
        s.scene.camera.height = std::max(1, int(std::lround(o.width / aspect)));
        s.fps = o.bench.quick ? 0.5 : o.fps;
        s.t0 = s.scene.path.front().t;
        s.frames = frameCount(s.t0, s.scene.path.back().t, s.fps);
        sequences.push_back(std::move(s));
    }
    return sequences;
}

// The methods and settings, the reference first.
std::vector<Run> flickerRuns(const FlickerOptions& o) {
    std::vector<Run> runs;
    auto add = [&](std::string method, std::string setting, Method m, auto change) {
        Run r{std::move(method), std::move(setting), {}};
        r.options.method = m;
        r.options.backend = o.bench.backend;
        change(r.options);
        runs.push_back(std::move(r));
    };
    add("gardner-exact", "reference", Method::GardnerExact,
        [](RenderOptions& r) { r.exactOrder = CompositeOrder::PerPixel; });
    add("ellipsoid", "default", Method::Ellipsoid, [](RenderOptions&) {});
    // The other composite than the default: back to front by centre distance (the paper) or
    // weighted, order-independent (see EllipsoidSettings::order).
    if (EllipsoidSettings().order == CompositeOrder::Weighted)
        add("ellipsoid", "back-to-front composite", Method::Ellipsoid,
            [](RenderOptions& r) { r.ellipsoid.order = CompositeOrder::PerEllipsoid; });
    else
        add("ellipsoid", "weighted composite", Method::Ellipsoid,
            [](RenderOptions& r) { r.ellipsoid.order = CompositeOrder::Weighted; });
    // Tiles that last (EllipsoidSettings::reuse): the default composite, with the cloud LOD too
    // (as auto draws it: far impostors, close tiles at what their image holds), and the weighted one.
    add("ellipsoid", "--reuse on", Method::Ellipsoid, [](RenderOptions& r) { r.ellipsoid.reuse = true; });
    add("ellipsoid", "--reuse on --cloud-lod on (as --method auto)", Method::Ellipsoid, [](RenderOptions& r) {
        r.ellipsoid.reuse = true;
        r.ellipsoid.cloudLod = true;
    });
    if (!o.bench.quick)
        add("ellipsoid", "weighted composite, --reuse on", Method::Ellipsoid, [](RenderOptions& r) {
            r.ellipsoid.order = CompositeOrder::Weighted;
            r.ellipsoid.reuse = true;
        });
    // The model itself, whole ellipsoids sorted by centre distance as the tiles must be: its
    // excess over the per-pixel reference is the popping of order flips alone.
    add("gardner-exact", "per-ellipsoid order", Method::GardnerExact, [](RenderOptions&) {});
    if (!o.bench.quick) {
        add("ellipsoid", "8-bit atlas", Method::Ellipsoid,
            [](RenderOptions& r) { r.ellipsoid.precision = AtlasPrecision::Unorm8; });
        add("ellipsoid", "max tile 32", Method::Ellipsoid, [](RenderOptions& r) { r.ellipsoid.maxTile = 32; });
        add("raymarch", "default", Method::Raymarch, [](RenderOptions&) {});
        add("raymarch", "step 100 m", Method::Raymarch, [](RenderOptions& r) { r.raymarch.step = 100; });
    }
    return runs;
}

// Every run along every sequence, against the sequence's first run (the reference). Throws.
std::vector<Outcome> measureFlicker(const FlickerOptions& o, const std::vector<Sequence>& sequences,
                                    const std::vector<Run>& runs, std::string& renderer) {
    std::vector<Outcome> outcomes;
    {
        ContextOptions co;
        co.backend = o.bench.backend;
        renderer = Context::create(co)->description();
    }
    for (const Sequence& s : sequences) {
        std::vector<double> reference;
        for (const Run& r : runs) {
            std::cerr << "bench: flicker: " << s.name << ", " << r.method << " " << r.setting << " (" << s.frames
                      << " frames at " << s.scene.camera.width << "x" << s.scene.camera.height << ")\n";
            Outcome out{s.name, r.method, r.setting, s.frames};
            out.changes = renderSequence(s, r.options, out.msPerFrame);
            if (reference.empty()) reference = out.changes;  // the first run is the reference
            for (std::size_t k = 0; k < out.changes.size(); ++k) {
                out.meanChange += out.changes[k] / out.changes.size();
                out.referenceMeanChange += reference[k] / reference.size();
                const double excess = out.changes[k] - reference[k];
                if (k == 0 || excess > out.maxExcess) out.maxExcess = excess, out.worstPair = int(k) + 1;
            }
            out.flickerIndex = out.meanChange - out.referenceMeanChange;
            outcomes.push_back(std::move(out));
        }
    }
    return outcomes;
}

// flicker.csv, a row per run and sequence; flicker_series.csv, a row per frame pair.
void writeCsvs(const std::vector<Outcome>& outcomes, const std::vector<Sequence>& sequences, std::ostream& csv,
               std::ostream& series) {
    csv << "sequence,method,setting,frames,fps,mean_change,reference_mean_change,flicker_index,max_excess,worst_frame,"
           "ms_per_frame\n";
    series << "sequence,method,setting,frame,change\n";
    for (const Outcome& r : outcomes) {
        const Sequence& s =
            *std::find_if(sequences.begin(), sequences.end(), [&](const Sequence& q) { return q.name == r.sequence; });
        csv << r.sequence << "," << r.method << ",\"" << r.setting << "\"," << r.frames << "," << fmt("%.3g", s.fps)
            << "," << fmt("%.6f", r.meanChange) << "," << fmt("%.6f", r.referenceMeanChange) << ","
            << fmt("%.6f", r.flickerIndex) << "," << fmt("%.6f", r.maxExcess) << "," << r.worstPair << ","
            << fmt("%.1f", r.msPerFrame) << "\n";
        for (std::size_t k = 0; k < r.changes.size(); ++k)
            series << r.sequence << "," << r.method << ",\"" << r.setting << "\"," << k + 1 << ","
                   << fmt("%.6f", r.changes[k]) << "\n";
    }
}

std::string flickerMarkdown(const FlickerOptions& o, const std::vector<Outcome>& outcomes,
                            const std::vector<Sequence>& sequences, const std::string& when,
                            const std::string& renderer) {
    std::ostringstream md;
    md << "Measured by `nephele bench --flicker` on " << when << ", " << machineLine(renderer)
       << ". Each sequence is the "
       << "scene's camera `path` rendered at " << o.width
       << " px wide; change = mean |difference| of linear RGB (clamped "
          "to [0, 1]) between consecutive frames. The reference is `gardner-exact --exact-order pixel`, the exact "
          "evaluation "
          "of the Gardner model with no tiles, no atlas and each pixel's contributions composited in the depth order "
          "of "
          "their shading points (an order that cannot flip as the eye moves), not the path tracer: at affordable "
          "sample counts the path tracer's Monte Carlo noise changes every frame and would swamp the signal. "
          "`gardner-exact, per-ellipsoid order` is the same model with whole ellipsoids sorted back to front by "
          "centre distance, as the compositor's back-to-front tiles must be: its excess is the popping of order flips "
          "alone; "
          "the compositor's other composite (`--composite`: back-to-front or weighted, order-independent) has a row of "
          "its "
          "own. Flicker index = the method's "
          "mean change − the reference's; max excess = the largest single-frame (change − reference change), where a "
          "pop would show.\n\n"
          "| sequence | method | setting | frames | fps | mean change | flicker index | max excess (frame) |\n"
          "|---|---|---|---:|---:|---:|---:|---:|\n";
    for (const Outcome& r : outcomes) {
        if (r.setting == "reference") {
            md << "| " << r.sequence << " | " << r.method << " | reference | " << r.frames << " | "
               << fmt("%.3g", sequences[0].fps) << " | " << fmt("%.5f", r.meanChange) << " | — | — |\n";
            continue;
        }
        md << "| " << r.sequence << " | " << r.method << " | " << r.setting << " | " << r.frames << " | "
           << fmt("%.3g", sequences[0].fps) << " | " << fmt("%.5f", r.meanChange) << " | "
           << fmt("%+.5f", r.flickerIndex) << " | " << fmt("%+.5f", r.maxExcess) << " (" << r.worstPair << ") |\n";
    }
    md << "\n![per-frame change along each path](flicker.png)\n";
    return md.str();
}

}  // namespace

int runFlickerBench(const FlickerOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    std::vector<Sequence> sequences;
    try {
        sequences = loadSequences(o);
    } catch (const std::exception& e) {
        return reportError(e, "loading the scenes");
    }
    const std::vector<Run> runs = flickerRuns(o);
    std::vector<Outcome> outcomes;
    std::string renderer;
    try {
        outcomes = measureFlicker(o, sequences, runs, renderer);
    } catch (const std::exception& e) {
        return reportError(e, "bench --flicker");
    }

    const std::string when = utcNow();
    std::ostringstream csv, series;
    writeCsvs(outcomes, sequences, csv, series);
    const std::string md = flickerMarkdown(o, outcomes, sequences, when, renderer);
    const std::string csvPath = (fs::path(o.bench.outDir) / "flicker.csv").string();
    const std::string seriesPath = (fs::path(o.bench.outDir) / "flicker_series.csv").string();
    const std::string mdPath = (fs::path(o.bench.outDir) / "flicker.md").string();
    const std::string pngPath = (fs::path(o.bench.outDir) / "flicker.png").string();
    try {
        writeTextFiles(
            {{csvPath, csv.str()}, {seriesPath, series.str()}, {mdPath, generatedSection("flicker bench", md)}});
        runPlot("plot_flicker.py", {seriesPath, std::string(kChartsFolder) + "/flicker.png", when}, o.bench.outDir,
                {"flicker.png"});
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench --flicker: " << e.what() << "\n";
        return 1;
    }
    std::cout << md;
    std::cerr << "nephele: bench --flicker wrote " << csvPath << ", " << seriesPath << ", " << mdPath << ", " << pngPath
              << "\n";
    return 0;
}

}  // namespace nephele::cli
