// parallelFor(n, f): calls f(i) for i in [0, n) on all cores (rows of an image, voxels of a
// grid). Work is handed out one index at a time, so uneven rows balance. f must be
// thread-safe; exceptions are rethrown on the calling thread (the first one).
#pragma once

#include "nephele/api.hpp"
#include "nephele/background.hpp"
#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#ifdef __linux__
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

NEPHELE_API_BEGIN
namespace nephele {

// The calling thread's bound on parallelFor's workers (0: all cores). Background jobs set 1
// (ParallelLimit) so that they never take more than one core from the frame.
inline thread_local int tParallelLimit = 0;
class ParallelLimit {
public:
    explicit ParallelLimit(int workers) : previous_(tParallelLimit) { tParallelLimit = workers; }
    ~ParallelLimit() { tParallelLimit = previous_; }
    ParallelLimit(const ParallelLimit&) = delete;
    ParallelLimit& operator=(const ParallelLimit&) = delete;

private:
    int previous_;
};

// Puts the calling thread (a background worker: the clouds' radiance grids, the layers'
// lighting) where the host's BackgroundSettings say (nephele/background.hpp): its priority (by
// default SCHED_IDLE, which runs only on a core that nothing else wants; where that is refused,
// nice 19, per thread on Linux) and its cores. Threads it starts inherit both. SCHED_IDLE first
// because even a nice-19 worker takes time from the frame's threads on a loaded machine.
// Returns the number of cores a job of this thread may use (for ParallelLimit).
int enterBackground(const BackgroundSettings& settings);
inline void makeThisThreadBackground() { enterBackground(BackgroundSettings{}); }

// A background worker's turn to compute: at most one core fewer than the machine has (at least
// one) of the process's workers (the clouds' radiance grids, the layers' lighting) compute at
// once, so that background work alone never keeps every core busy: on a virtual machine whose
// host throttles it when all its cores run flat out, that costs the frame whole throttle
// periods (docs/embedding.md, "Turns"). A worker takes its turn before a job and gives it back after;
// waiting, it gives up (holds no turn) once `abandon()` is true (the job was cancelled).
bool tryTakeBackgroundTurn();  // one process-wide count, in core (shared by every library)
void giveBackgroundTurn();
class BackgroundTurn {
public:
    template <class Abandon>
    explicit BackgroundTurn(Abandon&& abandon) {
        while (!(held_ = tryTakeBackgroundTurn()))
            if (abandon()) return;
            else std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ~BackgroundTurn() {
        if (held_) giveBackgroundTurn();
    }
    BackgroundTurn(const BackgroundTurn&) = delete;
    BackgroundTurn& operator=(const BackgroundTurn&) = delete;
    bool held() const { return held_; }

private:
    bool held_ = false;
};

template <class F>
void parallelFor(int n, F&& f) {
    const int cores = tParallelLimit > 0 ? tParallelLimit : int(std::thread::hardware_concurrency());
    const int workers = std::max(1, std::min<int>(n, cores));
    std::atomic<int> next{0};
    std::exception_ptr error;
    std::mutex errorMutex;
    auto work = [&] {
        for (int i; (i = next.fetch_add(1)) < n;) {
            try {
                f(i);
            } catch (...) {
                std::lock_guard lock(errorMutex);
                if (!error) error = std::current_exception();
                next = n;
            }
        }
    };
    std::vector<std::thread> threads;
    for (int t = 1; t < workers; ++t) threads.emplace_back(work);
    work();
    for (auto& t : threads) t.join();
    if (error) std::rethrow_exception(error);
}

}  // namespace nephele
NEPHELE_API_END
