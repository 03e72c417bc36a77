// `nephele bench --scale`: how time and memory grow with the number of ellipsoids (issue 14).
// Each count is benchScene's field (clouds of 16 at 3-9 km over the view) written to a scene
// file, loaded as a host loads it, and rendered twice by each fast method: the first frame
// plans (projection, packing, light volumes) and draws; the second reuses the light volumes.
// Per phase: wall ms and the process's peak resident memory (VmHWM, reset before each phase
// through /proc/self/clear_refs; llvmpipe's GPU memory is process memory). The growth
// exponent is the least-squares slope of log(ms) against log(count).
// Peak memory is of the whole process: the loaded scene and the other renderers' caches count.
#include "bench_command.hpp"

#include "bench_util.hpp"

#include "nephele/camera.hpp"
#include "nephele/ellipsoid.hpp"
#include "nephele/gardner.hpp"
#include "nephele/gl.hpp"
#include "nephele/opaque.hpp"
#include "nephele/raymarch.hpp"
#include "nephele/sky.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>

#include <malloc.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

using Clock = std::chrono::steady_clock;

// The scene as a cloudscene file (camera and clouds; every other section at its default).
std::string sceneJson(const Scene& s) {
    std::string out;
    char buf[256];
    const Camera& c = s.camera;
    std::snprintf(
        buf, sizeof buf,
        "{\"cloudscene\": 1, \"camera\": {\"position\": [%.3f, %.3f, %.3f], \"direction\": [%.6f, %.6f, %.6f], "
        "\"fov_y_deg\": %.3f, \"width\": %d, \"height\": %d},\n\"clouds\": [",
        c.position.x, c.position.y, c.position.z, c.direction.x, c.direction.y, c.direction.z, c.fovYDeg, c.width,
        c.height);
    out += buf;
    for (std::size_t k = 0; k < s.clouds.size(); ++k) {
        out += (k ? ",\n" : "") + std::string("{\"name\": \"") + s.clouds[k].name + "\", \"ellipsoids\": [";
        for (std::size_t i = 0; i < s.clouds[k].ellipsoids.size(); ++i) {
            const Ellipsoid& e = s.clouds[k].ellipsoids[i];
            std::snprintf(
                buf, sizeof buf,
                "%s{\"center\": [%.2f, %.2f, %.2f], \"radii\": [%.2f, %.2f, %.2f], \"rotation_deg\": [0, 0, %.2f]}",
                i ? ", " : "", e.center.x, e.center.y, e.center.z, e.radii.x, e.radii.y, e.radii.z, e.rotationDeg.z);
            out += buf;
        }
        out += "]}";
    }
    return out + "]}\n";
}

// The process's peak resident memory since resetPeak(), MB (VmHWM of /proc/self/status).
// malloc_trim first hands freed memory back, so that a phase's peak is what lives then.
void resetPeak() {
    ::malloc_trim(0);
    std::ofstream("/proc/self/clear_refs") << "5";
}
double peakMb() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return 0;
}

struct Phase {
    double ms = -1, peakMb = 0;  // ms < 0: not measured
};
struct ScaleRow {
    int count = 0;
    std::string method, size;
    Phase load, plan, draw;
    double nextMs = -1;   // the second frame, light volumes reused
    std::string refused;  // the message, when the method refused the scene
};

// Times `frame` twice (first and second frame) after `background` drew the sky; each to glFinish.
// `plannedMs` reads the plan time of the frame just drawn.
void timeMethod(ScaleRow& row, const std::function<void()>& background, const std::function<void()>& frame,
                const std::function<double()>& plannedMs) {
    try {
        background();
        gl::glFinish();
        resetPeak();
        auto t0 = Clock::now();
        frame();
        gl::glFinish();
        const double total = msSince(t0);
        row.plan.ms = plannedMs();
        row.draw.ms = total - row.plan.ms;
        row.plan.peakMb = row.draw.peakMb = peakMb();  // one peak for the frame: plan and draw share it
        background();
        gl::glFinish();
        t0 = Clock::now();
        frame();
        gl::glFinish();
        row.nextMs = msSince(t0);
    } catch (const std::exception& e) {
        row.refused = e.what();
    }
}

