// The host's background settings (nephele/background.hpp) as a worker thread applies them:
// its priority, its cores and the cores of its jobs, and the settings' checks.
#include "nephele/background.hpp"

#include "layer_assets.hpp"
#include "parallel.hpp"
#include "temp_dir.hpp"

#include <gtest/gtest.h>

#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <chrono>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

using namespace nephele;

namespace {

struct ThreadState {
    int policy = -1, nice = -100, jobCores = 0, cpus = 0;
    bool onlyCpu0 = false;
};

// What a fresh thread looks like after enterBackground(s).
ThreadState applyOnAThread(const BackgroundSettings& s) {
    ThreadState out;
    std::thread t([&] {
        out.jobCores = enterBackground(s);
        out.policy = sched_getscheduler(0);
        errno = 0;
        out.nice = getpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)));
        cpu_set_t set;
        CPU_ZERO(&set);
        sched_getaffinity(0, sizeof set, &set);
        out.cpus = CPU_COUNT(&set);
        out.onlyCpu0 = CPU_ISSET(0, &set) && out.cpus == 1;
    });
    t.join();
    return out;
}

}  // namespace

// The default puts the worker on SCHED_IDLE (or nice 19 where refused), one core per job, any
// core; Low is nice 10; Normal keeps the starting thread's priority; cpus pins it.
TEST(BackgroundTest, AWorkerTakesThePriorityAndCoresItIsGiven) {
    const int parentNice = getpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)));
    const ThreadState idle = applyOnAThread(BackgroundSettings{});
    EXPECT_TRUE(idle.policy == SCHED_IDLE || idle.nice == 19) << idle.policy << " " << idle.nice;
    EXPECT_EQ(idle.jobCores, 1);

    BackgroundSettings low;
    low.priority = BackgroundSettings::Priority::Low;
    low.threads = 3;
    low.cpus = {0};
    const ThreadState l = applyOnAThread(low);
    EXPECT_EQ(l.policy, SCHED_OTHER);
    EXPECT_EQ(l.nice, std::max(parentNice, 10));
    EXPECT_EQ(l.jobCores, 3);
    EXPECT_TRUE(l.onlyCpu0) << l.cpus << " cores";

    BackgroundSettings normal;
    normal.priority = BackgroundSettings::Priority::Normal;
    const ThreadState n = applyOnAThread(normal);
    EXPECT_EQ(n.policy, SCHED_OTHER);
    EXPECT_EQ(n.nice, parentNice);
    EXPECT_GE(n.cpus, 1);
}

// The process's background workers compute one core fewer at a time than the machine has (at
// least one), so that background work alone never keeps every core busy (docs/embedding.md,
// "Turns"). A turn waited for is given up when the job is cancelled.
TEST(BackgroundTest, WorkersComputeOnCoresTheFrameLeaves) {
    const int allowed = std::max(1, int(std::thread::hardware_concurrency()) - 1);
    std::vector<std::unique_ptr<BackgroundTurn>> turns;
    for (int k = 0; k < allowed; ++k) {
        turns.push_back(std::make_unique<BackgroundTurn>([] { return false; }));
        ASSERT_TRUE(turns.back()->held()) << k;
    }
    std::atomic<int> asked{0};
    const auto t0 = std::chrono::steady_clock::now();
    const BackgroundTurn over([&] { return ++asked > 3; });
    EXPECT_FALSE(over.held()) << "a turn past " << allowed << " of " << std::thread::hardware_concurrency() << " cores";
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(1));
    turns.pop_back();  // one given back: the next worker takes it
    const BackgroundTurn next([] { return false; });
    EXPECT_TRUE(next.held());
}

TEST(BackgroundTest, BadSettingsAreNamed) {
    BackgroundSettings s;
    EXPECT_NO_THROW(validate(s));
    s.threads = 0;
    EXPECT_THROW(validate(s), std::invalid_argument);
    s.threads = 257;
    EXPECT_THROW(validate(s), std::invalid_argument);
    s.threads = 2;
    s.cpus = {0, 1024};
    try {
        validate(s);
        ADD_FAILURE() << "a core past 1023 passed";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("cpus"), std::string::npos) << e.what();
    }
    s.cpus = {-1};
    EXPECT_THROW(validate(s), std::invalid_argument);
}

