#include "input_file.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace nephele::detail {

namespace {

const char* typeName(mode_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a FIFO";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return nullptr;
}

std::string overLimit(const std::string& subject, std::uint64_t bytes, const Limit& maxBytes, bool atLeast = false) {
    return (subject.empty() ? "" : subject + " ") + "is " + std::string(atLeast ? "more than " : "") +
           std::to_string(bytes) + " bytes, over the limit " + limitText(maxBytes);
}

}  // namespace

OpenedFile openRegularFile(const std::string& path, const Limit& maxBytes, const std::string& subject) {
    const std::string named = subject.empty() ? "" : " " + subject;
    OpenedFile out;
    if (path.find('\0') != std::string::npos) {
        out.fault = "cannot open" + named + ": the path contains a NUL character";
        return out;
    }
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        out.fault = "cannot open" + named + ": " + std::strerror(errno);
        return out;
    }
    struct stat st {};
    if (::fstat(fd, &st) != 0) {
        out.fault = "cannot read" + named + ": " + std::strerror(errno);
        ::close(fd);
        return out;
    }
    if (!S_ISREG(st.st_mode)) {
        const char* type = typeName(st.st_mode);
        out.fault = (subject.empty() ? "" : subject + " ") +
                    (type ? std::string("is ") + type + ", not a regular file" : "is not a regular file");
        ::close(fd);
        return out;
    }
    out.size = std::uint64_t(st.st_size);
    if (double(out.size) > maxBytes.value) {
        out.fault = overLimit(subject, out.size, maxBytes);
        ::close(fd);
        return out;
    }
    out.file.reset(::fdopen(fd, "rb"));
    if (!out.file) {
        out.fault = "cannot open" + named + ": " + std::strerror(errno);
        ::close(fd);
    }
    return out;
}

std::optional<std::string> readRegularFile(const std::string& path, const Limit& maxBytes, std::string* out,
                                           const std::string& subject) {
    OpenedFile f = openRegularFile(path, maxBytes, subject);
    if (!f.file) return f.fault;
    const std::uint64_t cap = std::uint64_t(maxBytes.value);
    std::string text;
    text.reserve(std::size_t(f.size));
    char buf[1 << 16];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f.file.get())) > 0) {
        if (text.size() + n > cap) return overLimit(subject, cap, maxBytes, true);  // it grew while we read
        text.append(buf, n);
    }
    if (std::ferror(f.file.get()))
        return "cannot read" + std::string(subject.empty() ? "" : " " + subject) + ": " + std::strerror(errno);
    if (out) *out = std::move(text);
    return std::nullopt;
}

std::optional<std::string> nulByteFault(std::string_view text) {
    const std::size_t at = text.find('\0');
    if (at == std::string_view::npos) return std::nullopt;
    const std::size_t line = 1 + std::size_t(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
    const std::size_t lineStart = text.rfind('\n', at) == std::string_view::npos ? 0 : text.rfind('\n', at) + 1;
    return "contains a NUL byte at line " + std::to_string(line) + ", column " + std::to_string(at - lineStart + 1) +
           ": not a text file";
}

}  // namespace nephele::detail
