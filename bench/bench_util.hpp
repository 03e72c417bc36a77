// What the bench commands (`bench`, `bench --accuracy`, `bench --flicker`) share: the
// machine line, medians, interleaved frame timing and the generated sections of docs/benchmarks.md.
#pragma once

#include "nephele/camera.hpp"
#include "nephele/image.hpp"
#include "nephele/layered.hpp"
#include "nephele/opaque.hpp"
#include "nephele/scene.hpp"

#include <chrono>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace nephele::cli {

std::string utcNow();  // "2026-11-22 04:17 UTC"
// "CPU model, N cores; GL renderer" (the renderer string from Context::description()).
std::string machineLine(const std::string& glRenderer);
double median(std::vector<double> v);
// Milliseconds of the steady clock since t0.
inline double msSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
// PSNR of two linear RGB images as 8-bit sRGB (peak 255): what a display shows.
double psnr8(const Image& a, const Image& b);
std::string fmt(const char* printfFormat, double v);
// A --quick run's layer lighting (for tests: every part exercised, the lighting coarse):
// 64 x 64 x 8 texels, 2^11 photons.
void useQuickLighting(LightingSettings& lighting);

// Median wall times (ms) of `frames` frames per method after two warm-up rounds, each
// finished with glFinish, the sky and objects drawn before the clock starts. The methods
// take turns frame by frame, so a busy machine slows them alike and their ratios hold.
std::vector<double> timeFrames(int frames, FrameTarget& target, const OpaquePass& opaque, const Scene& scene,
                               const View& view, const std::vector<std::function<void()>>& methods);

// The page in the docs folder that holds every bench's generated section.
inline constexpr const char* kBenchmarksPage = "benchmarks.md";

// A bench's generated section as its STEM.md in --out-dir holds it: `markdown` between the lines
// "<!-- BEGIN GENERATED: TAG -->" and "<!-- END GENERATED: TAG -->" (image links relative to
// that folder, so that they hold in docs/ too).
std::string generatedSection(const std::string& tag, const std::string& markdown);

// `bench --publish DOCS`: every generated section in `outDir` (each *.md that begins with a
// BEGIN GENERATED line) replaces the text between the same markers in DOCS/benchmarks.md, and
// the CSVs and charts named after its markdown file (STEM*.csv, STEM*.png) are copied into
// DOCS, all or nothing. Checks every marker before writing. Returns the exit code: 0; 2 with a
// message for a missing folder, page, section or marker; 1 when a write failed.
int publishBenchSections(const std::string& outDir, const std::string& docsDir);

// Before a bench runs: creates `outDir`, so that a bad folder fails before the long run.
// Prints what is wrong and returns false.
bool prepareBenchOutputs(const std::string& outDir);

// Writes each (path, text) all or nothing (OutputFiles): on failure none is left. Throws.
void writeTextFiles(const std::vector<std::pair<std::string, std::string>>& pathsAndTexts);

// The end of a bench without charts (`what`, e.g. "bench --scale"): writes `stem`.csv and
// `stem`.md, the generated section `tag` (generatedSection), into outDir (writeTextFiles), then
// prints the markdown and what was written. Returns the exit code: 0, or 1 with a message when
// a write failed.
int publishTextBench(const std::string& what, const std::string& outDir, const std::string& tag,
                     const std::string& stem, const std::string& csv, const std::string& markdown);

// The end of a bench with one chart (`bench`, `bench --layered`): writes STEM.csv and STEM.md,
// the generated section `tag`, into outDir (writeTextFiles), then the chart STEM.png, drawn by
// `script` from the CSV (its arguments: the CSV, the chart, `when`, then `plotArgs`); prints the
// markdown and what was written. Returns the exit code: 0, or 1 with a message when a write or
// the chart failed.
int publishChartBench(const std::string& outDir, const std::string& tag, const std::string& stem,
                      const std::string& csv, const std::string& markdown, const std::string& script,
                      const std::string& when, const std::vector<std::string>& plotArgs = {});

// Runs bench/plot_*.py through Debian's /usr/bin/python3 (python3-matplotlib) with `args`, in
// which a leading kChartsFolder stands for a temporary folder the script draws into; the files
// `charts` it drew there are then written to outDir (output_files.hpp's policy, all or
// nothing). Throws with a message naming the package when the script fails.
inline constexpr const char* kChartsFolder = "{charts}";

// The erosion the benches draw the detail with (the count bench's column, the cruise's detail
// flight): data/scenes/detailed_cumulus.json's, the detail's other settings the format's
// defaults (octaves from 256 m down to 1 m, faded by projected size).
inline constexpr double kBenchDetailErosion = 1.5;
void runPlot(const std::string& scriptName, const std::vector<std::string>& args, const std::string& outDir,
             const std::vector<std::string>& charts);

}  // namespace nephele::cli
