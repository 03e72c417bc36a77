// Internal: what the image files of core (PFM) and of platform (PNG) share.
#pragma once

#include "nephele/api.hpp"
#include "nephele/image.hpp"

#include "input_file.hpp"

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

NEPHELE_API_BEGIN
namespace nephele::detail {

// For writing (reading goes through openImage).
inline FilePtr openFile(const std::string& path, const char* mode) {
    FILE* f = std::fopen(path.c_str(), mode);
    if (!f) throw ImageError(path + ": cannot open: " + std::strerror(errno));
    return FilePtr(f);
}

inline void checkShape(const Image& image, const std::string& path) {
    if (image.width <= 0 || image.height <= 0 ||
        image.pixels.size() != std::size_t(image.width) * image.height * image.channels)
        throw ImageError(path + ": image has no pixels or an inconsistent size");
}

// Opens an image file for reading: a regular file of at most limits::kImageFileBytes, else
// ImageError naming the path.
OpenedFile openImage(const std::string& path);

// Checks a claimed image size (w x h pixels, rawBytes of pixel data) against the limits and
// the file's size before the image is allocated; `compressed` allows deflate's expansion.
// Throws ImageError naming the path.
void checkClaimedSize(const std::string& path, std::uint64_t w, std::uint64_t h, std::uint64_t rawBytes,
                      std::uint64_t fileBytes, bool compressed);

}  // namespace nephele::detail
NEPHELE_API_END
