#include "nephele/resources.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>

namespace nephele {

namespace {

// A "Key: N kB" line of /proc/meminfo, in bytes (0 when missing).
std::uint64_t meminfo(const char* key) {
    std::ifstream in("/proc/meminfo");
    for (std::string name; in >> name;) {
        std::uint64_t kb = 0;
        in >> kb;
        in.ignore(64, '\n');
        if (name == key) return kb * 1024;
    }
    return 0;
}

// The process's address space now (the first field of /proc/self/statm, in pages).
std::uint64_t addressSpaceUsed() {
    std::ifstream in("/proc/self/statm");
    std::uint64_t pages = 0;
    in >> pages;
    return pages * std::uint64_t(::sysconf(_SC_PAGESIZE));
}

}  // namespace

std::uint64_t availableMemoryBytes() {
    std::uint64_t bytes = meminfo("MemAvailable:");
    if (bytes == 0) bytes = std::uint64_t(::sysconf(_SC_AVPHYS_PAGES)) * std::uint64_t(::sysconf(_SC_PAGESIZE));
    struct rlimit limit;
    if (::getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) {
        const std::uint64_t used = addressSpaceUsed(), cap = limit.rlim_cur;
        bytes = std::min(bytes, cap > used ? cap - used : 0);
    }
    return bytes;
}

std::string formatBytes(std::uint64_t bytes) {
    static const char* units[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
    double v = double(bytes);
    int u = 0;
    while (v >= 1000 && u < 6) v /= 1000, ++u;
    char text[32];
    std::snprintf(text, sizeof text, u == 0 || v >= 100 ? "%.0f %s" : "%.1f %s", v, units[u]);
    return text;
}

void requireMemory(const std::string& what, std::uint64_t bytes) {
    const std::uint64_t available = availableMemoryBytes();
    if (bytes > available)
        throw ResourceError(what + " needs " + formatBytes(bytes) + " of memory, more than the " +
                            formatBytes(available) + " available");
}

}  // namespace nephele
