#include "bench_util.hpp"

#include "output_files.hpp"

#include "nephele/gl.hpp"

#include <algorithm>
#include <chrono>
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

bool prepareBenchOutputs(const std::string& outDir, const std::string& readme, const std::string& tag) {
    std::error_code ec;
    fs::create_directories(outDir, ec);
    if (!fs::is_directory(outDir)) {
        std::cerr << "nephele: bench: --out-dir: cannot create the output folder '" << outDir << "'"
                  << (ec ? ": " + ec.message() : "") << "\n";
        return false;
    }
    if (readme.empty()) return true;
    if (!fs::is_regular_file(readme)) {
        std::cerr << "nephele: bench: --readme '" << readme << "' is not a file\n";
        return false;
    }
    try {  // its name too, before the bench: it is replaced through a temporary beside it
        resolveOutput("--readme", readme);
    } catch (const std::invalid_argument& e) {
        std::cerr << "nephele: bench: " << e.what() << "\n";
        return false;
    }
    if (tag.empty()) return true;
    std::string text;
    try {
        text = readText(readme);
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench: " << e.what() << "\n";
        return false;
    }
    if (text.find(beginMarker(tag)) == std::string::npos || text.find(endMarker(tag)) == std::string::npos) {
        std::cerr << "nephele: bench: --readme '" << readme << "' has no '" << beginMarker(tag) << "' ... '"
                  << endMarker(tag) << "' lines to replace; add them where the table should go\n";
        return false;
    }
    return true;
}

void replaceGeneratedSection(const std::string& readme, const std::string& tag, const std::string& markdown,
                             const std::vector<std::string>& files) {
    std::string s = readText(readme);
    const std::string begin = beginMarker(tag), end = endMarker(tag);
    const auto b = s.find(begin), e = s.find(end);
    if (b == std::string::npos || e == std::string::npos || e < b)
        throw std::runtime_error(readme + " has no '" + begin + "' ... '" + end + "' section");
    s = s.substr(0, b + begin.size()) + "\n" + markdown + s.substr(e);
    OutputFiles out;
    out.add(readme, textWriter(s), "--readme");
    if (!files.empty()) {
        const fs::path docs = fs::path(readme).parent_path() / "docs";
        std::error_code ec;
        fs::create_directories(docs, ec);
        if (ec) throw std::runtime_error("cannot make " + docs.string() + " beside --readme: " + ec.message());
        for (const std::string& f : files)
            out.add((docs / fs::path(f).filename()).string(),
                    [from = fs::path(f)](const std::string& p) { fs::copy_file(from, p, fs::copy_options::overwrite_existing); },
                    "--readme");
    }
    out.commit();
}

void writeTextFiles(const std::vector<std::pair<std::string, std::string>>& pathsAndTexts) {
    OutputFiles files;
    for (const auto& [path, text] : pathsAndTexts) files.add(path, textWriter(text), "--out-dir");
    files.commit();
}

int publishTextBench(const std::string& what, const std::string& outDir, const std::string& readme, const std::string& tag,
                     const std::string& stem, const std::string& csv, const std::string& markdown) {
    const std::string csvPath = (fs::path(outDir) / (stem + ".csv")).string();
    const std::string mdPath = (fs::path(outDir) / (stem + ".md")).string();
    try {
        writeTextFiles({{csvPath, csv}, {mdPath, markdown}});
        if (!readme.empty()) replaceGeneratedSection(readme, tag, markdown, {csvPath, mdPath});
    } catch (const std::exception& e) {
        std::cerr << "nephele: " << what << ": " << e.what() << "\n";
        return 1;
    }
    std::cout << markdown;
    std::cerr << "nephele: " << what << " wrote " << csvPath << ", " << mdPath << (readme.empty() ? "" : ", " + readme) << "\n";
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
    cmd += shellQuote(std::string(NEPHELE_SOURCE_DIR) + "/demo/" + scriptName);
    for (std::string a : args) {
        if (a.rfind(kChartsFolder, 0) == 0) a = temp + a.substr(std::string(kChartsFolder).size());
        cmd += ' ', cmd += shellQuote(a);
    }
    if (std::system(cmd.c_str()) != 0)
        throw std::runtime_error("the chart (" + scriptName +
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
