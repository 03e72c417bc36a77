// parallelFor(n, f): calls f(i) for i in [0, n) on all cores (rows of an image, voxels of a
// grid). Work is handed out one index at a time, so uneven rows balance. f must be
// thread-safe; exceptions are rethrown on the calling thread (the first one).
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace nephele {

template <class F>
void parallelFor(int n, F&& f) {
    const int workers = std::max(1, std::min<int>(n, int(std::thread::hardware_concurrency())));
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
