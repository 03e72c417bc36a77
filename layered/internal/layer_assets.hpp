// The CPU data of the far-field layers that the layered sky and the near LOD share: lighting
// volumes (by LightingParameters: the medium and the layer's thickness; 0.3 s each, or a load
// from the cache) and modulation textures (by the layer's seed). Internal to layered/.
#pragma once

#include "nephele/api.hpp"
#include "nephele/layered.hpp"

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

class LayerAssets {
public:
    explicit LayerAssets(LayeredSettings settings);
    ~LayerAssets();  // stops the worker; the job in progress is cancelled (its photon trace stops soon)
    LayerAssets(const LayerAssets&) = delete;
    LayerAssets& operator=(const LayerAssets&) = delete;

    // false (the default): what is asked for is computed in the call. true: a request for data
    // not made yet queues a job for a worker thread (one job at a time, in order, modulation
    // textures before lighting volumes, as LayeredSettings::background says) and returns nullptr
    // until it is done, so that the frame never waits; meanwhile the caller keeps using what it
    // had (the last good result).
    void setBackground(bool background);
    bool background() const { return background_; }

    // The volume / texture, or nullptr while its job runs (background only). Rethrows the
    // failure of a job (std::exception of lightingCached or makeModulation).
    std::shared_ptr<const LightingVolume> lighting(const LightingParameters& parameters);
    std::shared_ptr<const ModulationTexture> modulation(unsigned seed);
    // As lighting() / modulation(), but while the job runs the nearest there is instead of
    // nullptr. A volume: the one made whose parameters differ least (relative differences of the
    // medium's extinction, albedo and phase and of the thickness); nullptr only while none is
    // made. A texture: the seed's own pattern at a quarter of the resolution (at least 8
    // texels), made in the call (a sixteenth of the full one's work) and kept until the full one
    // is made; about 1% of the texels fall on the other side of a threshold
    // (BackgroundTest.ANewPatternIsShownAtAQuarterOfItsResolutionUntilItIsMade). A layer is thus drawn from its first
    // frame (a new layer of a transition fades in with the light of another thickness) and never withheld, and never
    // shows another seed's clouds.
    std::shared_ptr<const LightingVolume> nearestLighting(const LightingParameters& parameters);
    std::shared_ptr<const ModulationTexture> nearestModulation(unsigned seed);

    int pending() const;  // jobs queued or running
    void wait();          // blocks until no job is left
    // CPU time (ms) of the lighting computed (not loaded) since the last call.
    double takeComputeMs();
    const LayeredSettings& settings() const { return settings_; }

private:
    struct Entry {
        bool isLight = true;
        LightingParameters parameters;
        unsigned seed = 0;
        std::shared_ptr<const LightingVolume> light;
        std::shared_ptr<const ModulationTexture> texture;
        bool done = false, queued = false;  // queued: waiting for the worker or being computed
        std::uint64_t lastUse = 0;
    };
    // The entry, made ready (synchronously) or queued (background; not ready on return).
    std::shared_ptr<Entry> request(bool isLight, const LightingParameters& parameters, unsigned seed);
    void compute(Entry& entry, std::unique_lock<std::mutex>& lock);  // unlocks while it works
    void run();

    LayeredSettings settings_;
    bool background_ = false;
    mutable std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<std::shared_ptr<Entry>> entries_;  // most recently used last
    std::deque<std::shared_ptr<Entry>> queue_;
    std::map<unsigned, std::shared_ptr<const ModulationTexture>> previews_;  // nearestModulation's, by seed
    int running_ = 0;  // jobs being computed by the worker (0 or 1)
    std::uint64_t clock_ = 0;
    double computeMs_ = 0;
    std::exception_ptr error_;
    bool stop_ = false;
    std::atomic<bool> cancel_{false};  // set by the destructor: the running job stops soon
    std::thread worker_;
};

}  // namespace nephele
NEPHELE_API_END
