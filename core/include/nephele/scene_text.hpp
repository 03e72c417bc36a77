// The scene loader's rules for text, for other JSON files of a host or of the command line
// (the flight scripts of `nephele fly --script`), so that they fail as scene files do.
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"  // SceneError

#include <string>

NEPHELE_API_BEGIN
namespace nephele {

// Checks `text` as JSON by the scene loader's rules: a NUL byte, a syntax error or a truncated
// text is named by line and column; duplicate keys are refused; nesting and the number of
// values are bounded (nephele/limits.hpp). Throws SceneError naming `file` (and the JSON path
// where the fault is inside the document).
void checkJsonText(const std::string& text, const std::string& file);

// Reads `file` as loadScene reads a scene: a regular file (no FIFO, device or folder) within
// the scene file size limit. Throws SceneError naming the file.
std::string readSceneText(const std::string& file);

}  // namespace nephele
NEPHELE_API_END
