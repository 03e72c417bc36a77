// Small settings for the tests of the layered sky and of SkyRenderer (issue #39: one factory
// instead of a copy in each file). Small textures keep the precomputation in milliseconds; the
// geometry and the periods are the real ones.
#pragma once

#include "nephele/layered.hpp"
#include "nephele/sky.hpp"
#include "test_build.hpp"

#include <cstdlib>
#include <string>

namespace nephele::test {

// The layers' lighting cache shared by every test of one ctest run: NEPHELE_TEST_CACHE, which
// tests/CMakeLists.txt sets and empties before the run (the fixture TestCacheReset), so that a
// lighting volume is traced once per run and never comes from an earlier build. "" when a test
// binary runs by hand: the test then keeps its own.
inline std::string runCacheDir() {
    const char* dir = std::getenv("NEPHELE_TEST_CACHE");
    return dir && *dir ? dir : "";
}
// The run's cache, else `own` (the test's own folder).
inline std::string runCacheDirOr(const std::string& own) { return runCacheDir().empty() ? own : runCacheDir(); }

// The library's default lighting volume (256 x 256 x 32 texels, 2^13 photons: about 0.3 s in
// release), for tests whose job must still be running in the frames right after the change that
// queued it. Under the sanitizers, where every part of it is several times slower, with 2^11
// photons: still running then (the tests that use it assert that it is).
inline LightingSettings busyLighting() {
    LightingSettings l;
    if (kSanitized) l.photons = 1 << 11;
    return l;
}

// `s` with a lighting volume of `lightingSide` x `lightingSide` x 8 texels (the default
// 256 x 256 x 32) traced with 2^11 photons (the default 2^13: the photons are most of a
// volume's time, and the light's noise is not what these tests measure) and a modulation
// texture of `modulationSize`^2 (the default 512^2).
inline LayeredSettings withSmallTextures(LayeredSettings s, int modulationSize = 128, int lightingSide = 32) {
    s.lighting.width = s.lighting.height = lightingSide, s.lighting.depth = 8, s.lighting.photons = 1 << 11;
    s.modulation.size = modulationSize;
    return s;
}
inline LayeredSettings smallLayered(int modulationSize = 128, int lightingSide = 32) {
    return withSmallTextures(LayeredSettings{}, modulationSize, lightingSide);
}

// `s` with radiance grids of 8^3 voxels and 4096 photons, for tests that do not measure the
// clouds' light (a full grid per cloud is most of their CPU).
inline EllipsoidSettings withSmallGrids(EllipsoidSettings s = {}) {
    s.light.size = 8;
    s.light.sunPhotons = s.light.skyPhotons = 4096;
    return s;
}

// SkyRenderer's settings (auto's) with small textures and small radiance grids (the light's
// accuracy is not what these tests measure).
inline SkySettings smallSky() {
    SkySettings s;
    s.layered = withSmallTextures(s.layered);
    s.ellipsoid = withSmallGrids(s.ellipsoid);
    return s;
}

}  // namespace nephele::test
