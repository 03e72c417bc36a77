#include "light_cache.hpp"

#include "fingerprint.hpp"
#include "grid_erosion.hpp"
#include "parallel.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_set>

namespace nephele {

namespace {

// What a grid depends on besides the cloud's shape: the sun's direction, the sky, the medium.
void addLight(Fingerprint& f, const Scene& sceneIn) {
    const Scene scene = lightSources(sceneIn);  // Scene::lighting when set
    f.add(scene.sun.direction).add(scene.sky.zenith).add(scene.sky.horizon).add(scene.sky.ground);
    f.addMedium(scene.medium);
}

// The cloud's shape (and tile) relative to its first ellipsoid, and the grid's settings.
std::uint64_t shapeKey(const Cloud& cloud, const RadianceGridSettings& s) {
    Fingerprint f;
    f.add(s.size).add(s.fitToCloud).add(s.sunPhotons).add(s.skyPhotons).add(s.smoothing).add(s.seed);
    f.add(cloud.ellipsoids.size());
    const Vec3 anchor = cloud.ellipsoids.empty() ? Vec3(0.0) : cloud.ellipsoids.front().center;
    // Offsets rounded to a millimetre: (c + d) - (a + d) differs from c - a in the last bits.
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const glm::i64vec3 offset(glm::round((e.center - anchor) * 1000.0));
        f.add(offset).add(e.radii).add(e.rotationDeg).add(e.density);
    }
    if (cloud.tiled())
        f.add(glm::i64vec2(glm::round((cloud.tileMin - Vec2(anchor)) * 1000.0)))
            .add(glm::i64vec2(glm::round((cloud.tileMax - Vec2(anchor)) * 1000.0)));
    return f.value();
}

std::uint64_t lightKey(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& s, std::uint64_t shape) {
    Fingerprint f;
    f.add(shape);
    addLight(f, scene);
    // With the detail a grid holds the eroded cloud: it depends on the detail, and on where the
    // detail sits in the cloud (grid_erosion.hpp).
    if (scene.medium.detail.on())
        f.addDetail(scene.medium.detail).add(gridDetailOffset(scene, cloud, gridGeometry(scene, cloud, s)));
    return f.value();
}

// The share of the smaller of two boxes inside the other.
double overlap(const Vec3& loA, const Vec3& extA, const Vec3& loB, const Vec3& extB) {
    const Vec3 d = glm::max(glm::min(loA + extA, loB + extB) - glm::max(loA, loB), Vec3(0.0));
    const double smaller = std::min(extA.x * extA.y * extA.z, extB.x * extB.y * extB.z);
    return smaller > 0 ? d.x * d.y * d.z / smaller : 0;
}

}  // namespace

std::uint64_t radianceGridKey(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& settings) {
    return lightKey(scene, cloud, settings, shapeKey(cloud, settings));
}

CloudRadianceCache::~CloudRadianceCache() {
    {
        std::lock_guard lock(mutex_);
        stop_ = true;
        cancel_ = true;
    }
    wake_.notify_all();
    if (worker_.joinable()) worker_.join();
}

// A sphere of 100 m radius whose optical radius is the cloud's (to a quarter octave), lit by
// the scene's sun and sky: cheap (8^3 voxels, 4096 photons each), made once per sun and size.
std::shared_ptr<const CloudRadiance> CloudRadianceCache::templateFor(const Scene& scene, const Cloud& cloud,
                                                                     const RadianceGridSettings& s) {
    const double tau = cloudOpticalRadius(scene, cloud);
    const int step = tau > 0 ? std::clamp(int(std::lround(4 * std::log2(tau))), -12, 36) : -12;
    Fingerprint f;
    f.add(step).add(s.seed);
    addLight(f, scene);
    const std::uint64_t key = f.value();
    if (auto it = templates_.find(key); it != templates_.end()) return it->second;
    if (templates_.size() > 64) templates_.clear();  // suns of long ago
    Scene sphere = lightSources(scene);
    Cloud c;
    Ellipsoid e;
    e.radii = Vec3(100.0);
    e.density = scene.medium.extinction > 0 ? std::exp2(step / 4.0) / (scene.medium.extinction * 100.0) : 0.0;
    c.ellipsoids.push_back(e);
    RadianceGridSettings small = s;
    small.size = std::min(8, s.size);
    small.fitToCloud = false;
    small.sunPhotons = small.skyPhotons = 4096;
    auto grid = std::make_shared<const CloudRadiance>(computeCloudRadiance(sphere, c, small));
    templates_.emplace(key, grid);
    return grid;
}

