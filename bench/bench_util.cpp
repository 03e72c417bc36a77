#include "bench_util.hpp"

#include "output_files.hpp"

#include "nephele/gl.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {
std::string firstLineOf(const std::string& file, const std::string& key) {
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);)
        if (line.rfind(key, 0) == 0) {
            const auto colon = line.find(':');
            return colon == std::string::npos ? line : line.substr(colon + 2);
        }
    return "unknown";
}

std::string shellQuote(const std::string& s) {
    std::string out = "'";
    for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}
}  // namespace

std::string utcNow() {
    const std::time_t t = std::time(nullptr);
    char buf[64];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
    return buf;
}

std::string machineLine(const std::string& glRenderer) {
    return firstLineOf("/proc/cpuinfo", "model name") + ", " + std::to_string(std::thread::hardware_concurrency()) +
           " cores; " + glRenderer;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

void useQuickLighting(LightingSettings& lighting) {
    lighting.width = lighting.height = 64, lighting.depth = 8, lighting.photons = 1 << 11;
}

double psnr8(const Image& a, const Image& b) {
    double se = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
        const double d = std::round(255 * linearToSrgb(a.pixels[i])) - std::round(255 * linearToSrgb(b.pixels[i]));
        se += d * d;
    }
    const double mse = se / double(a.pixels.size());
    return mse <= 0 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse);
}

std::vector<double> timeFrames(int frames, FrameTarget& target, const OpaquePass& opaque, const Scene& scene,
                               const View& view, const std::vector<std::function<void()>>& methods) {
    using Clock = std::chrono::steady_clock;
    std::vector<std::vector<double>> ms(methods.size());
    for (int i = 0; i < frames + 2; ++i)
        for (std::size_t m = 0; m < methods.size(); ++m) {
            opaque.draw(scene, view, target.framebuffer());
            gl::glFinish();
            const auto t0 = Clock::now();
            methods[m]();
            gl::glFinish();
            const double elapsed = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
            if (i >= 2) ms[m].push_back(elapsed);
        }
    std::vector<double> out;
    for (auto& v : ms) out.push_back(median(v));
    return out;
}

