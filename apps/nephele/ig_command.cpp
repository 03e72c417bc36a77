#include "ig_command.hpp"

#include "fly_app.hpp"
#include "output_files.hpp"

#include "nephele/cigi.hpp"
#include "nephele/cigi_scene.hpp"
#include "nephele/geodetic.hpp"
#include "nephele/gl.hpp"
#include "nephele/host_view.hpp"
#include "nephele/log.hpp"
#include "nephele/shader.hpp"
#include "nephele/weather.hpp"

#include <CLI/CLI.hpp>
#include <GLFW/glfw3.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <set>

namespace nephele::cli {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kMaxDatagram = 65536;  // a UDP datagram's largest payload

// A UDP socket bound to ADDRESS:PORT whose receive gives up after `timeout` seconds.
class UdpSocket {
public:
    UdpSocket(const std::string& address, int port, double timeout) {
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_port = htons(static_cast<std::uint16_t>(port));
        if (inet_pton(AF_INET, address.c_str(), &a.sin_addr) != 1)
            throw UsageError("--address must be an IPv4 address such as 127.0.0.1, got '" + address + "'");
        fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
        if (fd_ < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
        if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
            const int e = errno;
            ::close(fd_);
            throw std::runtime_error("binding UDP " + address + ":" + std::to_string(port) + ": " + std::strerror(e));
        }
        timeval tv{};
        tv.tv_sec = static_cast<time_t>(timeout);
        tv.tv_usec = static_cast<suseconds_t>((timeout - std::floor(timeout)) * 1e6);
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    ~UdpSocket() { ::close(fd_); }
    UdpSocket(const UdpSocket&) = delete;
    UdpSocket& operator=(const UdpSocket&) = delete;

    // The datagram's size, or -1 at the timeout.
    long receive(std::vector<std::uint8_t>& buffer, sockaddr_in& from) {
        buffer.resize(kMaxDatagram);
        for (;;) {
            socklen_t len = sizeof from;
            const ssize_t n =
                ::recvfrom(fd_, buffer.data(), buffer.size(), 0, reinterpret_cast<sockaddr*>(&from), &len);
            if (n >= 0) return static_cast<long>(n);
            if (errno == EINTR) continue;
            if (errno == EAGAIN || errno == EWOULDBLOCK) return -1;
            throw std::runtime_error(std::string("receiving: ") + std::strerror(errno));
        }
    }
    void send(const std::vector<std::uint8_t>& bytes, const sockaddr_in& to) {
        if (::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to) < 0)
            logMessage(LogLevel::Warning, std::string("nephele ig: sending Start of Frame: ") + std::strerror(errno));
    }

private:
    int fd_ = -1;
};

double degrees(double radians) { return radians * 180 / kPi; }
double radians(double degrees) { return degrees * kPi / 180; }

// What the host's packets have set so far.
struct IgState {
    Scene scene;  // the starting scene, its sun and layers replaced by `weather`'s
    Weather weather;
    int channel = 0;
    double left = 0, right = 0, bottom = 0, top = 0;  // the channel's half-angles (degrees), View Definition's
    ChannelOptions view;                              // the frustum and yaw/pitch offsets drawn
    double yaw = 0, pitch = 0;
    cigi::AtmosphereControl atmosphere;
    std::optional<EnuFrame> frame;  // the scene's frame (--origin): the host's latitudes, longitudes, altitudes
    cigi::CelestialLight day;       // the light with the sun on: the scene's, then the last date and time's
    std::uint16_t eyeEntity = 0;    // the entity the channel's view rides on (View Control's Entity ID)
    struct Entity {
        cigi::EntityPose pose;
        bool active = false;  // Entity State 1: drawn (0 standby and 2 destroyed are not)
    };
    std::map<std::uint16_t, Entity> entities;  // the last pose of each entity the host placed
    std::vector<Object> sceneObjects;          // the starting scene's own objects
    std::set<std::string> said;                // messages given once

    void once(const std::string& message) {
        if (said.insert(message).second) logMessage(LogLevel::Warning, "nephele ig: " + message);
    }

