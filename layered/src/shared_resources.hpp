// What layers with the same parameters share (issue #14: each layer cost ~30 MB, 100 layers of
// a 9 KB file 3.1 GB): one lighting volume per (LightingSettings, LightingParameters) and one
// modulation texture per (ModulationSettings, seed), held by shared_ptr. A process-wide pool
// keeps weak references, so the layered renderer and the near LOD (and several renderers) hold
// one copy while any of them uses it, and it is freed when none does.
#pragma once

#include "nephele/layered.hpp"

#include <memory>
#include <string>

namespace nephele::detail {

// The layer's lighting volume: shared when another holder has it, else lightingCached()
// (`*computedMs` gets its precomputeMs when it was computed here, else 0).
std::shared_ptr<const LightingVolume> sharedLighting(const LightingSettings& settings, const LightingParameters& parameters,
                                                     const std::string& cacheDir, double* computedMs = nullptr);
// The layer's modulation texture: shared when another holder has it, else makeModulation().
std::shared_ptr<const ModulationTexture> sharedModulation(const ModulationSettings& settings, unsigned seed);

// Bytes of a modulation texture with its GL copy and mipmaps (RG32F).
std::uint64_t modulationBytes(const ModulationSettings& settings);

}  // namespace nephele::detail
