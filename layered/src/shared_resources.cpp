#include "shared_resources.hpp"

#include "nephele/fingerprint.hpp"

#include <map>
#include <mutex>

namespace nephele::detail {

namespace {

// Weak references by a fingerprint of everything the resource depends on; expired ones are
// dropped as the pool is searched.
template <class T>
class Pool {
public:
    template <class Make>
    std::shared_ptr<const T> get(std::uint64_t key, Make&& make) {
        {
            std::lock_guard lock(mutex_);
            for (auto it = entries_.begin(); it != entries_.end();) it = it->second.expired() ? entries_.erase(it) : std::next(it);
            if (auto found = entries_.find(key); found != entries_.end())
                if (auto held = found->second.lock()) return held;
        }
        std::shared_ptr<const T> made = make();  // outside the lock: a precomputation takes time
        std::lock_guard lock(mutex_);
        entries_[key] = made;
        return made;
    }

private:
    std::mutex mutex_;
    std::map<std::uint64_t, std::weak_ptr<const T>> entries_;
};

}  // namespace

std::shared_ptr<const LightingVolume> sharedLighting(const LightingSettings& s, const LightingParameters& p,
                                                     const std::string& cacheDir, double* computedMs) {
    static Pool<LightingVolume> pool;
    Fingerprint f;
    f.add(s.width).add(s.height).add(s.depth).add(s.tilePeriod).add(s.forwardConeDeg).add(s.octaves).add(s.cells).add(s.seed);
    f.add(p.extinction).add(p.albedo).add(p.csG).add(p.thickness);
    if (computedMs) *computedMs = 0;
    return pool.get(f.value(), [&] {
        auto v = std::make_shared<LightingVolume>(lightingCached(s, p, cacheDir));
        if (computedMs) *computedMs = v->precomputeMs;
        return v;
    });
}

std::shared_ptr<const ModulationTexture> sharedModulation(const ModulationSettings& s, unsigned seed) {
    static Pool<ModulationTexture> pool;
    Fingerprint f;
    f.add(s.size).add(s.period).add(s.octaves).add(s.cells).add(s.maxThreshold).add(s.glowPeriod).add(seed);
    return pool.get(f.value(), [&] { return std::make_shared<ModulationTexture>(makeModulation(s, seed)); });
}

std::uint64_t modulationBytes(const ModulationSettings& s) {
    const std::uint64_t texels = std::uint64_t(s.size) * std::uint64_t(s.size);
    return texels * 8 + texels * 8 * 4 / 3;  // the CPU copy, and the GL texture with its mipmaps
}

}  // namespace nephele::detail
