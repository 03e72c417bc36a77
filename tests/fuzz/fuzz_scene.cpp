// libFuzzer: the scene loader on any bytes, with its `generate` expansion (bounded by the
// limits of nephele/limits.hpp). A SceneError is the expected way to fail; anything else
// (another exception, a crash, a sanitizer report, a timeout) is a finding.
#include "nephele/scene.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // Beside the shipped scenes, so that a mesh path such as "../meshes/anvil.obj" resolves.
    static const std::string file = NEPHELE_SCENES "/fuzz.json";
    try {
        nephele::parseScene(std::string(reinterpret_cast<const char*>(data), size), file);
    } catch (const nephele::SceneError&) {}
    return 0;
}
