#include "cache_file.hpp"

#include "fingerprint.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

namespace nephele::cache {

namespace {

constexpr std::size_t kChecksumBytes = 8;

std::string checksumBytes(std::string_view payload) {
    std::uint64_t sum = Fingerprint().bytes(payload.data(), payload.size()).value();
    std::string out(kChecksumBytes, '\0');
    for (std::size_t i = 0; i < kChecksumBytes; ++i) out[i] = char((sum >> (8 * i)) & 0xFF);
    return out;
}

bool writeAll(int fd, const char* data, std::size_t size) {
    while (size > 0) {
        const ssize_t n = ::write(fd, data, size);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        data += n, size -= std::size_t(n);
    }
    return true;
}

// Closes the descriptor when it goes out of scope.
struct Fd {
    int fd;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

}  // namespace

std::string write(const std::string& file, std::string_view payload) {
    struct stat st;
    if (::lstat(file.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
        return file + " is not a regular file; it is left alone";
    std::string temp = file + ".tmp-XXXXXX";
    Fd out{::mkostemp(temp.data(), O_CLOEXEC)};
    if (out.fd < 0) return "cannot create a file beside " + file + ": " + std::strerror(errno);
    const std::string sum = checksumBytes(payload);
    const bool ok = writeAll(out.fd, payload.data(), payload.size()) && writeAll(out.fd, sum.data(), sum.size()) &&
                    ::fsync(out.fd) == 0;
    const int closed = ::close(out.fd);
    out.fd = -1;
    if (!ok || closed != 0 || ::rename(temp.c_str(), file.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        ::unlink(temp.c_str());
        return "cannot write " + file + ": " + why;
    }
    return "";
}

std::optional<std::string> read(const std::string& file, std::size_t maxBytes, std::string& why) {
    why.clear();
    Fd in{::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
    if (in.fd < 0) {
        if (errno != ENOENT) why = std::string("cannot open: ") + std::strerror(errno);
        return std::nullopt;
    }
    struct stat st;
    if (::fstat(in.fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        why = "not a regular file";
        return std::nullopt;
    }
    const std::uint64_t size = std::uint64_t(st.st_size);
    if (size < kChecksumBytes || size - kChecksumBytes > maxBytes) {
        why = size < kChecksumBytes ? "truncated (" + std::to_string(size) + " bytes)"
                                    : "too large (" + std::to_string(size) + " bytes)";
        return std::nullopt;
    }
    std::string data(std::size_t(size), '\0');
    for (std::size_t got = 0; got < data.size();) {
        const ssize_t n = ::read(in.fd, data.data() + got, data.size() - got);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            why = n == 0 ? "truncated while read" : std::string("read failed: ") + std::strerror(errno);
            return std::nullopt;
        }
        got += std::size_t(n);
    }
    const std::string_view payload(data.data(), data.size() - kChecksumBytes);
    if (checksumBytes(payload) != data.substr(payload.size())) {
        why = "checksum mismatch (the file is damaged)";
        return std::nullopt;
    }
    data.resize(payload.size());
    return data;
}

}  // namespace nephele::cache
