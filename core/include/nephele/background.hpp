// How Nephele's background workers run: the one that makes the clouds' radiance grids and the
// one that makes the layers' lighting and modulation (docs/embedding.md, "Background work").
// A host sets it once (SkySettings::background); each worker applies it to itself when it
// starts.
#pragma once

#include "nephele/api.hpp"

#include <functional>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

struct BackgroundSettings {
    enum class Priority {
        Idle,    // SCHED_IDLE (runs only on a core nothing else wants; where refused, nice 19)
        Low,     // nice 10: below the host's threads, but it runs on a loaded machine
        Normal,  // the priority of the thread that started the worker (the host's)
    };
    Priority priority = Priority::Idle;
    // Cores one job may use at once (a grid's photons, a layer's lighting are traced in
    // parallel), 1..256. More finishes each job sooner and takes more from the frame.
    int threads = 1;
    // The cores the workers may run on (sched_setaffinity; each 0..1023); empty: any.
    std::vector<int> cpus;
    // Called on a worker thread when that worker has nothing left to do after a job (SkyRenderer
    // calls the host's once nothing is pending anywhere: see SkyRenderer::pending). Keep it
    // short and thread-safe; it must not call back into the renderer's GL side.
    std::function<void()> onIdle;
};

// Throws std::invalid_argument naming the field (threads outside 1..256, a cpu outside 0..1023).
void validate(const BackgroundSettings& settings);

}  // namespace nephele
NEPHELE_API_END