// Least-squares slope of log(y) against log(x).
double exponent(const std::vector<std::pair<double, double>>& xy) {
    if (xy.size() < 2) return NAN;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& [x, y] : xy) {
        const double lx = std::log(x), ly = std::log(y);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
    }
    const double n = double(xy.size());
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

std::string cell(const Phase& p) {
    return p.ms < 0 ? "—" : fmt("%.0f", p.ms) + " ms / " + fmt("%.0f", p.peakMb) + " MB";
}

std::vector<ScaleRow> measure(const ScaleBenchOptions& o, std::string& renderer) {
    ContextOptions co;
    co.backend = o.bench.backend;
    auto context = Context::create(co);
    renderer = context->description();
    gl::setChecks(false);  // timing: no glGetError round trips
    const std::string file =
        (fs::temp_directory_path() / ("nephele_scale_" + std::to_string(::getpid()) + ".json")).string();
    std::vector<ScaleRow> rows;
    for (int count : o.counts) {
        { std::ofstream(file) << sceneJson(benchScene(count, o.width, o.height)); }
        ScaleRow load;
        resetPeak();
        const auto t0 = Clock::now();
        Scene scene = loadScene(file);
        load.load = {msSince(t0), peakMb()};
        fs::remove(file);
        const View view = makeView(scene.camera);
        FrameTarget target(o.width, o.height);
        OpaquePass opaque;
        auto background = [&] { opaque.draw(scene, view, target.framebuffer()); };
        const std::string size = std::to_string(o.width) + "x" + std::to_string(o.height);
        auto row = [&](const std::string& method, const std::string& rowSize) {
            ScaleRow r = load;
            r.count = count, r.method = method, r.size = rowSize;
            return r;
        };
        {
            ScaleRow r = row("ellipsoid", size);
            EllipsoidRenderer clouds;
            EllipsoidStats st;
            timeMethod(
                r, background, [&] { st = clouds.render(scene, view, target.framebuffer(), false); },
                [&] { return st.planMs; });
            rows.push_back(r);
        }
        {
            ScaleRow r = row("auto", size);
            SkyRenderer sky;
            SkyStats st;
            timeMethod(
                r, background, [&] { st = sky.render(scene, view, target.framebuffer(), 0.0, false); },
                [&] { return st.ellipsoids.planMs; });
            rows.push_back(r);
        }
        {
            ScaleRow r = row("raymarch", size);
            RaymarchRenderer marcher;
            RaymarchStats st;
            timeMethod(
                r, background, [&] { st = marcher.render(scene, view, target.framebuffer(), false); },
                [&] { return st.planMs; });
            rows.push_back(r);
        }
        {  // the CPU reference at a thumbnail size
            Scene small = scene;
            small.camera.width = o.exactWidth;
            small.camera.height = std::max(1, int(std::lround(o.exactWidth * double(o.height) / o.width)));
            ScaleRow r =
                row("gardner-exact", std::to_string(small.camera.width) + "x" + std::to_string(small.camera.height));
            const NoiseSettings ns;
            const NoiseVolume noise = makeNoiseVolume(ns);
            resetPeak();
            const auto t1 = Clock::now();
            renderGardnerExact(small, makeView(small.camera), noise, ns);
            r.draw = {msSince(t1), peakMb()};
            rows.push_back(r);
        }
        for (const ScaleRow& r : rows)
            if (r.count == count)
                std::cerr << "bench --scale: " << count << " " << r.method << ": load " << cell(r.load) << ", plan "
                          << cell(r.plan) << ", draw " << cell(r.draw)
                          << (r.refused.empty() ? "" : ", refused: " + r.refused) << "\n";
    }
    gl::setChecks(true);
    return rows;
}

