// Every file the command line writes goes through here, under one policy:
// - An output is a regular file: it is replaced atomically (written to a temporary name
//   beside it, then renamed into place), or created when nothing is there yet.
// - A symlink is written through: the links are followed (at most 32) and the file they
//   end at is written under the same rules; the link itself stays.
// - A folder, a device node, a FIFO or a socket is refused (std::invalid_argument, exit 2),
//   and is checked again just before the rename, so `-o /dev/null` never replaces the device,
//   even as root.
// - All or nothing: when one output fails, none is left (OutputFiles::commit).
// Temporaries are named TARGET.partial-PID-XXXXXX (created exclusively, never through a
// link); a run that was killed leaves them behind, and a later run writing the same target
// removes those whose process is gone (regular files, or folders holding kPartialMarker).
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace nephele::cli {

// A temporary folder holds this file until it is renamed into place: only folders that hold
// it are ever removed as stale.
inline constexpr const char* kPartialMarker = ".nephele-partial";

// The path an output flag names, resolved by the policy above: the file to write (the end of
// its symlinks), which is a regular file or does not exist yet, in an existing folder.
// Throws std::invalid_argument("FLAG: 'PATH' ...") naming the flag and what is wrong.
// `folder` = true: the target is a folder (fly-through frames), which must be empty or absent.
std::string resolveOutput(const std::string& flag, const std::string& path, bool folder = false);

// Removes stale temporaries of `target` (see above). Never throws.
void removeStalePartials(const std::string& target);

// A new temporary beside `target` (TARGET.partial-PID-XXXXXX), created exclusively: a file,
// or a folder holding kPartialMarker, with the usual permissions (0666 / 0777 less the umask).
// Throws std::runtime_error.
std::string makePartial(const std::string& target, bool folder = false);

// Renames `temp` onto `target` after checking once more that `target` is a regular file (an
// empty folder when `folder`) or absent. Throws std::runtime_error.
void renameIntoPlace(const std::string& temp, const std::string& target, bool folder = false);

class OutputFiles {
public:
    using Writer = std::function<void(const std::string& path)>;
    // `flag` names the output in messages ("-o", "--alpha", ...).
    void add(const std::string& path, Writer writer, const std::string& flag = "output");
    // Resolves every path (resolveOutput) and checks that none repeats. Throws std::invalid_argument.
    void checkPaths();
    // Refuses (std::invalid_argument naming the flag) an output that is the file `input`
    // (the same file by any name or link): `-o scene.json` would overwrite the scene. Call after
    // checkPaths.
    void refuseInput(const std::string& input, const std::string& what);
    // Writes every file to its temporary and renames them all into place. Throws (after
    // removing every temporary, and the outputs already renamed) if a writer or rename fails.
    void commit();

private:
    struct File {
        std::string path, flag;
        Writer writer;
        std::string target;  // resolved by checkPaths()
    };
    std::vector<File> files_;
    bool checked_ = false;
};

}  // namespace nephele::cli