// What the worker finished since the last call, into the kept grids.
void CloudRadianceCache::takeFinished(RadianceUpdateStats& stats) {
    std::lock_guard lock(mutex_);
    for (Finished& f : finished_) {
        stats.workerMs += f.entry.grid->computeMs;
        entries_[f.key] = std::move(f.entry);
        ++stats.computed;
    }
    finished_.clear();
}

// Per scene cloud: its keys, its grid's box, and its rank (its size on screen from `eye`).
std::vector<CloudRadianceCache::Want> CloudRadianceCache::wants(const Scene& scene, const RadianceGridSettings& s,
                                                                const Vec3* eye) const {
    std::vector<Want> out(scene.clouds.size());
    for (std::size_t i = 0; i < out.size(); ++i) {
        Want& w = out[i];
        w.shape = shapeKey(scene.clouds[i], s);
        w.key = lightKey(scene, scene.clouds[i], s, w.shape);
        Vec3 hi;
        radianceBox(scene.clouds[i], w.lo, hi);
        w.extent = glm::max(hi - w.lo, Vec3(1.0));
        if (eye) {  // its size on screen: 1 inside, falling as 1 / distance outside
            const double r = 0.5 * glm::length(w.extent);
            const double d = glm::length(glm::max(glm::max(w.lo - *eye, *eye - (w.lo + w.extent)), Vec3(0.0)));
            w.priority = r / (r + d);
        }
        if (entries_.count(w.key)) w.priority *= 1.5;  // a kept grid stays kept at the budget's edge
    }
    return out;
}

// The budget: the grids of the clouds largest on screen (clouds of one shape share one). Past
// it (at least one grid), the clouds smaller on screen keep a stand-in. A kept grid tells its
// size; only a missing one's is worked out from its cloud.
std::unordered_set<std::uint64_t> CloudRadianceCache::owned(const Scene& scene, const RadianceGridSettings& s,
                                                            const std::vector<Want>& wants,
                                                            const std::vector<std::size_t>& order) const {
    std::unordered_set<std::uint64_t> own;
    double bytes = 0;
    for (std::size_t i : order) {
        if (own.count(wants[i].key)) continue;
        const auto kept = entries_.find(wants[i].key);
        const int size = kept != entries_.end() ? kept->second.grid->size : radianceGridSize(scene, scene.clouds[i], s);
        const double b = double(radianceGridBytes(size));
        if (!own.empty() && bytes + b > s.megabytes * 1048576.0) break;
        own.insert(wants[i].key);
        bytes += b;
    }
    return own;
}

// The grid cloud i had in the last call: found by its noiseId when it has one (a near-LOD
// cloud's place in scene.clouds changes as cells before it come and go), else by its index.
const PlacedRadiance* CloudRadianceCache::previousOf(const Scene& scene, std::size_t i) const {
    std::size_t last = i;
    if (const std::uint64_t id = scene.clouds[i].noiseId) {
        const auto it = previousById_.find(id);
        if (it == previousById_.end()) return nullptr;
        last = it->second;
    }
    return last < previous_.size() && previous_[last].grid ? &previous_[last] : nullptr;
}

std::vector<PlacedRadiance> CloudRadianceCache::update(const Scene& scene, const RadianceGridSettings& s,
                                                       const Vec3* eye, RadianceUpdateStats* statsOut,
                                                       bool takeFinishedGrids) {
    RadianceUpdateStats stats;
    if (takeFinishedGrids) takeFinished(stats);
    const std::size_t n = scene.clouds.size();
    const std::vector<Want> want = wants(scene, s, eye);
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t(0));
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return want[a].priority > want[b].priority; });
    const std::unordered_set<std::uint64_t> own = owned(scene, s, want, order);

    std::unordered_map<std::uint64_t, std::uint64_t> byShape;  // shape -> key of its last grid
    for (const auto& [key, e] : entries_) byShape[e.shape] = key;
    std::unordered_map<std::uint64_t, Entry> used;
    std::vector<PlacedRadiance> out(n);
    std::vector<Job> jobs;
    std::unordered_set<std::uint64_t> missing;
    for (std::size_t i : order) {
        const Want& w = want[i];
        PlacedRadiance& p = out[i];
        p.lo = w.lo, p.extent = w.extent;
        const bool isOwned = own.count(w.key) > 0;
        auto exact = used.find(w.key);
        if (exact == used.end() && isOwned)
            if (auto it = entries_.find(w.key); it != entries_.end()) exact = used.emplace(w.key, it->second).first;
        if (exact != used.end() && isOwned) {
            p.grid = exact->second.grid;
            continue;
        }
        if (isOwned && !s.background) {  // made now
            const Entry e{std::make_shared<const CloudRadiance>(computeCloudRadiance(scene, scene.clouds[i], s)),
                          w.shape};
            p.grid = used.emplace(w.key, e).first->second.grid;
            ++stats.computed;
            continue;
        }
        p.exact = false;
        ++stats.standIns;
        if (!isOwned) {
            ++stats.overBudget;
        } else if (missing.insert(w.key).second) {
            Job job{w.key, w.shape, w.priority, Scene{}, s};
            job.scene = lightSources(scene);
            job.scene.clouds = {scene.clouds[i]};
            jobs.push_back(std::move(job));
        }
        if (auto it = byShape.find(w.shape); it != byShape.end() && isOwned) {
            p.grid = used.emplace(it->second, entries_.at(it->second)).first->second.grid;  // kept while it stands in
        } else if (const PlacedRadiance* last = previousOf(scene, i);
                   isOwned && last && overlap(last->lo, last->extent, w.lo, w.extent) > 0.5) {
            p.grid = last->grid;
        } else {
            p.grid = templateFor(scene, scene.clouds[i], s);
        }
    }
    entries_ = std::move(used);
    previous_ = out;
    previousById_.clear();
    for (std::size_t i = 0; i < n; ++i)
        if (scene.clouds[i].noiseId) previousById_[scene.clouds[i].noiseId] = i;
    schedule(std::move(jobs));
    {
        std::lock_guard lock(mutex_);
        stats.pending = int(queue_.size()) + (running_ != 0 ? 1 : 0);
    }
    if (statsOut) *statsOut = stats;
    return out;
}

