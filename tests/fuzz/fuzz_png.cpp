// libFuzzer: the image readers of `nephele compare` on any bytes, through a regular in-memory
// file (memfd) as they read from disk: readPng, or readPfm for bytes that begin with 'P'.
// An ImageError is the expected way to fail.
#include "nephele/image.hpp"
#include "nephele/png.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const int fd = memfd_create("fuzz-image", 0);
    static const std::string path = "/proc/self/fd/" + std::to_string(fd);
    if (fd < 0 || ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != ssize_t(size)) return 0;
    try {
        if (size > 0 && data[0] == 'P') nephele::readPfm(path);
        else nephele::readPng(path);
    } catch (const nephele::ImageError&) {}
    return 0;
}