    void apply(const cigi::WeatherControl& p) {
        CloudLayerControl c;
        c.layerId = p.layerId;
        c.weatherEnable = p.weatherEnable;
        c.scope = static_cast<CigiWeatherScope>(p.scope);
        c.cloudType = static_cast<CigiCloudType>(p.cloudType);
        c.coverage = p.coverage;
        c.baseElevation = p.baseElevation;
        c.thickness = p.thickness;
        c.transitionBand = p.transitionBand;
        c.horizontalWindSpeed = p.horizontalWindSpeed;
        c.verticalWindSpeed = p.verticalWindSpeed;
        c.windDirection = p.windDirection;
        try {
            weather.apply(c);
        } catch (const std::invalid_argument& e) {
            once(std::string(e.what()) + " (packet ignored)");
        }
    }

    void apply(const cigi::ViewDefinition& p) {
        if (p.viewId != channel) return;
        if (p.leftEnable) left = p.left;
        if (p.rightEnable) right = p.right;
        if (p.bottomEnable) bottom = p.bottom;
        if (p.topEnable) top = p.top;
        if (p.nearEnable || p.farEnable) once("View Definition: the near and far planes are the scene camera's");
        if (p.mirrorMode != 0 || p.pixelReplication != 0 || p.orthographic)
            once("View Definition: mirror modes, pixel replication and orthographic views are not drawn");
        setView();
    }

    // Celestial Sphere Control: the date and time's sun and sky at --origin's latitude and
    // longitude (Date/Time Valid), the sun's light off when Sun Enable is clear.
    void apply(const cigi::CelestialSphereControl& p) {
        try {
            const cigi::CelestialLight light =
                cigi::applyCelestial(p, frame->origin().latitudeDeg, frame->origin().longitudeDeg, day);
            weather.sun = light.sun;
            weather.sky = light.sky;
        } catch (const std::invalid_argument& e) {
            once(std::string(e.what()) + " (packet ignored)");
        }
        if (p.ephemerisModelEnable)
            once(
                "Celestial Sphere Control: the sun moves with the host's date and time only (no ephemeris clock of the "
                "IG's own)");
        if (p.moonEnable || p.starFieldEnable) once("Celestial Sphere Control: the moon and the stars are not drawn");
    }

    // Entity Control: each entity's pose; the one the view rides on is the eye.
    void apply(const cigi::EntityControl& p) {
        if (p.attached) {
            once("Entity Control: entities attached to a parent are not placed (entity " + std::to_string(p.entityId) +
                 ")");
            return;
        }
        try {
            entities[p.entityId] = {cigi::entityPose(p, *frame), p.entityState == 1};
        } catch (const std::invalid_argument& e) {
            once(std::string(e.what()) + " (packet ignored)");
        }
    }

    // The eye: the pose of the entity the view rides on once the host has placed it, else the
    // scene camera's (its `path` at the frame's time).
    Camera eye(double t) const {
        Camera camera = cameraAt(scene, t);
        camera.width = scene.camera.width;
        camera.height = scene.camera.height;
        if (const auto e = entities.find(eyeEntity); e != entities.end()) {
            camera.position = e->second.pose.position;
            camera.direction = e->second.pose.forward;
            camera.up = e->second.pose.up;
        }
        return camera;
    }

    // The objects drawn: the scene's, and a box for every active entity but the eye.
    std::vector<Object> objects() const {
        std::vector<Object> all = sceneObjects;
        for (const auto& [id, e] : entities)
            if (e.active && id != eyeEntity) all.push_back(cigi::entityBox(e.pose));
        return all;
    }

    void apply(const cigi::ViewControl& p) {
        if (p.viewId != channel) return;
        eyeEntity = p.entityId;
        if (p.yawEnable) yaw = p.yaw;
        if (p.pitchEnable) pitch = p.pitch;
        if (p.rollEnable || p.xOffsetEnable || p.yOffsetEnable || p.zOffsetEnable)
            once("View Control: roll and eyepoint offsets are not applied (yaw and pitch are)");
        setView();
    }

    // The frustum of the half-angles as tangents, checked as --frustum is.
    void setView() {
        char f[160];
        std::snprintf(f, sizeof f, "%.9g,%.9g,%.9g,%.9g", std::tan(radians(left)), std::tan(radians(right)),
                      std::tan(radians(bottom)), std::tan(radians(top)));
        try {
            view = parseChannel(f, yaw, pitch);
        } catch (const UsageError& e) {
            once(std::string("channel ") + std::to_string(channel) + ": " + e.what() + " (view left as it was)");
        }
    }

