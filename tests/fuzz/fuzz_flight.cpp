// libFuzzer: the flight-script reader of `nephele fly --script` (apps/fly/fly_script.cpp) on any
// bytes, and the cameras of the flight it reads (keyframes interpolated, inputs integrated at
// the fixed step) over a small scene. A SceneError is the expected way to fail; anything else
// (another exception, a crash, a sanitizer report, a timeout) is a finding.
#include "fly_script.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const nephele::Scene scene = [] {
        nephele::Scene s;
        s.camera.width = 16, s.camera.height = 12;
        return s;
    }();
    try {
        const nephele::fly::Flight f =
            nephele::fly::parseFlight(std::string(reinterpret_cast<const char*>(data), size), "fuzz_flight.json");
        // Every frame's camera: bounded by the reader's frame limit, so only short flights here
        // (a long one is a timeout, not a finding).
        if (f.frameCount() <= 2000) nephele::fly::flightCameras(f, scene);
    } catch (const nephele::SceneError&) {}
    return 0;
}
