// The clouds' radiance grids (nephele/cloud_radiance.hpp), computed once and kept while what
// they depend on stays. A cloud's light does not change when the cloud is translated (the sun
// is directional and the sky the same everywhere), so a cloud drifting with the wind, or a
// near-LOD cell that stays near, keeps its grid, moved with it.
//
// Grids are made either before the frame (waiting: a still image, a test) or progressively on
// one worker thread (RadianceGridSettings::background: a host's frame loop), nearest clouds
// first. Until its grid is ready a cloud is lit by a stand-in, and no frame waits:
//   1. the last grid of the same shape (the sun, the sky or the medium changed): the old light
//      serves until the new one is ready;
//   2. else the grid the same cloud (by Cloud::noiseId when set, else by index) had in the last
//      call, if the cloud still overlaps it (a cloud of a weather change that grew or shrank);
//   3. else the template: a sphere of the cloud's optical size, lit by the scene's sun and sky
//      (a small grid, made in a few ms and kept), stretched onto the cloud's box.
// A memory budget (RadianceGridSettings::megabytes) bounds the grids kept: past it, the clouds
// smallest on screen keep the template until they come nearer.
#pragma once

#include "nephele/api.hpp"
#include "nephele/cloud_radiance.hpp"

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// A grid where a cloud is now: the grid's box stretched onto the cloud's box (an exact grid's
// box is the cloud's own, moved with it).
struct PlacedRadiance {
    std::shared_ptr<const CloudRadiance> grid;
    Vec3 lo{0.0}, extent{1.0};  // the cloud's box (m, world) the grid covers
    bool exact = true;          // this cloud's own grid (false: a stand-in)
    Vec3 boxMin() const { return lo; }
    RadianceSample sample(const Vec3& world) const {
        return sampleRadiance(*grid, grid->boxMin + (world - lo) / extent * grid->boxExtent);
    }
};

// What a cloud's grid depends on, as one number: the cloud's shape relative to its first
// ellipsoid, the sun's direction, the sky, the medium and the settings (the cache's own key; a
// translated cloud has the same key, its grid moved with it).
std::uint64_t radianceGridKey(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& settings);

class CloudRadianceCache {
public:
    CloudRadianceCache() = default;
    ~CloudRadianceCache();  // stops the worker (its grid in progress is cancelled)
    CloudRadianceCache(const CloudRadianceCache&) = delete;
    CloudRadianceCache& operator=(const CloudRadianceCache&) = delete;

    // One placed grid per scene cloud (see above). Clouds that are a translation of a cloud of
    // an earlier call (same ellipsoids relative to its first one, same sun direction, sky,
    // medium and settings) keep its grid. Grids no call uses any more are dropped. `eye`
    // (optional) ranks the clouds for the budget and the worker: the largest on screen first.
    // Without `takeFinishedGrids` the worker's new grids wait for a later call (the channels of one
    // frame draw with the same grids).
    std::vector<PlacedRadiance> update(const Scene& scene, const RadianceGridSettings& settings,
                                       const Vec3* eye = nullptr, RadianceUpdateStats* stats = nullptr,
                                       bool takeFinishedGrids = true);
    // Blocks until the worker has nothing left to do (tests, benches, a host's loading screen);
    // the next update() uses what it made. The waiting thread makes queued grids itself
    // meanwhile, on every core at its own priority: a host that waits wants them now.
    void waitIdle();
    // Grids queued or being made (thread-safe); at 0 the next update() takes every one made.
    int pending();


private:
    struct Entry {
        std::shared_ptr<const CloudRadiance> grid;
        std::uint64_t shape = 0;  // the key without the sun, sky and medium
    };
    struct Job {
        std::uint64_t key = 0, shape = 0;
        double priority = 0;
        Scene scene;  // the sun, the sky, the medium and the one cloud
        RadianceGridSettings settings;
    };
    struct Finished {
        std::uint64_t key = 0;
        Entry entry;
    };
    struct Want {  // what one scene cloud wants this call
        std::uint64_t shape = 0, key = 0;
        Vec3 lo{0.0}, extent{1.0};
        double priority = 1;
    };
    void takeFinished(RadianceUpdateStats& stats);
    std::vector<Want> wants(const Scene& scene, const RadianceGridSettings& s, const Vec3* eye) const;
    std::unordered_set<std::uint64_t> owned(const Scene& scene, const RadianceGridSettings& s,
                                            const std::vector<Want>& wants,
                                            const std::vector<std::size_t>& order) const;
    std::shared_ptr<const CloudRadiance> templateFor(const Scene& scene, const Cloud& cloud,
                                                     const RadianceGridSettings& s);
    void schedule(std::vector<Job> jobs);
    void work(BackgroundSettings settings);
    Job takeBest();  // the queue's highest priority; with mutex_ held, the queue not empty

    std::unordered_map<std::uint64_t, Entry> entries_;
    std::unordered_map<std::uint64_t, std::shared_ptr<const CloudRadiance>> templates_;
    const PlacedRadiance* previousOf(const Scene& scene, std::size_t i) const;
    std::vector<PlacedRadiance> previous_;                         // the last call's result, by cloud index
    std::unordered_map<std::uint64_t, std::size_t> previousById_;  // Cloud::noiseId -> its index then

    std::mutex mutex_;  // guards what follows (shared with the worker)
    std::condition_variable wake_, idle_;
    std::vector<Job> queue_;
    std::uint64_t running_ = 0;  // key of the grid the worker makes (0: none)
    std::atomic<bool> cancel_{false};
    std::vector<Finished> finished_;
    bool stop_ = false;
    std::thread worker_;
};

}  // namespace nephele
NEPHELE_API_END
