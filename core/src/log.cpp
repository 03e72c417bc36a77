#include "nephele/log.hpp"

#include <mutex>
#include <utility>

namespace nephele {

namespace {
std::mutex& logMutex() {
    static std::mutex m;
    return m;
}
LogCallback& callbackSlot() {
    static LogCallback c;
    return c;
}
ProgressCallback& progressSlot() {
    static ProgressCallback c;
    return c;
}
}  // namespace

const char* logLevelName(LogLevel level) {
    switch (level) {
        case LogLevel::Debug: return "debug";
        case LogLevel::Info: return "info";
        case LogLevel::Warning: return "warning";
        case LogLevel::Error: return "error";
    }
    return "?";
}

LogCallback setLogCallback(LogCallback callback) {
    std::lock_guard lock(logMutex());
    return std::exchange(callbackSlot(), std::move(callback));
}

void logMessage(LogLevel level, std::string_view message) {
    std::lock_guard lock(logMutex());
    if (!callbackSlot()) return;
    try {
        callbackSlot()(level, message);
    } catch (...) {}
}

ProgressCallback setProgressCallback(ProgressCallback callback) {
    std::lock_guard lock(logMutex());
    return std::exchange(progressSlot(), std::move(callback));
}

void reportProgress(std::string_view label, double fraction) {
    std::lock_guard lock(logMutex());
    if (!progressSlot()) return;
    try {
        progressSlot()(label, fraction);
    } catch (...) {}
}

}  // namespace nephele