// A host closing down does not wait for the layer's lighting in progress: the photon trace
// stops at its next batch, and nothing of it is cached. (Before, ~LayerAssets joined the worker
// after the whole job: about 90 s once for a low-priority worker on a loaded machine.)
TEST(BackgroundTest, ClosingCancelsTheLayersLightingInProgress) {
    LightingSettings ls;
    ls.width = ls.height = 64, ls.depth = 8;
    ls.photons = 1 << 17;  // seconds of tracing: still running when the assets close
    const LightingParameters p{0.05, 0.99, 0.85, 800};
    std::atomic<bool> cancel{true};
    EXPECT_THROW(precomputeLighting(ls, p, &cancel), LightingCancelled);

    const test::TempDir cache("nephele_cancel");
    LayeredSettings s;
    s.lighting = ls;
    s.cacheDir = cache.dir().string();
    s.background.priority = BackgroundSettings::Priority::Normal;  // starts at once, whatever the load
    {
        LayerAssets assets(s);
        assets.setBackground(true);
        EXPECT_EQ(assets.lighting(p), nullptr);
        std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the worker is tracing
        EXPECT_EQ(assets.pending(), 1);
    }
    EXPECT_TRUE(std::filesystem::is_empty(cache.dir())) << "the cancelled lighting was finished and cached";
}

// A new layer is drawn with another seed's pattern until its own modulation texture is made, so
// that texture goes before the lighting volumes queued (their stand-in, a nearby thickness's
// light, is close): asked for after two volumes, it is made while the second still waits.
TEST(BackgroundTest, ALayersPatternIsMadeBeforeTheLightingQueuedBeforeIt) {
    LightingSettings ls;
    ls.width = ls.height = 64, ls.depth = 8;
    ls.photons = 1 << 12;  // a volume takes longer than the pattern
    const test::TempDir cache("nephele_queue_order");
    LayeredSettings s;
    s.lighting = ls;
    s.modulation.size = 128;
    s.cacheDir = cache.dir().string();
    s.background.priority = BackgroundSettings::Priority::Normal;  // runs whatever the load
    LayerAssets assets(s);
    assets.setBackground(true);
    const LightingParameters first{0.05, 0.99, 0.85, 800}, second{0.05, 0.99, 0.85, 900};
    EXPECT_EQ(assets.lighting(first), nullptr);
    EXPECT_EQ(assets.lighting(second), nullptr);
    EXPECT_EQ(assets.modulation(7), nullptr);
    const auto until = std::chrono::steady_clock::now() + std::chrono::minutes(2);
    while (!assets.modulation(7) && std::chrono::steady_clock::now() < until)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    ASSERT_NE(assets.modulation(7), nullptr) << "the pattern was not made within 2 minutes";
    EXPECT_EQ(assets.lighting(second), nullptr) << "the pattern waited for the volume asked for before it";
    assets.wait();
    EXPECT_NE(assets.lighting(second), nullptr);
}

// While a seed's pattern is being made, a layer of that seed is drawn with the same pattern at a
// quarter of the resolution, made in the call: never another seed's clouds, and close to what
// replaces it (measured at 512 x 512: a mean threshold change of 0.007, 1.1% of the texels on
// the other side of a threshold of 0.4; another seed's pattern: 0.26 and 48%).
TEST(BackgroundTest, ANewPatternIsShownAtAQuarterOfItsResolutionUntilItIsMade) {
    LightingSettings ls;
    ls.width = ls.height = 64, ls.depth = 8;
    ls.photons = 1 << 12;
    const test::TempDir cache("nephele_preview");
    LayeredSettings s;
    s.lighting = ls;
    s.cacheDir = cache.dir().string();
    s.background.priority = BackgroundSettings::Priority::Normal;
    LayerAssets assets(s);
    assets.setBackground(true);
    EXPECT_EQ(assets.lighting({0.05, 0.99, 0.85, 800}), nullptr);  // the worker is busy with it
    const std::shared_ptr<const ModulationTexture> preview = assets.nearestModulation(7);
    ASSERT_NE(preview, nullptr);
    EXPECT_EQ(preview->size, s.modulation.size / 4);
    EXPECT_EQ(assets.nearestModulation(7), preview) << "made again on the next call";
    assets.wait();
    const std::shared_ptr<const ModulationTexture> full = assets.nearestModulation(7);
    ASSERT_NE(full, nullptr);
    EXPECT_EQ(full->size, s.modulation.size);
    const ModulationTexture other = makeModulation(s.modulation, 8);
    auto compare = [&](const ModulationTexture& m, double& meanChange, double& flipped) {
        const int n = full->size;
        double sum = 0, flips = 0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double a = full->texels[(std::size_t(j) * n + i) * 2],
                             b = m.sample((i + 0.5) / n, (j + 0.5) / n, 0);
                sum += std::abs(a - b), flips += (a < 0.4) != (b < 0.4);
            }
        meanChange = sum / (double(n) * n), flipped = flips / (double(n) * n);
    };
    double change = 0, flipped = 0, otherChange = 0, otherFlipped = 0;
    compare(*preview, change, flipped);
    compare(other, otherChange, otherFlipped);
    std::printf("[ figure ] preview: mean change %.4f, %.2f%% flipped; another seed: %.4f, %.1f%%\n", change,
                100 * flipped, otherChange, 100 * otherFlipped);
    EXPECT_LT(change, 0.015);
    EXPECT_LT(flipped, 0.02);
    EXPECT_GT(otherFlipped, 0.2);  // the comparison tells patterns apart
}
