// The clouds' radiance grids (nephele/cloud_radiance.hpp), computed once and kept while what
// they depend on stays. A cloud's light does not change when the cloud is translated (the sun
// is directional and the sky the same everywhere), so a cloud drifting with the wind, or a
// near-LOD cell that stays near, keeps its grid, moved with it.
#pragma once

#include "nephele/cloud_radiance.hpp"

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

namespace nephele {

// A cloud's grid where the cloud is now: world = the grid's world coordinates + offset.
struct PlacedRadiance {
    std::shared_ptr<const CloudRadiance> grid;
    Vec3 offset{0.0};
    Vec3 boxMin() const { return grid->boxMin + offset; }
    RadianceSample sample(const Vec3& world) const { return sampleRadiance(*grid, world - offset); }
};

class CloudRadianceCache {
public:
    // One grid per scene cloud, computing only those of clouds that are not a translation of
    // a cloud of the previous call (same ellipsoids relative to the cloud's first one, same sun
    // direction, sky, medium and settings). Grids not used by this call are dropped.
    // `computed` (optional) receives how many were computed.
    std::vector<PlacedRadiance> update(const Scene& scene, const RadianceGridSettings& settings, int* computed = nullptr);

private:
    struct Entry {
        std::shared_ptr<const CloudRadiance> grid;
        Vec3 anchor{0.0};  // the cloud's first ellipsoid's centre when the grid was computed
    };
    std::unordered_map<std::uint64_t, Entry> entries_;
};

}  // namespace nephele
