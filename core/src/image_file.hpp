// Internal: what the image files of core (PFM) and of platform (PNG) share.
#pragma once

#include "nephele/image.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

namespace nephele::detail {

using FilePtr = std::unique_ptr<FILE, int (*)(FILE*)>;

inline FilePtr openFile(const std::string& path, const char* mode) {
    FILE* f = std::fopen(path.c_str(), mode);
    if (!f) throw ImageError(path + ": cannot open: " + std::strerror(errno));
    return FilePtr(f, &std::fclose);
}

inline void checkShape(const Image& image, const std::string& path) {
    if (image.width <= 0 || image.height <= 0 || image.pixels.size() != std::size_t(image.width) * image.height * image.channels)
        throw ImageError(path + ": image has no pixels or an inconsistent size");
}

}  // namespace nephele::detail
