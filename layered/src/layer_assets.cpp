#include "layer_assets.hpp"

#include "parallel.hpp"

#include <algorithm>
#include <cmath>

namespace nephele {

namespace {
constexpr std::size_t kCapacity = 12;  // entries kept (a lighting volume is 8 MB at the default size)
}  // namespace

LayerAssets::LayerAssets(LayeredSettings settings) : settings_(std::move(settings)) {}

LayerAssets::~LayerAssets() {
    {
        std::lock_guard lock(mutex_);
        stop_ = true;
        queue_.clear();
    }
    cancel_ = true;  // a host closing down does not wait for a lighting volume it will not draw
    changed_.notify_all();
    if (worker_.joinable()) worker_.join();
}

void LayerAssets::setBackground(bool background) {
    std::lock_guard lock(mutex_);
    background_ = background;
}

std::shared_ptr<LayerAssets::Entry> LayerAssets::request(bool isLight, const LightingParameters& parameters,
                                                         unsigned seed) {
    std::unique_lock lock(mutex_);
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
    auto it = std::find_if(entries_.begin(), entries_.end(), [&](const std::shared_ptr<Entry>& e) {
        return e->isLight == isLight && (isLight ? e->parameters == parameters : e->seed == seed);
    });
    std::shared_ptr<Entry> entry;
    if (it != entries_.end()) {
        entry = *it;
        entries_.erase(it);
    } else {
        entry = std::make_shared<Entry>();
        entry->isLight = isLight;
        entry->parameters = parameters;
        entry->seed = seed;
    }
    entry->lastUse = ++clock_;
    entries_.push_back(entry);
    // Least recently used first; the one just asked for, those with a job and those whose data a
    // renderer still holds (dropping them frees nothing: a scene with more distinct layers than
    // kCapacity would compute them again every frame) stay.
    auto held = [](const Entry& e) { return e.light.use_count() > 1 || e.texture.use_count() > 1; };
    for (auto e = entries_.begin(); e != entries_.end() && entries_.size() > kCapacity;)
        e = *e == entry || (*e)->queued || held(**e) ? e + 1 : entries_.erase(e);
    if (entry->done || entry->queued) return entry;
    if (!background_) {
        compute(*entry, lock);
        if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
        return entry;
    }
    entry->queued = true;
    // A modulation texture goes before the lighting volumes queued: until it is made a layer is
    // drawn with its pattern at a quarter of the resolution (nearestModulation), which is further
    // from it than the stand-in for its light, a nearby thickness's; and it takes a fraction of a
    // volume's time.
    if (isLight) queue_.push_back(entry);
    else queue_.insert(std::find_if(queue_.begin(), queue_.end(), [](const auto& e) { return e->isLight; }), entry);
    if (!worker_.joinable()) worker_ = std::thread([this] { run(); });
    changed_.notify_all();
    return entry;
}

void LayerAssets::compute(Entry& e, std::unique_lock<std::mutex>& lock) {
    const bool isLight = e.isLight;
    const LightingParameters parameters = e.parameters;
    const unsigned seed = e.seed;
    lock.unlock();
    std::shared_ptr<const LightingVolume> light;
    std::shared_ptr<const ModulationTexture> texture;
    std::exception_ptr error;
    try {
        if (isLight)
            light = std::make_shared<const LightingVolume>(
                lightingCached(settings_.lighting, parameters, settings_.cacheDir, &cancel_));
        else texture = std::make_shared<const ModulationTexture>(makeModulation(settings_.modulation, seed));
    } catch (const LightingCancelled&) {
        lock.lock();
        e.queued = false;
        return;
    } catch (...) {
        error = std::current_exception();
    }
    lock.lock();
    e.queued = false;
    if (error) {
        error_ = error;
        return;
    }
    e.light = light;
    e.texture = texture;
    e.done = true;
    if (light) computeMs_ += light->precomputeMs;
}

void LayerAssets::run() {
    // By default below the frame's threads, the lighting's parallelFor on this thread alone.
    const ParallelLimit cores(enterBackground(settings_.background));
    std::unique_lock lock(mutex_);
    for (;;) {
        changed_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        std::shared_ptr<Entry> e = queue_.front();
        queue_.pop_front();
        ++running_;
        lock.unlock();
        {  // the turn is given back before the host's onIdle below
            const BackgroundTurn turn([&] { return cancel_.load(); });
            lock.lock();
            if (turn.held()) compute(*e, lock);
            else e->queued = false;  // closing down
        }
        --running_;
        changed_.notify_all();
        if (queue_.empty() && settings_.background.onIdle) {  // told without the lock: it may ask pending()
            lock.unlock();
            settings_.background.onIdle();
            lock.lock();
        }
    }
}

std::shared_ptr<const LightingVolume> LayerAssets::lighting(const LightingParameters& parameters) {
    const std::shared_ptr<Entry> e = request(true, parameters, 0);
    std::lock_guard lock(mutex_);
    return e->done ? e->light : nullptr;
}

std::shared_ptr<const ModulationTexture> LayerAssets::modulation(unsigned seed) {
    const std::shared_ptr<Entry> e = request(false, {}, seed);
    std::lock_guard lock(mutex_);
    return e->done ? e->texture : nullptr;
}

std::shared_ptr<const LightingVolume> LayerAssets::nearestLighting(const LightingParameters& p) {
    if (auto exact = lighting(p)) return exact;
    auto relative = [](double a, double b) { return std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-12}); };
    std::lock_guard lock(mutex_);
    std::shared_ptr<const LightingVolume> best;
    double bestDistance = 0;
    for (const auto& e : entries_) {
        if (!e->isLight || !e->done) continue;
        const LightingParameters& q = e->parameters;
        const double d = relative(p.extinction, q.extinction) + relative(p.albedo, q.albedo) + relative(p.csG, q.csG) +
                         relative(p.thickness, q.thickness);
        if (!best || d < bestDistance) best = e->light, bestDistance = d;
    }
    return best;
}

std::shared_ptr<const ModulationTexture> LayerAssets::nearestModulation(unsigned seed) {
    if (auto exact = modulation(seed)) {
        std::lock_guard lock(mutex_);
        previews_.erase(seed);
        return exact;
    }
    {
        std::lock_guard lock(mutex_);
        if (const auto p = previews_.find(seed); p != previews_.end()) return p->second;
    }
    ModulationSettings quarter = settings_.modulation;
    quarter.size = std::max(8, quarter.size / 4);
    auto preview = std::make_shared<const ModulationTexture>(makeModulation(quarter, seed));
    std::lock_guard lock(mutex_);
    return previews_.emplace(seed, std::move(preview)).first->second;
}

int LayerAssets::pending() const {
    std::lock_guard lock(mutex_);
    return int(queue_.size()) + running_;
}

void LayerAssets::wait() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return queue_.empty() && running_ == 0; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

double LayerAssets::takeComputeMs() {
    std::lock_guard lock(mutex_);
    return std::exchange(computeMs_, 0.0);
}

}  // namespace nephele
