// Where the library's messages go. Nephele never writes to stdout or stderr: it hands each
// message to the host's callback (none by default: the library is silent). The `nephele`
// command line installs one that prints "nephele: warning: ..." to stderr.
//
// The callback may be called from any thread the library uses (the path tracer's workers,
// background lighting jobs); calls are serialised, so it need not lock. Set it once, before
// rendering; setting it again while another thread logs is safe.
#pragma once

#include "nephele/api.hpp"
#include <functional>
#include <string_view>

NEPHELE_API_BEGIN
namespace nephele {

enum class LogLevel { Debug, Info, Warning, Error };

// Returns "debug", "info", "warning" or "error".
const char* logLevelName(LogLevel level);

using LogCallback = std::function<void(LogLevel level, std::string_view message)>;

// Installs `callback` (an empty function: no logging) and returns the previous one.
LogCallback setLogCallback(LogCallback callback);

// Sends `message` to the installed callback, if any. A callback that throws is ignored.
void logMessage(LogLevel level, std::string_view message);

// Long CPU work (the path tracer, lighting precomputation) reports its progress here, as a
// fraction in [0, 1] with a short label; none by default. The CLI draws a bar on a terminal.
using ProgressCallback = std::function<void(std::string_view label, double fraction)>;
ProgressCallback setProgressCallback(ProgressCallback callback);
void reportProgress(std::string_view label, double fraction);

}  // namespace nephele
NEPHELE_API_END
