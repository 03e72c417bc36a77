#include "light_cache.hpp"

#include "fingerprint.hpp"

namespace nephele {

namespace {

// The cloud's shape relative to its first ellipsoid, and everything else its light depends on.
std::uint64_t relativeKey(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& s) {
    Fingerprint f;
    f.add(s.size).add(s.sunPhotons).add(s.skyPhotons).add(s.smoothing).add(s.seed);
    f.add(scene.sun.direction).add(scene.sky.zenith).add(scene.sky.horizon).add(scene.sky.ground);
    f.addMedium(scene.medium).add(cloud.ellipsoids.size());
    const Vec3 anchor = cloud.ellipsoids.empty() ? Vec3(0.0) : cloud.ellipsoids.front().center;
    // Offsets rounded to a millimetre: (c + d) - (a + d) differs from c - a in the last bits.
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const glm::i64vec3 offset(glm::round((e.center - anchor) * 1000.0));
        f.add(offset).add(e.radii).add(e.rotationDeg).add(e.density);
    }
    return f.value();
}

}  // namespace

std::vector<PlacedRadiance> CloudRadianceCache::update(const Scene& scene, const RadianceGridSettings& settings,
                                                       int* computed) {
    std::unordered_map<std::uint64_t, Entry> used;
    std::vector<PlacedRadiance> out;
    out.reserve(scene.clouds.size());
    int made = 0;
    for (const Cloud& cloud : scene.clouds) {
        const std::uint64_t key = relativeKey(scene, cloud, settings);
        const Vec3 anchor = cloud.ellipsoids.empty() ? Vec3(0.0) : cloud.ellipsoids.front().center;
        auto it = used.find(key);
        if (it == used.end()) {
            auto old = entries_.find(key);
            if (old != entries_.end()) {
                it = used.emplace(key, std::move(old->second)).first;
                entries_.erase(old);
            } else {
                auto grid = std::make_shared<const CloudRadiance>(computeCloudRadiance(scene, cloud, settings));
                it = used.emplace(key, Entry{std::move(grid), anchor}).first;
                ++made;
            }
        }
        out.push_back({it->second.grid, anchor - it->second.anchor});
    }
    entries_ = std::move(used);
    if (computed) *computed = made;
    return out;
}

}  // namespace nephele
