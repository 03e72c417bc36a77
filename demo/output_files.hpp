// All-or-nothing output: every file is written to a temporary name beside its target and
// renamed into place only when all of them were written. On failure nothing is left.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace nephele::cli {

class OutputFiles {
public:
    using Writer = std::function<void(const std::string& path)>;
    void add(const std::string& path, Writer writer) { files_.push_back({path, std::move(writer)}); }
    // Throws (after removing every temporary and nothing else) if a writer or rename fails.
    void commit();
    // Throws std::invalid_argument if a path repeats or its folder does not exist.
    void checkPaths() const;

private:
    struct File { std::string path; Writer writer; };
    std::vector<File> files_;
};

}  // namespace nephele::cli
