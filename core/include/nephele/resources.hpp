// Memory a piece of work needs is checked before it allocates, so that a request this machine
// cannot hold ends in a message that says so (and names the setting), not in std::bad_alloc
// or the kernel's OOM killer.
#pragma once

#include "nephele/api.hpp"
#include <cstdint>
#include <stdexcept>
#include <string>

NEPHELE_API_BEGIN
namespace nephele {

// Too big for this machine or driver: memory, or a GL maximum. what() says what needed how much.
class ResourceError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Bytes available for new allocations: MemAvailable of /proc/meminfo (else the free physical
// pages), and no more than the address-space limit (RLIMIT_AS, `ulimit -v`) leaves.
std::uint64_t availableMemoryBytes();

// "3.2 GB", "512 MB", "12 kB", "100 B" (powers of 1000).
std::string formatBytes(std::uint64_t bytes);

// Throws ResourceError("WHAT needs N of memory, more than the M available") when `bytes` is more
// than availableMemoryBytes().
void requireMemory(const std::string& what, std::uint64_t bytes);

}  // namespace nephele
NEPHELE_API_END
