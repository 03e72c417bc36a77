// The limits of what Nephele loads: one place for every number, read by the scene loader,
// the OBJ and image readers, the command line's --help and the tests that check that
// data/scene-format.md ("Limits") and docs/reliability.md ("Limits") state the same values.
//
// A scene past a limit is rejected on load with a message that names the file, the JSON path
// and the limit, e.g. "scene.json: clouds[0].ellipsoids[3].radii[0]: 2e+06 is over the limit
// 'ellipsoid radius' (100000 m)". The values are chosen from what a flight simulator's
// weather needs (a few layers, thousands of clouds, a sky a few hundred km across) and
// from what the renderers can do in bounded time and memory (see docs/reliability.md, "Limits").
#pragma once

#include "nephele/api.hpp"
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

NEPHELE_API_BEGIN
namespace nephele {

struct Limit {
    std::string_view name;  // as in messages and in the docs' tables: "ellipsoid radius"
    double value;           // the largest value accepted (the smallest, for `minimum` limits)
    std::string_view unit;  // "bytes", "m", "s", "1/m", ... ("" for counts)
    bool minimum = false;   // true: values below `value` are rejected
};

namespace limits {
// ---- Files and structure.
inline constexpr Limit kSceneFileBytes{"scene file size", 256.0 * 1024 * 1024, "bytes"};
inline constexpr Limit kNestingDepth{"nesting depth", 64, ""};
inline constexpr Limit kJsonValues{"JSON values", 16'000'000, ""};  // numbers, strings, arrays, ... of one scene
inline constexpr Limit kObjFileBytes{"OBJ file size", 64.0 * 1024 * 1024, "bytes"};
inline constexpr Limit kObjBytesPerScene{"OBJ data per scene", 256.0 * 1024 * 1024, "bytes"};
inline constexpr Limit kImageFileBytes{"image file size", 1024.0 * 1024 * 1024, "bytes"};
inline constexpr Limit kImageSide{"image side", 16384, "pixels"};
inline constexpr Limit kImagePixels{"image pixels", 8192.0 * 8192, "pixels"};
inline constexpr Limit kShaderFileBytes{"shader file size", 1024.0 * 1024, "bytes"};

// ---- Counts.
inline constexpr Limit kEllipsoids{"ellipsoids", 1'000'000, ""};  // explicit and generated, in all
inline constexpr Limit kClouds{"clouds", 100'000, ""};            // explicit and generated, in all
inline constexpr Limit kGenerateEntries{"generate entries", 1'000, ""};
inline constexpr Limit kEllipsoidsPerEntry{"ellipsoids per generate entry", 100'000, ""};
inline constexpr Limit kLSystemSymbols{"L-system symbols per scene", 20'000'000, ""};
inline constexpr Limit kLSystemDepth{"L-system branch depth", 1'000, ""};  // nested '[' of one string
inline constexpr Limit kLayers{"layers", 8, ""};
inline constexpr Limit kLightningFlashes{"lightning flashes", 10'000, ""};
inline constexpr Limit kObjects{"objects", 10'000, ""};
inline constexpr Limit kKeyframes{"path keyframes", 100'000, ""};

// ---- Physical ranges: where a number stops making sense.
inline constexpr Limit kCoordinate{"coordinate", 1e7, "m"};  // |x|, |y|, |z| of every position
inline constexpr Limit kEllipsoidRadius{"ellipsoid radius", 100'000, "m"};
inline constexpr Limit kSmallestRadius{"smallest ellipsoid radius", 0.01, "m", true};
inline constexpr Limit kOpticalDepth{"optical depth per ellipsoid", 10'000,
                                     ""};  // extinction*density*16/15*largest radius
inline constexpr Limit kExtinction{"extinction", 10, "1/m"};
inline constexpr Limit kNoiseAmplitude{"noise amplitude", 10, ""};
inline constexpr Limit kNoiseScale{"noise scale", 1e6, "m"};
inline constexpr Limit kSmallestNoiseScale{"smallest noise scale", 0.01, "m", true};
inline constexpr Limit kLayerThickness{"layer thickness", 20'000, "m"};
inline constexpr Limit kLayerExtent{"layer extent", 500'000, "m"};
inline constexpr Limit kLayerOpticalDepth{"layer optical depth", 10'000, ""};  // extinction*density*thickness
// medium.detail (shaders/detail.glsl): wavelengths in [kDetailSmallest, kDetailScale] m, at most
// 16 octaves (scale / smallest < 2^16).
inline constexpr double kDetailSmallest = 0.05;
inline constexpr double kDetailScale = 1e5;
inline constexpr double kDetailOctaveRatio = 65535;
inline constexpr Limit kWindSpeed{"wind speed", 200, "m/s"};
inline constexpr Limit kTime{"time", 1e7, "s"};  // |t| of keyframes and lightning; flash durations
inline constexpr Limit kSmallestNear{"smallest near clip", 1e-3, "m", true};
inline constexpr Limit kFarClip{"far clip", 1e8, "m"};
inline constexpr Limit kObjectSize{"object size", 1e6, "m"};
inline constexpr Limit kColour{"colour component", 1e6, ""};
inline constexpr Limit kIntensity{"intensity", 1e9, ""};

// ---- Outputs (not of what Nephele loads: not in allLimits(), documented in docs/cli.md).
// Voxels of the box `nephele export --vdb` samples (its --voxel over the field's extent): at
// 4 bytes a float and OpenVDB's leaf overhead a full box stays under about 400 MB.
inline constexpr Limit kExportVoxels{"VDB export voxels", 64.0 * 1024 * 1024, ""};
}  // namespace limits

// Every limit above but the outputs', in the order of data/scene-format.md's table.
std::span<const Limit> allLimits();

// "'ellipsoid radius' (100000 m)", "'scene file size' (256 MiB)", "'layers' (8)".
std::string limitText(const Limit& limit);

// The value as the docs write it: "100000", "256 MiB", "1e+07", "0.01".
std::string limitValueText(const Limit& limit);

// One paragraph for the command line's --help: every limit's name and value.
std::string limitsHelp();

// Whether `value` passes `limit` (value <= limit, or >= for a minimum; NaN never passes).
inline bool withinLimit(double value, const Limit& limit) {
    return limit.minimum ? value >= limit.value : value <= limit.value;
}

}  // namespace nephele
NEPHELE_API_END
