#include "output_files.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <system_error>

namespace fs = std::filesystem;

namespace nephele::cli {

namespace {

constexpr int kMaxLinks = 32;  // as the kernel's own limit on a path's links (ELOOP at 40)

const char* kindOf(mode_t mode) {
    return S_ISDIR(mode)    ? "a folder"
           : S_ISCHR(mode)  ? "a character device"
           : S_ISBLK(mode)  ? "a block device"
           : S_ISFIFO(mode) ? "a FIFO"
           : S_ISSOCK(mode) ? "a socket"
                            : "not a regular file";
}

mode_t currentUmask() {
    const mode_t m = ::umask(0);
    ::umask(m);
    return m;
}

bool processAlive(long pid) { return ::kill(pid_t(pid), 0) == 0 || errno == EPERM; }

// "PID" or "PID-XXXXXX" after TARGET.partial-: the process id, or -1 when the name is not ours.
long partialPid(const std::string& rest) {
    std::size_t i = 0;
    while (i < rest.size() && i < 10 && rest[i] >= '0' && rest[i] <= '9') ++i;
    if (i == 0) return -1;
    const bool old = i == rest.size();  // TARGET.partial-PID, as older versions named it
    if (!old && !(rest.size() == i + 7 && rest[i] == '-')) return -1;
    return std::stol(rest.substr(0, i));
}

// The longest suffix makePartial adds: ".partial-" PID "-XXXXXX", a PID of at most 7 digits
// (Linux's PID_MAX_LIMIT is 4194304).
constexpr std::size_t kPartialSuffix = 9 + 7 + 7;

// An output whose temporary's name would pass the file system's limits is refused before
// anything is rendered (issue 38: a 254-byte name rendered, then failed to create the
// temporary).
template <class Bad>
void checkNameLength(const fs::path& p, const Bad& bad) {
    const std::size_t name = p.filename().string().size();
    long nameMax = ::pathconf(p.parent_path().c_str(), _PC_NAME_MAX);
    if (nameMax <= 0) nameMax = NAME_MAX;
    if (name + kPartialSuffix > std::size_t(nameMax))
        bad("has a name of " + std::to_string(name) + " bytes; the longest an output can have here is " +
            std::to_string(std::size_t(nameMax) - kPartialSuffix) + " (the folder allows " + std::to_string(nameMax) +
            " bytes a name, and the temporary it is written to first adds up to " + std::to_string(kPartialSuffix) +
            ")");
    if (p.string().size() + kPartialSuffix >= PATH_MAX)
        bad("is a path of " + std::to_string(p.string().size()) + " bytes; the longest an output can have is " +
            std::to_string(PATH_MAX - 1 - kPartialSuffix) + " (the system's PATH_MAX " + std::to_string(PATH_MAX) +
            ", less the temporary's suffix)");
}

bool emptyFolder(const fs::path& p) {
    std::error_code ec;
    return fs::is_empty(p, ec) && !ec;
}

}  // namespace

std::string resolveOutput(const std::string& flag, const std::string& path, bool folder) {
    auto bad = [&](const std::string& why) { throw std::invalid_argument(flag + ": '" + path + "' " + why); };
    if (path.empty()) throw std::invalid_argument(flag + ": the path is empty");
    std::error_code ec;
    fs::path p = fs::absolute(path, ec);
    if (ec) bad("cannot be made absolute: " + ec.message());
    for (int links = 0;; ++links) {
        checkNameLength(p, bad);
        struct stat st;
        if (::lstat(p.c_str(), &st) != 0) {
            if (errno != ENOENT) bad(std::string("cannot be inspected: ") + std::strerror(errno));
            const fs::path dir = p.parent_path();
            struct stat ds;
            if (::stat(dir.c_str(), &ds) != 0 || !S_ISDIR(ds.st_mode))
                bad("is in folder '" + dir.string() + "', which does not exist");
            if (::access(dir.c_str(), W_OK | X_OK) != 0)
                bad("is in folder '" + dir.string() + "', which is not writable");
            return p.string();
        }
        if (S_ISLNK(st.st_mode)) {  // written through: follow the link
            if (links == kMaxLinks) bad("has more than " + std::to_string(kMaxLinks) + " symbolic links in a row");
            const fs::path link = fs::read_symlink(p, ec);
            if (ec) bad("is a symbolic link that cannot be read: " + ec.message());
            p = link.is_absolute() ? link : p.parent_path() / link;
            continue;
        }
        if (folder) {
            if (!S_ISDIR(st.st_mode))
                bad((links ? "leads to '" + p.string() + "', which is " : std::string("exists and is ")) +
                    kindOf(st.st_mode) + ", not a folder");
            if (!emptyFolder(p)) bad("exists and is not an empty folder");
            return p.string();
        }
        if (!S_ISREG(st.st_mode))
            bad((links ? "leads to '" + p.string() + "', which is " : std::string("is ")) + kindOf(st.st_mode) +
                "; outputs are written as regular files only");
        return p.string();
    }
}

void removeStalePartials(const std::string& target) {
    const fs::path t(target);
    const fs::path dir = t.has_parent_path() ? t.parent_path() : fs::path(".");
    const std::string prefix = t.filename().string() + ".partial-";
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.rfind(prefix, 0) != 0) continue;
        const long pid = partialPid(name.substr(prefix.size()));
        if (pid <= 0 || pid == long(::getpid()) || processAlive(pid)) continue;
        struct stat st;
        if (::lstat(it->path().c_str(), &st) != 0) continue;
        std::error_code rm;
        if (S_ISREG(st.st_mode)) {
            fs::remove(it->path(), rm);
        } else if (S_ISDIR(st.st_mode)) {
            struct stat ms;
            const fs::path marker = it->path() / kPartialMarker;
            if (::lstat(marker.c_str(), &ms) == 0 && S_ISREG(ms.st_mode)) fs::remove_all(it->path(), rm);
        }
    }
}

