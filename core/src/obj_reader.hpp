// The Wavefront OBJ reader of the mesh generator (nephele/generate.hpp), apart so that the
// fuzzer (tests/fuzz/) can drive it from memory.
#pragma once

#include "nephele/generate.hpp"

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace nephele::detail {

struct ObjMesh {
    std::vector<Vec3> vertices;
    struct Triangle {
        std::size_t a, b, c;  // 0-based vertex indices
    };
    std::vector<Triangle> triangles;
};

// Reads `v` and `f` lines of OBJ text (`file` names it in messages). At most
// limits::kEllipsoidsPerEntry triangles. Throws ObjError naming the file and line.
ObjMesh parseObj(std::string_view text, const std::string& file);

// Reads the OBJ file at `file` (a regular file of at most limits::kObjFileBytes, no NUL byte)
// and parses it. *bytes (optional) receives its size. Throws ObjError.
ObjMesh readObj(const std::string& file, std::uint64_t* bytes = nullptr);

// The ellipsoids of `mesh` under g's transform (generateMesh without the file).
Cloud meshCloud(const ObjMesh& mesh, const Generator& g, GenerateStats* stats = nullptr);

}  // namespace nephele::detail