// The worker's queue becomes `jobs` (what is still missing, by priority); a grid in progress
// that is no longer wanted is cancelled.
void CloudRadianceCache::schedule(std::vector<Job> jobs) {
    {
        std::lock_guard lock(mutex_);
        const bool runningWanted =
            std::any_of(jobs.begin(), jobs.end(), [&](const Job& j) { return j.key == running_; });
        if (running_ != 0 && !runningWanted) cancel_ = true;
        std::erase_if(jobs, [&](const Job& j) { return j.key == running_; });
        // A grid finished but not yet taken (a channel's draw does not take them: the host's next
        // update does) is not made again.
        std::erase_if(jobs, [&](const Job& j) {
            return std::any_of(finished_.begin(), finished_.end(), [&](const Finished& f) { return f.key == j.key; });
        });
        queue_ = std::move(jobs);
        if (!queue_.empty() && !worker_.joinable())
            worker_ = std::thread([this, w = queue_.front().settings.backgroundWork] { work(w); });
    }
    wake_.notify_all();
}

void CloudRadianceCache::work(BackgroundSettings settings) {
    // By default below the frame's threads, on one core: the grids come later, the frames stay on time.
    const ParallelLimit cores(enterBackground(settings));
    std::unique_lock lock(mutex_);
    for (;;) {
        wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        Job job = takeBest();
        running_ = job.key;
        cancel_ = false;
        lock.unlock();
        std::shared_ptr<const CloudRadiance> grid;
        if (const BackgroundTurn turn([&] { return cancel_.load(); }); turn.held())
            grid = std::make_shared<const CloudRadiance>(
                computeCloudRadiance(job.scene, job.scene.clouds[0], job.settings, &cancel_));
        lock.lock();
        running_ = 0;
        if (!cancel_ && grid && grid->size > 0) finished_.push_back({job.key, Entry{std::move(grid), job.shape}});
        idle_.notify_all();
        if (queue_.empty() && settings.onIdle) {  // told without the lock: it may ask pending()
            lock.unlock();
            settings.onIdle();
            lock.lock();
        }
    }
}

int CloudRadianceCache::pending() {
    std::lock_guard lock(mutex_);
    return int(queue_.size()) + (running_ != 0 ? 1 : 0);
}

CloudRadianceCache::Job CloudRadianceCache::takeBest() {
    auto best = std::max_element(queue_.begin(), queue_.end(),
                                 [](const Job& a, const Job& b) { return a.priority < b.priority; });
    Job job = std::move(*best);
    queue_.erase(best);
    return job;
}

void CloudRadianceCache::waitIdle() {
    std::unique_lock lock(mutex_);
    for (;;) {
        if (stop_) return;
        if (!queue_.empty()) {  // help: nothing cancels these (schedule() runs on this thread)
            Job job = takeBest();
            lock.unlock();
            auto grid = std::make_shared<const CloudRadiance>(
                computeCloudRadiance(job.scene, job.scene.clouds[0], job.settings));
            lock.lock();
            if (grid->size > 0) finished_.push_back({job.key, Entry{std::move(grid), job.shape}});
            continue;
        }
        if (running_ == 0) return;
        idle_.wait(lock, [&] { return stop_ || running_ == 0 || !queue_.empty(); });
    }
}

}  // namespace nephele