std::string markdown(const ScaleBenchOptions& o, const std::vector<ScaleRow>& rows, const std::string& when,
                     const std::string& machine) {
    std::ostringstream md;
    md << "Measured by `nephele bench --scale` on " << when << ", " << machine << ". Each count is `nephele bench`'s "
       << "field of ellipsoids (clouds of 16 at 3-9 km over the view, `medium.noise` 0.3) written to a scene file; "
       << "load = `loadScene` of that file; the first frame's plan = the renderer's CPU work before its first draw "
       << "(projection, packing, the light volumes), draw = the rest of the frame to glFinish; next = the second "
       << "frame, light volumes reused. Memory = the process's peak resident set during the phase (scene included; "
       << "llvmpipe's GPU memory is process memory). gardner-exact is the CPU model at " << o.exactWidth
       << " px wide, whole. Wall times on a machine shared with other jobs: compare within a column.\n\n";
    md << "| ellipsoids | method | size | load | plan | draw | next frame ms |\n|---:|---|---|---:|---:|---:|---:|\n";
    for (const ScaleRow& r : rows) {
        md << "| " << r.count << " | " << r.method << " | " << r.size << " | " << cell(r.load) << " | ";
        if (!r.refused.empty()) {
            md << "refused: " << r.refused << " | | |\n";
            continue;
        }
        md << cell(r.plan) << " | " << cell(r.draw) << " | " << (r.nextMs < 0 ? "—" : fmt("%.0f", r.nextMs)) << " |\n";
    }
    md << "\nGrowth exponent (slope of log ms against log ellipsoids over the counts above; 1 = linear):\n\n"
       << "| method | load | first frame (plan + draw) | next frame |\n|---|---:|---:|---:|\n";
    for (const char* method : {"ellipsoid", "auto", "raymarch", "gardner-exact"}) {
        std::vector<std::pair<double, double>> load, first, next;
        for (const ScaleRow& r : rows)
            if (r.method == method && r.refused.empty()) {
                load.push_back({double(r.count), r.load.ms});
                first.push_back({double(r.count), std::max(r.plan.ms, 0.0) + r.draw.ms});
                if (r.nextMs > 0) next.push_back({double(r.count), r.nextMs});
            }
        auto e = [](const std::vector<std::pair<double, double>>& xy) {
            const double v = exponent(xy);
            return std::isnan(v) ? std::string("—") : fmt("%.2f", v);
        };
        md << "| " << method << " | " << e(load) << " | " << e(first) << " | " << e(next) << " |\n";
    }
    return md.str();
}

}  // namespace

int runScaleBench(const ScaleBenchOptions& o) {
    if (!prepareBenchOutputs(o.bench.outDir)) return 2;
    std::vector<ScaleRow> rows;
    std::string renderer;
    try {
        rows = measure(o, renderer);
    } catch (const std::exception& e) {
        std::cerr << "nephele: bench --scale failed: " << e.what() << "\n";
        return 1;
    }
    const std::string md = markdown(o, rows, utcNow(), machineLine(renderer));
    std::ostringstream csv;
    csv << "ellipsoids,method,size,load_ms,load_peak_mb,plan_ms,draw_ms,frame_peak_mb,next_ms,refused\n";
    for (const ScaleRow& r : rows)
        csv << r.count << "," << r.method << "," << r.size << "," << fmt("%.1f", r.load.ms) << ","
            << fmt("%.1f", r.load.peakMb) << "," << fmt("%.1f", r.plan.ms) << "," << fmt("%.1f", r.draw.ms) << ","
            << fmt("%.1f", r.draw.peakMb) << "," << fmt("%.1f", r.nextMs) << ",\"" << r.refused << "\"\n";
    return publishTextBench("bench --scale", o.bench.outDir, "scale bench", "scale_bench", csv.str(), md);
}

}  // namespace nephele::cli
