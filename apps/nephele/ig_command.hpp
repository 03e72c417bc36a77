// `nephele ig`: one display channel of a CIGI 3.3 image generator over UDP (docs/cigi.md).
// Each datagram from the host is one frame: its packets are applied, the channel is drawn
// (headless) with the host API (SkyRenderer's prepare once, then update and draw per frame,
// waiting for what the update queued, so that every channel draws the same light) and a Start of Frame goes back to the
// sender with the IG's frame counter and the host frame number it answers, followed by the answers to the frame's
// Environmental Conditions Requests (the cloud water at the point, from the cloud queries).
#pragma once

#include "render_command.hpp"

#include <string>

namespace CLI {
class App;
}

namespace nephele::cli {

struct IgOptions {
    RenderOptions render;  // the starting scene, image size, GL backend (method: auto only)
    std::string address = "127.0.0.1";
    int port = 0;
    int channel = 0;  // the View ID this process draws
    bool headless = false;
    bool window = false;           // draw into a window too (GLFW), exactly one of the two
    std::string record;            // a folder: one PFM per rendered frame, named by host frame number
    long long frames = 0;          // stop after this many frames (0: no limit)
    double timeout = 10;           // seconds without a datagram: stop
    std::string origin = "0,0,0";  // LAT,LON,HEIGHT: the geodetic point of the scene's (0, 0, 0)
    // Seconds a Weather Control change takes (Weather::transitionSeconds). 0: at once, what the
    // host sent: CIGI 3.3's Weather Control carries no transition time, and a host that ramps
    // the weather itself, packet by packet, would see a nonzero default lag behind its ramp.
    double transition = 0;
};

// Adds --address, --port, --channel, --headless, --window, --record, --frames, --timeout, --origin,
// --transition to `cmd`.
void addIgOptions(CLI::App* cmd, IgOptions& o);

// Runs the loop; returns the exit code: 0 after --frames frames or at the receive timeout
// (having rendered every frame asked for), 1 on a runtime failure or a timeout before
// --frames, 2 on bad options.
int runIg(const IgOptions& o);

}  // namespace nephele::cli
