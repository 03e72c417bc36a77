// Light volumes of clouds that only moved. A cloud's sun transmittance does not change when
// the cloud is translated (the sun is directional), so a cloud drifting with the wind, or a
// near-LOD cell that stays near, needs no new volume: the cached one is moved with it.
#pragma once

#include "nephele/gardner.hpp"

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace nephele {

class CloudLightCache {
public:
    // What makeCloudLights(scene, size) returns, one per scene cloud, computing only the
    // volumes of clouds that are not a translation of a cloud of the previous call (same
    // ellipsoids relative to the cloud's first one, same sun, medium and size). Volumes not
    // used by this call are dropped. `computed` (optional) receives how many were computed.
    std::vector<CloudLight> lights(const Scene& scene, int size, int* computed = nullptr);

private:
    struct Entry {
        CloudLight light;  // as computed, box in world space at `anchor`
        Vec3 anchor{0.0};  // the first ellipsoid's centre then
    };
    std::unordered_map<std::uint64_t, Entry> entries_;
};

}  // namespace nephele