    // Environmental Conditions Request: the global atmosphere, and per enabled cloud layer the
    // liquid water content (g/m^3) of the clouds at the request's point when it lies in that
    // layer's slab (0 elsewhere): the extinction the cloud queries give there, in droplets of
    // kCumulusDropletRadius (docs/cigi.md). The point is converted into the scene's frame
    // (--origin); the host's Aerosol Concentration values are not echoed.
    void answer(const cigi::EnvironmentalConditionsRequest& r, const SkyRenderer& sky, cigi::DatagramWriter& out) {
        if (r.requestType & 4) {
            cigi::WeatherConditionsResponse w;
            w.requestId = r.requestId;
            w.humidity = atmosphere.humidity;
            w.airTemperature = atmosphere.airTemperature;
            w.visibilityRange = atmosphere.visibilityRange;
            w.horizontalWindSpeed = atmosphere.horizontalWindSpeed;
            w.verticalWindSpeed = atmosphere.verticalWindSpeed;
            w.windDirection = atmosphere.windDirection;
            w.barometricPressure = atmosphere.barometricPressure;
            out.add(w);
        }
        if (r.requestType & 8) {
            double water = 0;
            Vec3 point(0.0);
            bool placed = false;
            try {
                point = frame->geodeticToEnu(Geodetic{r.latitude, r.longitude, r.altitude});
                water = liquidWaterFromExtinction(sky.densityAt(point), kCumulusDropletRadius);
                placed = true;
            } catch (const std::invalid_argument& e) {
                once(std::string("Environmental Conditions Request: ") + e.what() + " (answered with no cloud water)");
            }
            for (const auto& [id, l] : weather.layers) {
                if (!l.enabled) continue;
                cigi::AerosolConcentrationResponse a;
                a.requestId = r.requestId;
                a.layerId = static_cast<std::uint8_t>(id);
                const bool inside = placed && point.z >= l.layer.base && point.z <= l.layer.base + l.layer.thickness;
                a.aerosolConcentration = inside ? static_cast<float>(water) : 0.0f;
                out.add(a);
            }
        }
        if (r.requestType & 3)
            once("Environmental Conditions Request: maritime and terrestrial surface conditions are not answered");
    }
};

}  // namespace

void addIgOptions(CLI::App* cmd, IgOptions& o) {
    cmd->add_option("--port", o.port, "UDP port to receive the host's datagrams on")
        ->required()
        ->check(CLI::Range(1, 65535));
    cmd->add_option("--address", o.address, "IPv4 address to bind (0.0.0.0: every interface, for a host on another PC)")
        ->capture_default_str();
    cmd->add_option("--channel", o.channel, "The CIGI View ID this process draws")
        ->check(CLI::Range(0, 65535))
        ->capture_default_str();
    cmd->add_flag("--headless", o.headless, "Render off-screen (EGL, or --gl osmesa)");
    cmd->add_flag("--window", o.window, "Render and show each frame in a window (GLFW: needs a display)");
    cmd->add_option("--record", o.record,
                    "Folder (created if absent) for one PFM per frame, host-frame-NUMBER.pfm (linear); with --window "
                    "also window-frame-NUMBER.pfm, what the window shows (sRGB / 255)");
    cmd->add_option("--frames", o.frames, "Stop after this many frames (0: no limit)")
        ->check(CLI::Range(0LL, 1000000000LL));
    cmd->add_option("--timeout", o.timeout, "Stop after this many seconds without a datagram")
        ->check(CLI::Range(0.01, 86400.0))
        ->capture_default_str();
    cmd->add_option(
           "--origin", o.origin,
           "LAT,LON,HEIGHT: the WGS84 point (degrees, degrees, m) of the scene's (0, 0, 0), its x east, y north, "
           "z up; the host's geodetic positions are taken into this frame")
        ->capture_default_str();
    cmd->add_option("--transition", o.transition,
                    "Seconds over which a Weather Control change ramps (coverage, base, thickness, wind, a layer on "
                    "or off); 0: at once, as the host sent it (for a host that ramps the weather itself)")
        ->check(CLI::Range(0.0, 3600.0))
        ->capture_default_str();
}

namespace {
// "LAT,LON,HEIGHT" as --origin takes it.
Geodetic parseOrigin(const std::string& text) {
    double v[3];
    char tail = 0;
    if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) != 3)
        throw UsageError("--origin must be LAT,LON,HEIGHT (three numbers separated by commas), got '" + text + "'");
    if (!(std::abs(v[0]) <= 90) || !std::isfinite(v[1]) || !(std::abs(v[2]) <= 100000))
        throw UsageError(
            "--origin: latitude in [-90, 90] degrees, a finite longitude and a height within 100 km, got '" + text +
            "'");
    return Geodetic{v[0], v[1], v[2]};
}
}  // namespace

