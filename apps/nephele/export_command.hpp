// `nephele export SCENE --vdb FILE [--voxel METRES]`: the scene's extinction field, exactly as
// the path tracer renders it (nephele::ExtinctionField), as an OpenVDB FloatGrid named
// `density` in 1/m, for Blender, Houdini or any volume path tracer (docs/cli.md, "export").
#pragma once

#include <string>

namespace nephele::cli {

struct ExportOptions {
    std::string scene;
    std::string vdb;       // output file (written atomically)
    double voxel = 0;      // m; 0: chosen from the field's extent (defaultVoxelSize)
    double time = 0;       // s: the layers' wind and the camera path (the layers are centred on the eye)
    std::string cacheDir;  // the layers' lighting volumes ("" = none)
};

// The voxel edge (m) `export` uses when --voxel is not given: the box's volume shared among
// 2^24 voxels (256^3), rounded up to two significant digits.
double defaultVoxelSize(double dx, double dy, double dz);

// Exit codes: 0 written; 2 bad input (scene, arguments, nothing to export, past
// limits::kExportVoxels; no file is written); 1 a failure while writing (no file is left).
int runExport(const ExportOptions& options);

}  // namespace nephele::cli
