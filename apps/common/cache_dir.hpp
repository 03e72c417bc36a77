// Where the path tracer's references and the layered sky's lighting volumes are cached: one
// rule for every command that caches.
#pragma once

#include <cstdlib>
#include <string>

namespace nephele::cli {

// The option's folder, else $NEPHELE_CACHE, else ~/.cache/nephele.
inline std::string defaultCacheDir(const std::string& option) {
    const char* env = std::getenv("NEPHELE_CACHE");
    const char* home = std::getenv("HOME");
    return !option.empty() ? option : env && *env ? env : home ? std::string(home) + "/.cache/nephele" : "";
}

}  // namespace nephele::cli