namespace {
// --window: each frame, the linear float frame onto the window as `nephele fly` shows it
// (clamped, sRGB-encoded: shaders/fly_present.frag), scaled to the window's framebuffer.
struct Screen {
    Program present = Program::build({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "fly_present.frag"}});
    gl::VertexArray empty = gl::VertexArray::create();
    gl::Sampler linear = gl::linearSampler(GL_CLAMP_TO_EDGE);
    // Shows `frame`; with `shown`, also reads back what the window shows (sRGB values / 255,
    // row 0 at the top) for --record.
    void show(const Context& context, const FrameTarget& frame, Image* shown) {
        int w = 0, h = 0;
        glfwGetFramebufferSize(context.window(), &w, &h);
        gl::glBindFramebuffer(GL_FRAMEBUFFER, 0);
        gl::glViewport(0, 0, w, h);
        gl::glDisable(GL_BLEND);
        gl::glDisable(GL_DEPTH_TEST);
        gl::glUseProgram(present.id());
        present.set("frame", 0);
        gl::glBindTextureUnit(0, frame.colorTexture());
        gl::glBindSampler(0, linear.id());
        gl::glBindVertexArray(empty.id());
        gl::glDrawArrays(GL_TRIANGLES, 0, 3);
        gl::check("showing the frame in the window");
        if (shown) *shown = fly::readWindow(w, h);
        glfwSwapBuffers(context.window());
        glfwPollEvents();
    }
};
}  // namespace

