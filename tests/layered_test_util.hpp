// Small settings for the tests of the layered sky and of SkyRenderer (issue #39: one factory
// instead of a copy in each file). Small textures keep the precomputation in milliseconds; the
// geometry and the periods are the real ones.
#pragma once

#include "nephele/layered.hpp"
#include "nephele/sky.hpp"

namespace nephele::test {

// `s` with a lighting volume of `lightingSide` x `lightingSide` x 8 texels (the default
// 256 x 256 x 32) and a modulation texture of `modulationSize`^2 (the default 512^2).
inline LayeredSettings withSmallTextures(LayeredSettings s, int modulationSize = 128, int lightingSide = 32) {
    s.lighting.width = s.lighting.height = lightingSide, s.lighting.depth = 8;
    s.modulation.size = modulationSize;
    return s;
}
inline LayeredSettings smallLayered(int modulationSize = 128, int lightingSide = 32) {
    return withSmallTextures(LayeredSettings{}, modulationSize, lightingSide);
}

// SkyRenderer's settings (auto's) with small textures, and radiance grids of 8^3 voxels and 4096
// photons (the light's accuracy is not what these tests measure).
inline SkySettings smallSky() {
    SkySettings s;
    s.layered = withSmallTextures(s.layered);
    s.ellipsoid.light.size = 8;
    s.ellipsoid.light.sunPhotons = s.ellipsoid.light.skyPhotons = 4096;
    return s;
}

}  // namespace nephele::test
