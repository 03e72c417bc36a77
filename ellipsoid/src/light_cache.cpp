#include "nephele/light_cache.hpp"

#include "nephele/fingerprint.hpp"

namespace nephele {

namespace {

// The cloud's shape relative to its first ellipsoid, and everything else its light depends on.
std::uint64_t relativeKey(const Scene& scene, const Cloud& cloud, int size) {
    Fingerprint f;
    f.add(size).add(scene.sun.direction).addMedium(scene.medium).add(cloud.ellipsoids.size());
    const Vec3 anchor = cloud.ellipsoids.empty() ? Vec3(0.0) : cloud.ellipsoids.front().center;
    // Offsets rounded to a millimetre: (c + d) - (a + d) differs from c - a in the last bits.
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const glm::i64vec3 offset(glm::round((e.center - anchor) * 1000.0));
        f.add(offset).add(e.radii).add(e.rotationDeg).add(e.density);
    }
    return f.value();
}

}  // namespace

std::vector<CloudLight> CloudLightCache::lights(const Scene& scene, int size, int* computed) {
    std::unordered_map<std::uint64_t, Entry> used;
    std::vector<CloudLight> out;
    out.reserve(scene.clouds.size());
    int made = 0;
    for (const Cloud& cloud : scene.clouds) {
        const std::uint64_t key = relativeKey(scene, cloud, size);
        const Vec3 anchor = cloud.ellipsoids.empty() ? Vec3(0.0) : cloud.ellipsoids.front().center;
        auto it = used.find(key);
        if (it == used.end()) {
            auto old = entries_.find(key);
            if (old != entries_.end()) {
                it = used.emplace(key, std::move(old->second)).first;
                entries_.erase(old);
            } else {
                Scene one;  // the light of one cloud depends on the sun, the medium and that cloud only
                one.sun = scene.sun;
                one.medium = scene.medium;
                one.clouds = {cloud};
                it = used.emplace(key, Entry{std::move(makeCloudLights(one, size).front()), anchor}).first;
                ++made;
            }
        }
        CloudLight light = it->second.light;
        light.boxMin += anchor - it->second.anchor;
        out.push_back(std::move(light));
    }
    entries_ = std::move(used);
    if (computed) *computed = made;
    return out;
}

}  // namespace nephele
