#pragma once

#include <string>

namespace nephele::cli {

struct CompareOptions {
    std::string a, b;            // .png (8-bit sRGB; RGBA also gives alpha) or .pfm (linear)
    std::string alphaA, alphaB;  // optional grey opacity maps (.png stored linear, or grey .pfm)
};

// The `compare` command: prints one JSON line (see nephele::toJson) on stdout. Returns 0, 2 for
// bad input (unreadable file, unknown extension, size mismatch; the message names the file) or
// 1 for other failures. Alpha is compared when both A and B give one (file or RGBA PNG; an
// --alpha-a/--alpha-b file takes precedence over the PNG's own alpha).
int runCompare(const CompareOptions& o);

}  // namespace nephele::cli
