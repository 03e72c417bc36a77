// The library's log and progress callbacks (nephele/log.hpp): silent by default, and what a
// host installs receives every message, including the lighting cache's warnings.
#include "nephele/layered.hpp"
#include "nephele/log.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace nephele;

namespace {
struct Captured {
    std::vector<std::pair<LogLevel, std::string>> messages;
};

// Installs a capturing callback for the test's lifetime and restores the previous one.
class LogCapture {
public:
    LogCapture() {
        previous_ =
            setLogCallback([this](LogLevel l, std::string_view m) { got.messages.emplace_back(l, std::string(m)); });
    }
    ~LogCapture() { setLogCallback(previous_); }
    Captured got;

private:
    LogCallback previous_;
};
}  // namespace

TEST(LogTest, SilentWithoutCallbackAndDeliversWithOne) {
    const LogCallback before = setLogCallback({});
    logMessage(LogLevel::Warning, "nobody hears this");  // must not crash or print
    {
        LogCapture capture;
        logMessage(LogLevel::Info, "hello");
        logMessage(LogLevel::Error, "bad");
        ASSERT_EQ(capture.got.messages.size(), 2u);
        EXPECT_EQ(capture.got.messages[0].first, LogLevel::Info);
        EXPECT_EQ(capture.got.messages[0].second, "hello");
        EXPECT_EQ(capture.got.messages[1].first, LogLevel::Error);
    }
    setLogCallback(before);
    EXPECT_STREQ(logLevelName(LogLevel::Warning), "warning");
}

TEST(LogTest, ThrowingCallbackIsContained) {
    const LogCallback before = setLogCallback([](LogLevel, std::string_view) { throw std::runtime_error("host bug"); });
    EXPECT_NO_THROW(logMessage(LogLevel::Warning, "x"));
    const ProgressCallback beforeProgress = setProgressCallback([](std::string_view, double) { throw 1; });
    EXPECT_NO_THROW(reportProgress("x", 0.5));
    setProgressCallback(beforeProgress);
    setLogCallback(before);
}

// A damaged lighting cache is reported through the host's callback, not stderr.
TEST(LogTest, DamagedLightingCacheWarnsThroughTheCallback) {
    const std::filesystem::path dir = std::filesystem::path(NEPHELE_TEST_OUTPUT) / "log_test_cache";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    LightingSettings s;
    s.width = s.height = 16;
    s.depth = 4;
    LightingParameters p;
    (void)lightingCached(s, p, dir.string());  // writes the cache
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(dir)) files.push_back(e.path());
    ASSERT_EQ(files.size(), 1u);
    std::ofstream(files[0], std::ios::binary | std::ios::trunc) << "garbage";
    LogCapture capture;
    (void)lightingCached(s, p, dir.string());
    ASSERT_FALSE(capture.got.messages.empty());
    EXPECT_EQ(capture.got.messages[0].first, LogLevel::Warning);
    EXPECT_NE(capture.got.messages[0].second.find("cached lighting volume"), std::string::npos);
}