std::string makePartial(const std::string& target, bool folder) {
    std::string name = target + ".partial-" + std::to_string(::getpid()) + "-XXXXXX";
    const mode_t mask = currentUmask();
    if (folder) {
        if (!::mkdtemp(name.data()))
            throw std::runtime_error(target + ": cannot create a temporary folder: " + std::strerror(errno));
        ::chmod(name.c_str(), 0777 & ~mask);
        const std::string marker = name + "/" + kPartialMarker;
        const int fd = ::open(marker.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
        if (fd < 0) throw std::runtime_error(marker + ": cannot create: " + std::strerror(errno));
        ::close(fd);
        return name;
    }
    const int fd = ::mkostemp(name.data(), O_CLOEXEC);  // O_EXCL: never through a link planted there
    if (fd < 0)
        throw std::runtime_error(target + ": cannot create a temporary file beside it: " + std::strerror(errno));
    ::fchmod(fd, 0666 & ~mask);
    ::close(fd);
    return name;
}

void renameIntoPlace(const std::string& temp, const std::string& target, bool folder) {
    if (folder) {
        std::error_code ec;
        fs::remove(fs::path(temp) / kPartialMarker, ec);
    }
    for (int attempt = 0; attempt < 3; ++attempt) {
        struct stat st;
        if (::lstat(target.c_str(), &st) == 0) {
            const bool ok = folder ? S_ISDIR(st.st_mode) : S_ISREG(st.st_mode);
            if (!ok) throw std::runtime_error(target + ": is now " + kindOf(st.st_mode) + "; it was not replaced");
            if (::rename(temp.c_str(), target.c_str()) == 0) return;  // a folder only if empty (ENOTEMPTY)
        } else if (errno == ENOENT) {
            // Nothing there: never replace what may appear in the meantime.
            if (::renameat2(AT_FDCWD, temp.c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) == 0) return;
            if (errno == EEXIST) continue;
            if (errno == EINVAL && ::rename(temp.c_str(), target.c_str()) == 0) return;  // no RENAME_NOREPLACE here
        }
        throw std::runtime_error(target + ": cannot rename '" + temp + "' into place: " + std::strerror(errno));
    }
    throw std::runtime_error(target + ": keeps changing while it is written; it was not replaced");
}

void OutputFiles::add(const std::string& path, Writer writer, const std::string& flag) {
    files_.push_back({path, flag, std::move(writer), ""});
    checked_ = false;
}

void OutputFiles::checkPaths() {
    std::set<fs::path> seen;
    for (File& f : files_) {
        f.target = resolveOutput(f.flag, f.path);
        std::error_code ec;
        const fs::path canonical = fs::weakly_canonical(f.target, ec);
        if (!seen.insert(ec ? fs::path(f.target) : canonical).second)
            throw std::invalid_argument(f.flag + ": '" + f.path + "' is named as two outputs");
    }
    checked_ = true;
}

void OutputFiles::refuseInput(const std::string& input, const std::string& what) {
    if (!checked_) checkPaths();
    for (const File& f : files_) {
        std::error_code ec;
        if (fs::equivalent(f.target, input, ec) && !ec)
            throw std::invalid_argument(f.flag + ": '" + f.path + "' is the " + what + " '" + input +
                                        "'; writing it would overwrite its input");
    }
}

void OutputFiles::commit() {
    if (!checked_) checkPaths();
    std::vector<std::string> temps;
    std::size_t renamed = 0;
    auto cleanup = [&] {
        std::error_code ec;
        for (std::size_t i = 0; i < temps.size(); ++i) fs::remove(i < renamed ? files_[i].target : temps[i], ec);
    };
    try {
        for (const File& f : files_) {
            removeStalePartials(f.target);
            temps.push_back(makePartial(f.target));
            f.writer(temps.back());
        }
        for (; renamed < files_.size(); ++renamed) renameIntoPlace(temps[renamed], files_[renamed].target);
    } catch (...) {
        cleanup();
        throw;
    }
}

}  // namespace nephele::cli
