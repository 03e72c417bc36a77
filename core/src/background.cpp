// The host's background settings (nephele/background.hpp) applied to a worker thread.
#include "nephele/background.hpp"

#include "parallel.hpp"

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <string>
#include <thread>

namespace nephele {

void validate(const BackgroundSettings& s) {
    if (s.threads < 1 || s.threads > 256)
        throw std::invalid_argument("BackgroundSettings::threads must be 1..256, got " + std::to_string(s.threads));
    for (int cpu : s.cpus)
        if (cpu < 0 || cpu > 1023)
            throw std::invalid_argument("BackgroundSettings::cpus: " + std::to_string(cpu) + " is not a core 0..1023");
    if (s.priority != BackgroundSettings::Priority::Idle && s.priority != BackgroundSettings::Priority::Low &&
        s.priority != BackgroundSettings::Priority::Normal)
        throw std::invalid_argument("BackgroundSettings::priority is none of Idle, Low, Normal");
}

namespace {
std::atomic<int> gBackgroundTurns{0};
int backgroundTurnsAllowed() {
    static const int allowed = std::max(1, int(std::thread::hardware_concurrency()) - 1);
    return allowed;
}
}  // namespace

bool tryTakeBackgroundTurn() {
    for (int used = gBackgroundTurns.load(); used < backgroundTurnsAllowed();)
        if (gBackgroundTurns.compare_exchange_weak(used, used + 1)) return true;
    return false;
}

void giveBackgroundTurn() { gBackgroundTurns.fetch_sub(1); }

int enterBackground(const BackgroundSettings& s) {
#ifdef __linux__
    const id_t tid = id_t(syscall(SYS_gettid));
    switch (s.priority) {
        case BackgroundSettings::Priority::Idle: {
            sched_param none{};
            if (pthread_setschedparam(pthread_self(), SCHED_IDLE, &none) != 0) setpriority(PRIO_PROCESS, tid, 19);
            break;
        }
        case BackgroundSettings::Priority::Low: setpriority(PRIO_PROCESS, tid, 10); break;
        case BackgroundSettings::Priority::Normal: break;
    }
    if (!s.cpus.empty()) {
        cpu_set_t set;
        CPU_ZERO(&set);
        for (int cpu : s.cpus)
            if (cpu >= 0 && cpu < CPU_SETSIZE) CPU_SET(cpu, &set);
        // A set of cores the machine does not have is refused: the worker runs anywhere (not
        // nowhere), which the host can read back with sched_getaffinity.
        sched_setaffinity(0, sizeof set, &set);
    }
#endif
    return s.threads;
}

}  // namespace nephele
