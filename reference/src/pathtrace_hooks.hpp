// The path tracer's counter for the tests and the accuracy bench, out of the installed header.
#pragma once

#include <cstdint>

namespace nephele::detail {
// How many images renderPathTraced has computed in this process (not read from a cache): for
// the tests and for tools that report what the cache saved.
std::uint64_t pathTracedImagesComputed();
}  // namespace nephele::detail
