// The library's cache files (the path tracer's images, the layered sky's lighting volumes):
// written atomically with a checksum, read only from regular files, never blocking, and
// verified before anything in them is used.
#pragma once

#include "nephele/api.hpp"
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

NEPHELE_API_BEGIN
namespace nephele::cache {

// Writes `payload` followed by its checksum (the 64-bit FNV-1a of core/internal/fingerprint.hpp, 8
// bytes, little-endian) to `file`: through a temporary created exclusively beside it
// (FILE.tmp-XXXXXX, never through a link) that is renamed into place. Something other than a
// regular file at `file` (a folder, a FIFO, a device) is left alone. Returns "" when written,
// else why not (the caller warns through nephele/log.hpp and goes on without the cache).
std::string write(const std::string& file, std::string_view payload);

// The payload of `file` when it is a regular file of at most maxBytes whose checksum matches.
// Otherwise nullopt, with `why` empty when there is no file, else saying what is wrong (not a
// regular file, too large, truncated, checksum mismatch). Opens without blocking (a FIFO put
// in its place does not hang the caller).
std::optional<std::string> read(const std::string& file, std::size_t maxBytes, std::string& why);

}  // namespace nephele::cache
NEPHELE_API_END
