// `nephele fly SCENE [--script FLIGHT.json] --record DIR [--headless]`.
#include "fly_command.hpp"
#include "fly_host.hpp"
#include "fly_script.hpp"
#include "output_files.hpp"

#include "nephele/context.hpp"
#include "nephele/gl.hpp"
#include "nephele/log.hpp"
#include "nephele/png.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <vector>

extern char** environ;

namespace fs = std::filesystem;

namespace nephele::fly {

namespace {

struct Recording {
    Scene scene;
    Flight flight;
    FlyMethod method = FlyMethod::Auto;
};

// Everything that can be bad input, checked before a context is made. Throws SceneError
// or std::invalid_argument.
Recording prepare(const FlyOptions& o) {
    Recording r;
    const auto method = parseFlyMethod(o.method);
    if (!method)
        throw std::invalid_argument("--method: unknown method '" + o.method +
                                    "' (expected auto, ellipsoid, raymarch or layered)");
    r.method = *method;
    cli::resolveOutput("--record", o.record, /*folder=*/true);  // its name and place, before any work
    std::error_code ec;
    if (fs::exists(o.record) && !(fs::is_directory(o.record) && fs::is_empty(o.record, ec)))
        throw std::invalid_argument("--record '" + o.record + "' exists and is not an empty folder");
    const fs::path parent = fs::absolute(o.record).parent_path();
    if (!fs::is_directory(parent))
        throw std::invalid_argument("--record: folder '" + parent.string() + "' does not exist");
    if (!(o.fps > 0 && o.fps <= 1000)) throw std::invalid_argument("--fps must be in (0, 1000]");
    r.scene = loadScene(o.scene);
    // One of --width / --height alone keeps the camera's aspect, as `render` does.
    Camera& cam = r.scene.camera;
    const double aspect = double(cam.width) / cam.height;
    if (o.width > 0)
        cam.width = o.width, cam.height = o.height > 0 ? o.height : std::max(1, int(std::lround(o.width / aspect)));
    else if (o.height > 0) cam.height = o.height, cam.width = std::max(1, int(std::lround(o.height * aspect)));
    if (cam.width > 16384 || cam.height > 16384)
        throw std::invalid_argument("--width/--height: frames of at most 16384 pixels a side");
    r.flight = o.script.empty() ? pathFlight(r.scene, o.fps) : loadFlight(o.script);
    return r;
}

// The program's path on $PATH, or "".
std::string findOnPath(const std::string& program) {
    const char* path = std::getenv("PATH");
    std::string dirs = path ? path : "";
    for (std::size_t a = 0; a <= dirs.size();) {
        const std::size_t b = std::min(dirs.find(':', a), dirs.size());
        const fs::path p = fs::path(dirs.substr(a, b - a)) / program;
        if (b > a && ::access(p.c_str(), X_OK) == 0) return p.string();
        a = b + 1;
    }
    return "";
}

void writeVideo(const std::string& ffmpeg, const fs::path& dir, double fps) {
    const std::string rate = std::to_string(fps), frames = (dir / "frame_%04d.png").string(),
                      mp4 = (dir / "flight.mp4").string();
    std::vector<const char*> argv = {"ffmpeg",
                                     "-nostdin",
                                     "-loglevel",
                                     "error",
                                     "-y",
                                     "-framerate",
                                     rate.c_str(),
                                     "-i",
                                     frames.c_str(),
                                     "-vf",
                                     "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                                     "-pix_fmt",
                                     "yuv420p",
                                     mp4.c_str(),
                                     nullptr};
    pid_t pid = 0;
    int status = 0;
    if (posix_spawn(&pid, ffmpeg.c_str(), nullptr, nullptr, const_cast<char* const*>(argv.data()), environ) != 0 ||
        waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
        throw std::runtime_error("ffmpeg could not write flight.mp4 (--no-video skips it)");
}

// Plays the flight into `temp`: frames, frames.csv, flight.json.
void play(const Recording& rec, const FlyOptions& o, const fs::path& temp) {
    ContextOptions co;
    co.backend = o.headless ? GlBackend::Egl : GlBackend::Glfw;
    co.width = rec.scene.camera.width;
    co.height = rec.scene.camera.height;
    co.title = "nephele fly: recording";
    const std::unique_ptr<Context> context = Context::create(co);
    gl::setChecks(true);
    // Every near-LOD cell and every light at every frame, as `render --time` makes them (the
    // window spreads the cells and lights new clouds by a stand-in until their grids are made).
    FlyHost host({rec.method, std::nullopt, o.cacheDir, true, 0, true});
    const std::vector<Camera> cameras = flightCameras(rec.flight, rec.scene);
    std::ofstream csv(temp / "frames.csv");
    csv << "frame,t,x,y,z,total_ms,opaque_ms,far_field_ms,near_lod_ms,tiles_ms,composite_ms,volume_ms,visible,passes\n";
    for (int k = 0; k < int(cameras.size()); ++k) {
        const double t = rec.flight.frameTime(k);
        const FlyFrameStats st = host.draw(rec.scene, cameras[k], t);
        if (GLFWwindow* w = context->window()) {
            int fw = 0, fh = 0;
            glfwGetFramebufferSize(w, &fw, &fh);
            host.present(0, fw, fh);
            glfwSwapBuffers(w);
            glfwPollEvents();
        }
        char name[32];
        std::snprintf(name, sizeof name, "frame_%04d.png", k);
        writePng((temp / name).string(), channels(host.readColor(), 0, 3), Encoding::Srgb);
        const Vec3& p = cameras[k].position;
        char row[256];
        std::snprintf(row, sizeof row, "%d,%.6f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%d,%d\n", k, t, p.x,
                      p.y, p.z, st.totalMs, st.opaqueMs, st.farFieldMs, st.nearLodMs, st.tilesMs, st.compositeMs,
                      st.volumeMs, st.ellipsoids.visible, st.ellipsoids.passes);
        csv << row;
        reportProgress("recording", double(k + 1) / double(cameras.size()));
    }
    if (!csv.flush()) throw std::runtime_error("cannot write frames.csv");
    std::ofstream(temp / "flight.json") << flightJson(rec.flight);
}

}  // namespace

int runFlyRecord(const FlyOptions& o) {
    Recording rec;
    try {
        rec = prepare(o);
    } catch (const std::exception& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 2;
    }
    // The folder is written beside its target and renamed into place at the end.
    const fs::path out = fs::absolute(o.record);
    const fs::path temp = out.string() + ".partial-" + std::to_string(::getpid());
    std::error_code ec;
    try {
        fs::create_directories(temp);
        play(rec, o, temp);
        const std::string ffmpeg = o.video ? findOnPath("ffmpeg") : "";
        const bool video = !ffmpeg.empty();
        if (video) writeVideo(ffmpeg, temp, rec.flight.fps);
        if (fs::exists(out)) fs::remove(out);
        fs::rename(temp, out);
        std::cerr << "nephele: wrote " << rec.flight.frameCount() << " frames, frames.csv, flight.json"
                  << (video     ? ", flight.mp4"
                      : o.video ? " (no flight.mp4: ffmpeg is not installed)"
                                : "")
                  << " to " << o.record << "\n";
    } catch (const ContextError& e) {
        fs::remove_all(temp, ec);
        std::cerr << "nephele: recording failed: " << e.what()
                  << (o.headless ? "" : " (no display? use --headless or xvfb-run)") << "\n";
        return 1;
    } catch (const std::exception& e) {
        fs::remove_all(temp, ec);
        std::cerr << "\nnephele: recording failed: " << e.what() << "\n";
        return 1;
    }
    return 0;
}

}  // namespace nephele::fly
