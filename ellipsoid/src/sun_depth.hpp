// Optical depths towards the sun through one cloud, for its light volume and gardner-exact,
// in time that grows with the ellipsoids a ray meets rather than with the cloud's size.
#pragma once

#include "nephele/scene.hpp"

#include <cstdint>
#include <vector>

namespace nephele::detail {

class SunDepthIndex {
public:
    // `sun`: unit, towards the sun.
    SunDepthIndex(const Cloud& cloud, const Vec3& sun);

    // Sum over the cloud's ellipsoids of density * model::segmentDepth from `from` towards the
    // sun, bit for bit what the sum over all of them gives: an ellipsoid is left out only when
    // the sun ray passes it at more than 1.01 times its largest radius, where its term is
    // exactly 0, and the others are added in the cloud's order.
    double depth(const Vec3& from) const;

private:
    struct Entry {
        glm::dmat3 unit;  // diag(1/r) R^T
        Vec3 center;
        double density, reach;  // reach: 1.01 * the largest radius, m
    };
    std::vector<Entry> entries_;  // in the cloud's order
    Vec3 sun_, u_, v_;            // the sun and the plane across it
    double u0_ = 0, v0_ = 0, cell_ = 1;
    int nu_ = 0, nv_ = 0;
    std::vector<std::uint32_t> first_, items_;  // per cell of the plane: the entries whose shadow covers it
};

}  // namespace nephele::detail
