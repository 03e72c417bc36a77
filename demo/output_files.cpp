#include "output_files.hpp"

#include <unistd.h>

#include <filesystem>
#include <set>
#include <stdexcept>
#include <system_error>

namespace fs = std::filesystem;

namespace nephele::cli {

void OutputFiles::checkPaths() const {
    std::set<fs::path> seen;
    for (const File& f : files_) {
        const fs::path p = fs::absolute(f.path).lexically_normal();
        if (!seen.insert(p).second) throw std::invalid_argument("'" + f.path + "' is named as two outputs");
        const fs::path dir = p.parent_path();
        std::error_code ec;
        if (!fs::is_directory(dir, ec))
            throw std::invalid_argument("cannot write '" + f.path + "': folder '" + dir.string() + "' does not exist");
        if (fs::is_directory(p, ec)) throw std::invalid_argument("cannot write '" + f.path + "': it is a folder");
    }
}

void OutputFiles::commit() {
    std::vector<std::string> temps;
    std::size_t renamed = 0;
    auto cleanup = [&] {
        std::error_code ec;
        for (std::size_t i = 0; i < temps.size(); ++i) fs::remove(i < renamed ? files_[i].path : temps[i], ec);
    };
    try {
        for (const File& f : files_) {
            temps.push_back(f.path + ".partial-" + std::to_string(::getpid()));
            f.writer(temps.back());
        }
        for (; renamed < files_.size(); ++renamed) fs::rename(temps[renamed], files_[renamed].path);
    } catch (...) {
        cleanup();
        throw;
    }
}

}  // namespace nephele::cli
