// Folders of a test process's own: named after the process id, because other checkouts on the
// machine run the same tests at the same time (issue #39: one helper instead of eight copies).
#pragma once

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace nephele::test {

// `<parent>/<prefix><pid>`, neither made nor emptied.
inline std::filesystem::path processPath(const std::string& prefix,
                                         const std::filesystem::path& parent = std::filesystem::temp_directory_path()) {
    return parent / (prefix + std::to_string(::getpid()));
}

// The same folder, emptied: what was left there by an earlier run is gone; made when `make`.
inline std::filesystem::path freshProcessDir(
    const std::string& prefix, bool make = true,
    const std::filesystem::path& parent = std::filesystem::temp_directory_path()) {
    const std::filesystem::path dir = processPath(prefix, parent);
    std::filesystem::remove_all(dir);
    if (make) std::filesystem::create_directories(dir);
    return dir;
}

// A fresh folder for one test, `<parent>/<prefix><pid>_<test name>`, removed at its end.
class TempDir {
public:
    explicit TempDir(const std::string& prefix,
                     const std::filesystem::path& parent = std::filesystem::temp_directory_path())
        : dir_(processPath(prefix, parent).string() + "_" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name()) {
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    ~TempDir() { std::filesystem::remove_all(dir_); }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const std::filesystem::path& dir() const { return dir_; }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    // Writes `text` (bytes as they are) to the file `name` in the folder; returns its path.
    std::string write(const std::string& name, const std::string& text) const {
        std::ofstream(path(name), std::ios::binary) << text;
        return path(name);
    }

private:
    std::filesystem::path dir_;
};

}  // namespace nephele::test