namespace {

// What the IG holds from its start to its end: the host's state, the GL objects, the socket.
struct Ig {
    IgState s;
    std::unique_ptr<Context> context;
    std::unique_ptr<FrameTarget> target;
    std::unique_ptr<OpaquePass> opaque;
    std::unique_ptr<SkyRenderer> sky;
    std::unique_ptr<UdpSocket> socket;
    std::optional<Screen> screen;  // --window
};

// Checks the options, loads the scene, binds the socket, makes the context and prepares the
// sky (the one wait). Throws.
void startIg(const IgOptions& o, Ig& ig) {
    IgState& s = ig.s;
    if (o.headless == o.window) throw UsageError("nephele ig: give exactly one of --headless and --window");
    if (o.render.method != Method::Auto) throw UsageError("nephele ig draws with --method auto only");
    if (!o.record.empty()) {
        std::filesystem::create_directories(o.record);
        if (!std::filesystem::is_directory(o.record)) throw UsageError("--record: '" + o.record + "' is not a folder");
    }
    s.scene = loadScene(o.render.scene);
    applySize(s.scene, o.render);
    checkFrameMemory(s.scene, o.render);
    s.weather = Weather::of(s.scene);
    s.weather.transitionSeconds = o.transition;
    s.frame.emplace(parseOrigin(o.origin));
    s.day = {s.scene.sun, s.scene.sky};
    s.sceneObjects = s.scene.objects;
    s.channel = o.channel;
    const Camera& cam = s.scene.camera;
    const Frustum f = symmetricFrustum(cam.fovYDeg, double(cam.width) / cam.height);
    s.left = degrees(std::atan(f.left)), s.right = degrees(std::atan(f.right));
    s.bottom = degrees(std::atan(f.bottom)), s.top = degrees(std::atan(f.top));
    ig.socket = std::make_unique<UdpSocket>(o.address, o.port, o.timeout);
    ContextOptions co;
    co.backend = o.window ? GlBackend::Glfw : o.render.backend;
    co.width = cam.width, co.height = cam.height;
    co.title = "nephele ig: channel " + std::to_string(o.channel);
    ig.context = Context::create(co);
    if (o.window) ig.screen.emplace();
    gl::setChecks(true);
    ig.opaque = std::make_unique<OpaquePass>();
    ig.sky = std::make_unique<SkyRenderer>(SkySettings{o.render.layered, o.render.nearLod, o.render.ellipsoid});
    ig.sky->prepare(s.scene);  // the one wait: shaders, the layers' lighting, the clouds' grids
    ig.target = std::make_unique<FrameTarget>(cam.width, cam.height);
}

// A frame's packets applied to the state; its Environmental Conditions Requests, answered
// after the frame is drawn.
std::vector<const cigi::EnvironmentalConditionsRequest*> applyPackets(IgState& s, const cigi::HostDatagram& d) {
    std::vector<const cigi::EnvironmentalConditionsRequest*> requests;
    for (const cigi::HostPacket& p : d.packets) {
        if (auto* w = std::get_if<cigi::WeatherControl>(&p)) s.apply(*w);
        else if (auto* v = std::get_if<cigi::ViewDefinition>(&p)) s.apply(*v);
        else if (auto* c = std::get_if<cigi::ViewControl>(&p)) s.apply(*c);
        else if (auto* a = std::get_if<cigi::AtmosphereControl>(&p)) s.atmosphere = *a;
        else if (auto* r = std::get_if<cigi::EnvironmentalConditionsRequest>(&p)) requests.push_back(r);
        else if (auto* cs = std::get_if<cigi::CelestialSphereControl>(&p)) s.apply(*cs);
        else if (auto* e = std::get_if<cigi::EntityControl>(&p)) s.apply(*e);
    }
    return requests;
}

// --record: the frame drawn (linear), and with --window what the window shows, as PFMs named
// by the host frame number.
void recordFrame(const IgOptions& o, const Ig& ig, std::uint32_t hostFrame, const Image& shown) {
    char name[64];
    std::snprintf(name, sizeof name, "host-frame-%010u.pfm", hostFrame);
    const Image color = channels(ig.target->readColor(), 0, 3);
    OutputFiles files;
    files.add((std::filesystem::path(o.record) / name).string(), [&](const std::string& p) { writePfm(p, color); },
              "--record");
    if (ig.screen) {
        std::snprintf(name, sizeof name, "window-frame-%010u.pfm", hostFrame);
        files.add((std::filesystem::path(o.record) / name).string(), [&](const std::string& p) { writePfm(p, shown); },
                  "--record");
    }
    files.checkPaths();
    files.commit();
}

// Draws the host frame `igc` with the state its packets left, then records or shows it.
// Returns false when the window was closed.
bool drawFrame(const IgOptions& o, Ig& ig, const cigi::IgControl& igc) {
    IgState& s = ig.s;
    const std::unique_ptr<SkyRenderer>& sky = ig.sky;
    // The frame's time: the host's timestamp when valid, else its frame number at 60 Hz, so
    // that every channel of one host frame draws the same instant.
    const double t = igc.timestampValid ? igc.timestamp * 1e-5 : igc.hostFrameNumber / 60.0;
    s.scene.sun = s.weather.sun;  // the opaque pass's light, and a rewind's prepare()
    s.scene.sky = s.weather.sky;
    s.scene.layers = s.weather.enabledLayers();
    ig.context->makeCurrent();
    s.scene.objects = s.objects();
    const Camera camera = s.eye(t);
    const View view = channelView(camera, s.view);
    // The host's clock drives the sky's; one that runs back (a host restarting its frame
    // numbers) starts the sky again (prepare() sets its time to 0). prepare() numbers the
    // scene's layers 1, 2, 3, 10, ... as Weather::of does, not by the ids the host gave them:
    // an update at once to the host's weather gives each layer its id back before the frame's
    // update, which would otherwise ramp from one to the other.
    if (t < sky->time() - 1e-6) {
        sky->prepare(s.scene);
        Weather atOnce = s.weather;
        atOnce.transitionSeconds = 0;
        sky->update(0, atOnce, camera.position);
    }
    sky->update(std::max(0.0, t - sky->time()), s.weather, camera.position);
    // Every channel must draw the same light for one host frame, and each IG process makes its
    // own: what a weather change queued is waited for here, so a change that needs a new
    // lighting volume still costs the frame it lands in.
    sky->waitForBackgroundWork();
    ig.opaque->draw(s.scene, view, ig.target->framebuffer());
    sky->draw(viewDescOf(view, ig.target->framebuffer(), !s.scene.objects.empty()));
    Image shown;
    if (ig.screen) ig.screen->show(*ig.context, *ig.target, o.record.empty() ? nullptr : &shown);
    if (!o.record.empty()) recordFrame(o, ig, igc.hostFrameNumber, shown);
    else if (!ig.screen) gl::glFinish();
    return !(ig.screen && glfwWindowShouldClose(ig.context->window()));
}

// The answer to host frame `igc`, in the host's byte order: a Start of Frame with the IG's
// frame counter (advanced here), then the answers to the frame's requests.
std::vector<std::uint8_t> answerFrame(IgState& s, const SkyRenderer& sky, const cigi::HostDatagram& d,
                                      const std::vector<const cigi::EnvironmentalConditionsRequest*>& requests,
                                      bool operate, std::uint32_t& igFrame,
                                      std::chrono::steady_clock::time_point start) {
    const cigi::IgControl& igc = d.igControl;
    cigi::DatagramWriter reply(d.byteOrder);
    for (const auto* r : requests) {
        if (reply.bytes().size() > 60000) {  // a UDP datagram holds 65507 bytes
            s.once(
                "more Environmental Conditions Requests in one frame than one datagram can answer: the rest are not");
            break;
        }
        s.answer(*r, sky, reply);
    }
    cigi::StartOfFrame sof;
    sof.databaseNumber = static_cast<std::int8_t>(igc.databaseNumber > 0 ? igc.databaseNumber : 0);
    sof.igMode = operate ? igc.igMode : cigi::IgMode::Reset;
    sof.igFrameNumber = ++igFrame;
    sof.lastHostFrameNumber = igc.hostFrameNumber;
    sof.timestampValid = true;
    sof.timestamp = static_cast<std::uint32_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - start).count() / 10);
    cigi::DatagramWriter out(d.byteOrder);
    out.add(sof);
    const std::vector<std::uint8_t>& extra = reply.bytes();
    std::vector<std::uint8_t> datagram = out.bytes();
    datagram.insert(datagram.end(), extra.begin(), extra.end());
    return datagram;
}

}  // namespace