namespace {

std::string beginMarker(const std::string& tag) { return "<!-- BEGIN GENERATED: " + tag + " -->"; }
std::string endMarker(const std::string& tag) { return "<!-- END GENERATED: " + tag + " -->"; }

// Writes `text` to the path it is given; throws if the stream fails (a full disk).
OutputFiles::Writer textWriter(const std::string& text) {
    return [&text](const std::string& p) {
        std::ofstream out(p, std::ios::binary | std::ios::trunc);
        out << text;
        out.close();
        if (!out) throw std::runtime_error(p + ": write failed");
    };
}

std::string readText(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot read '" + path + "'");
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

}  // namespace

bool prepareBenchOutputs(const std::string& outDir) {
    std::error_code ec;
    fs::create_directories(outDir, ec);
    if (!fs::is_directory(outDir)) {
        std::cerr << "nephele: bench: --out-dir: cannot create the output folder '" << outDir << "'"
                  << (ec ? ": " + ec.message() : "") << "\n";
        return false;
    }
    return true;
}

std::string generatedSection(const std::string& tag, const std::string& markdown) {
    return beginMarker(tag) + "\n" + markdown + endMarker(tag) + "\n";
}

namespace {

const std::string kPublish = "nephele: bench --publish: ";

// A bench's generated section in --out-dir: its tag, its text between the markers, its file.
struct Section {
    std::string tag, body;
    fs::path md;
};

// The sections in outDir: each *.md whose first line is a BEGIN marker and that holds its END
// marker. Returns 0, or the exit code with a message (2: a section without its END marker).
// Throws when a file cannot be read.
int readSections(const std::string& outDir, std::vector<Section>& sections) {
    std::vector<fs::path> mds;
    for (const auto& entry : fs::directory_iterator(outDir))
        if (entry.is_regular_file() && entry.path().extension() == ".md" &&
            entry.path().filename().string().find(".partial-") == std::string::npos)
            mds.push_back(entry.path());
    std::sort(mds.begin(), mds.end());
    const std::string beginPrefix = "<!-- BEGIN GENERATED: ", suffix = " -->";
    for (const fs::path& md : mds) {
        const std::string text = readText(md.string());
        if (text.rfind(beginPrefix, 0) != 0) continue;
        const auto eol = text.find('\n');
        const std::string first = text.substr(0, eol);
        if (eol == std::string::npos || first.size() < beginPrefix.size() + suffix.size() ||
            first.compare(first.size() - suffix.size(), suffix.size(), suffix) != 0)
            continue;
        const std::string tag = first.substr(beginPrefix.size(), first.size() - beginPrefix.size() - suffix.size());
        const auto end = text.rfind(endMarker(tag));
        if (end == std::string::npos || end < eol) {
            std::cerr << kPublish << md.string() << ": no '" << endMarker(tag) << "' line: not a whole section\n";
            return 2;
        }
        sections.push_back({tag, text.substr(eol + 1, end - eol - 1), md});
    }
    return 0;
}

// Writes the page and copies each section's CSVs and charts (the files named after its
// markdown file: STEM.csv, STEM_series.csv, STEM_chart.png, ...) into docsDir, all or nothing.
// Throws.
void writePublished(const std::string& page, const fs::path& pagePath, const std::vector<Section>& sections,
                    const std::string& outDir, const std::string& docsDir) {
    OutputFiles out;
    out.add(pagePath.string(), textWriter(page), "--publish");
    for (const Section& s : sections) {
        const std::string stem = s.md.stem().string();
        for (const auto& entry : fs::directory_iterator(outDir)) {
            const std::string name = entry.path().filename().string(), ext = entry.path().extension().string();
            if (!entry.is_regular_file() || name.rfind(stem, 0) != 0 || (ext != ".csv" && ext != ".png") ||
                name.find(".partial-") != std::string::npos)
                continue;
            const auto copy = [from = entry.path()](const std::string& p) {
                fs::copy_file(from, p, fs::copy_options::overwrite_existing);
            };
            out.add((fs::path(docsDir) / name).string(), copy, "--publish");
        }
    }
    out.commit();
}

}  // namespace

int publishBenchSections(const std::string& outDir, const std::string& docsDir) {
    const fs::path pagePath = fs::path(docsDir) / kBenchmarksPage;
    std::vector<Section> sections;
    std::error_code ec;
    if (!fs::is_directory(outDir, ec)) {
        std::cerr << kPublish << "--out-dir '" << outDir << "' is not a folder (run a bench with --out-dir first)\n";
        return 2;
    }
    if (!fs::is_regular_file(pagePath, ec)) {
        std::cerr << kPublish << "'" << pagePath.string()
                  << "' is not a file: --publish names the docs folder that holds " << kBenchmarksPage << "\n";
        return 2;
    }
    std::string page;
    try {
        page = readText(pagePath.string());
        if (const int code = readSections(outDir, sections)) return code;
    } catch (const std::exception& e) {
        std::cerr << kPublish << e.what() << "\n";
        return 1;
    }
    if (sections.empty()) {
        std::cerr << kPublish << "'" << outDir << "' holds no generated section (a bench's *.md beginning with '"
                  << beginMarker("TAG") << "'): run a bench with --out-dir " << outDir << " first\n";
        return 2;
    }
    // Every section's markers must be in the page before anything is written.
    for (const Section& s : sections) {
        const std::string begin = beginMarker(s.tag), end = endMarker(s.tag);
        const auto b = page.find(begin), e = page.find(end);
        if (b == std::string::npos || e == std::string::npos || e < b) {
            std::cerr << kPublish << pagePath.string() << " has no '" << begin << "' ... '" << end
                      << "' lines to replace; add them where the section should go\n";
            return 2;
        }
        page = page.substr(0, b + begin.size()) + "\n" + s.body + page.substr(e);
    }
    try {
        writePublished(page, pagePath, sections, outDir, docsDir);
    } catch (const std::exception& e) {
        std::cerr << kPublish << e.what() << "\n";
        return 1;
    }
    std::cerr << kPublish << "replaced " << sections.size() << " section" << (sections.size() == 1 ? "" : "s") << " of "
              << pagePath.string() << ":";
    for (const Section& s : sections) std::cerr << " " << s.tag << ";";
    std::cerr << " and copied their CSVs and charts into " << docsDir << "\n";
    return 0;
}

void writeTextFiles(const std::vector<std::pair<std::string, std::string>>& pathsAndTexts) {
    OutputFiles files;
    for (const auto& [path, text] : pathsAndTexts) files.add(path, textWriter(text), "--out-dir");
    files.commit();
}

int publishTextBench(const std::string& what, const std::string& outDir, const std::string& tag,
                     const std::string& stem, const std::string& csv, const std::string& markdown) {
    const std::string csvPath = (fs::path(outDir) / (stem + ".csv")).string();
    const std::string mdPath = (fs::path(outDir) / (stem + ".md")).string();
    try {
        writeTextFiles({{csvPath, csv}, {mdPath, generatedSection(tag, markdown)}});
    } catch (const std::exception& e) {
        std::cerr << "nephele: " << what << ": " << e.what() << "\n";
        return 1;
    }
    std::cout << markdown;
    std::cerr << "nephele: " << what << " wrote " << csvPath << ", " << mdPath << "\n";
    return 0;
}

int publishChartBench(const std::string& outDir, const std::string& tag, const std::string& stem,
                      const std::string& csv, const std::string& markdown, const std::string& script,
                      const std::string& when, const std::vector<std::string>& plotArgs) {
    const std::string csvPath = (fs::path(outDir) / (stem + ".csv")).string();
    const std::string mdPath = (fs::path(outDir) / (stem + ".md")).string();
    const std::string pngPath = (fs::path(outDir) / (stem + ".png")).string();
    try {
        writeTextFiles({{csvPath, csv}, {mdPath, generatedSection(tag, markdown)}});
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench: writing the results failed: " << e.what() << "\n";
        return 1;
    }
    try {
        std::vector<std::string> args{csvPath, std::string(kChartsFolder) + "/" + stem + ".png", when};
        args.insert(args.end(), plotArgs.begin(), plotArgs.end());
        runPlot(script, args, outDir, {stem + ".png"});
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench: " << e.what() << "\n";
        return 1;
    }
    std::cout << markdown;
    std::cerr << "nephele: bench wrote " << csvPath << ", " << mdPath << ", " << pngPath << "\n";
    return 0;
}

void runPlot(const std::string& scriptName, const std::vector<std::string>& args, const std::string& outDir,
             const std::vector<std::string>& charts) {
    // The script draws into a temporary folder of its own; the charts then go into place
    // under the output policy (output_files.hpp), all or nothing.
    const std::string temp = makePartial((fs::path(outDir) / "charts").string(), true);
    struct Remove {
        std::string dir;
        ~Remove() {
            std::error_code ec;
            fs::remove_all(dir, ec);
        }
    } removeTemp{temp};
    // Appended piece by piece: "literal " + string trips a GCC 12 -Wrestrict false positive.
    std::string cmd = "/usr/bin/python3 ";
    cmd += shellQuote(std::string(NEPHELE_SOURCE_DIR) + "/bench/" + scriptName);
    for (std::string a : args) {
        if (a.rfind(kChartsFolder, 0) == 0) a = temp + a.substr(std::string(kChartsFolder).size());
        cmd += ' ', cmd += shellQuote(a);
    }
    if (std::system(cmd.c_str()) != 0)
        throw std::runtime_error(
            "the chart (" + scriptName +
            ") failed: it needs /usr/bin/python3 with python3-matplotlib (./setup.sh installs it)");
    OutputFiles files;
    for (const std::string& name : charts)
        files.add((fs::path(outDir) / name).string(),
                  [from = fs::path(temp) / name](const std::string& p) {
                      fs::copy_file(from, p, fs::copy_options::overwrite_existing);
                  },
                  "--out-dir");
    files.commit();
}

}  // namespace nephele::cli
