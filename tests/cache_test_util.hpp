// Shared by the cache tests (the path tracer's images, the layered sky's lighting volumes):
// the log's warnings collected while a test runs, and the damage a cache file must survive.
#pragma once

#include "nephele/log.hpp"

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace nephele::test {

// Collects the warnings logged while it lives (nephele/log.hpp), then puts the previous
// callback back.
class WarningCapture {
public:
    WarningCapture()
        : before_(setLogCallback([this](LogLevel level, std::string_view m) {
              if (level == LogLevel::Warning) warnings.emplace_back(m);
          })) {}
    ~WarningCapture() { setLogCallback(before_); }
    std::vector<std::string> warnings;

private:
    LogCallback before_;
};

// Overwrites the last `bytes` bytes of `file` with `fill` (a damaged tail: the checksum must catch it).
inline void overwriteTail(const std::filesystem::path& file, std::size_t bytes, char fill) {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-std::streamoff(bytes), std::ios::end);
    f << std::string(bytes, fill);
}

// Replaces `file` with a FIFO of the same name (opening it to read would block forever).
inline bool replaceWithFifo(const std::filesystem::path& file) {
    std::filesystem::remove(file);
    return ::mkfifo(file.c_str(), 0600) == 0;
}

}  // namespace nephele::test