int runIg(const IgOptions& o) {
    Ig ig;
    try {
        startIg(o, ig);
    } catch (const std::exception& e) {
        return reportError(e, "starting nephele ig");
    }
    std::cerr << "nephele: ig: channel " << o.channel << " listening on " << o.address << ":" << o.port << " ("
              << ig.s.scene.camera.width << "x" << ig.s.scene.camera.height << ")\n";

    const auto start = std::chrono::steady_clock::now();
    std::uint32_t igFrame = 0;
    long long rendered = 0;
    std::vector<std::uint8_t> buffer;
    std::optional<std::uint32_t> lastHostFrame;
    std::vector<std::uint8_t> lastAnswer;
    try {
        for (;;) {
            sockaddr_in from{};
            const long n = ig.socket->receive(buffer, from);
            if (n < 0) {
                if (o.frames > 0 && rendered < o.frames) {
                    std::cerr << "nephele: ig: no datagram from the host for " << o.timeout << " s after " << rendered
                              << " of " << o.frames << " frames\n";
                    return 1;
                }
                std::cerr << "nephele: ig: no datagram for " << o.timeout << " s: stopping after " << rendered
                          << " frames\n";
                return 0;
            }
            const auto d =
                cigi::parseHostDatagram(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)));
            if (!d) continue;  // logged by the parser; no Start of Frame for a datagram that is not a frame
            const cigi::IgControl& igc = d->igControl;
            // A host resending its frame (it has not seen the Start of Frame yet) gets the same
            // answer again: the frame is not drawn twice and the IG frame counter does not move.
            if (lastHostFrame && igc.hostFrameNumber == *lastHostFrame) {
                ig.socket->send(lastAnswer, from);
                continue;
            }
            const auto requests = applyPackets(ig.s, *d);
            const bool operate = igc.igMode == cigi::IgMode::Operate || igc.igMode == cigi::IgMode::Debug;
            if (operate) {
                if (!drawFrame(o, ig, igc)) {
                    std::cerr << "nephele: ig: the window was closed after " << rendered + 1 << " frames\n";
                    return 0;
                }
                ++rendered;
            }
            std::vector<std::uint8_t> datagram = answerFrame(ig.s, *ig.sky, *d, requests, operate, igFrame, start);
            ig.socket->send(datagram, from);
            lastHostFrame = igc.hostFrameNumber;
            lastAnswer = std::move(datagram);
            if (o.frames > 0 && rendered >= o.frames) {
                std::cerr << "nephele: ig: " << rendered << " frames drawn\n";
                return 0;
            }
        }
    } catch (const std::exception& e) {
        return reportError(e, "nephele ig");
    }
}

}  // namespace nephele::cli
