// The layered sky's entry point for the benches, out of the installed header: a host never
// calls it. Included by the command line's benches through nephele_testing_internal.
#pragma once

#include "nephele/layered.hpp"

namespace nephele {

struct LayeredBenchHooks {
    // The bench's floor (`nephele bench --layered`): the same annulus and billboard instances
    // (same vertex shader, depth test, blending) with a trivial fragment shader that fetches
    // the 2D modulation texture once and blends every fragment: the unavoidable pixel work of
    // the geometry. Call after render() with the same scene (it uses its textures).
    static LayeredStats renderFloor(LayeredRenderer& renderer, const Scene& scene, const View& view, GLuint framebuffer,
                                    double timeSeconds);
};

inline LayeredStats renderFloor(LayeredRenderer& renderer, const Scene& scene, const View& view, GLuint framebuffer,
                                double timeSeconds) {
    return LayeredBenchHooks::renderFloor(renderer, scene, view, framebuffer, timeSeconds);
}

}  // namespace nephele
