// Reading input files safely: the one helper the scene loader, the OBJ reader, the image
// readers of `compare` and the shader loader use.
//
// A file is opened without blocking (O_NONBLOCK: a FIFO without a writer, a terminal or a
// device never blocks the caller), its type is checked with fstat (only regular files are
// read: /dev/zero, a FIFO or a directory is refused at once) and its size against a limit
// before a byte is read; reading stops one byte past the limit if the file grows meanwhile.
#pragma once

#include "nephele/api.hpp"
#include "nephele/limits.hpp"

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

NEPHELE_API_BEGIN
namespace nephele::detail {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

struct OpenedFile {
    FilePtr file;            // binary, positioned at the start; null on failure
    std::uint64_t size = 0;  // bytes, from fstat
    std::string fault;       // on failure: "cannot open: No such file or directory",
                             // "is a FIFO, not a regular file", "is 300000000 bytes, over the limit ..."
};

// Opens `path` for reading if it is a regular file of at most maxBytes.value bytes. Faults
// name `subject` when it is given ("cannot open 'mesh.obj': ...", "'mesh.obj' is a FIFO, ...").
OpenedFile openRegularFile(const std::string& path, const Limit& maxBytes, const std::string& subject = "");

// Reads the whole of `path` (as openRegularFile) into *out. Returns the fault, or nothing.
std::optional<std::string> readRegularFile(const std::string& path, const Limit& maxBytes, std::string* out,
                                           const std::string& subject = "");

// The fault of a text file that holds a NUL byte ("contains a NUL byte at line 3, column 7:
// not a text file"), or nothing when it holds none.
std::optional<std::string> nulByteFault(std::string_view text);

}  // namespace nephele::detail
NEPHELE_API_END
