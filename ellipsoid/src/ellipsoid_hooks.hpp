// The compositor's entry points for the benches (and tests), out of the installed header: a
// host never calls them. Included by the command line's benches through nephele_testing_internal.
#pragma once

#include "nephele/ellipsoid.hpp"

namespace nephele {

struct EllipsoidBenchHooks {
    // The bench's floor for the same frame: the same tiles, passes and CPU work, but only
    // the unavoidable pixel work: each tile's pixels blended once per pass, and each tile's
    // screen rectangle composited once as a plain textured quad; one draw each per pass.
    static EllipsoidStats renderFloor(EllipsoidRenderer& renderer, const Scene& scene, const View& view,
                                      GLuint framebuffer);
};

inline EllipsoidStats renderFloor(EllipsoidRenderer& renderer, const Scene& scene, const View& view,
                                  GLuint framebuffer) {
    return EllipsoidBenchHooks::renderFloor(renderer, scene, view, framebuffer);
}

}  // namespace nephele
