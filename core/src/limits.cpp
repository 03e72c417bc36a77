#include "nephele/limits.hpp"

#include <charconv>
#include <cmath>

namespace nephele {

namespace {
using namespace limits;
constexpr Limit kAll[] = {kSceneFileBytes,   kNestingDepth,      kJsonValues,         kEllipsoids,
                          kClouds,           kGenerateEntries,   kEllipsoidsPerEntry, kLSystemSymbols,
                          kLSystemDepth,     kObjFileBytes,      kObjBytesPerScene,   kLayers,
                          kLightningFlashes, kObjects,           kKeyframes,          kCoordinate,
                          kEllipsoidRadius,  kSmallestRadius,    kOpticalDepth,       kExtinction,
                          kNoiseAmplitude,   kNoiseScale,        kSmallestNoiseScale, kLayerThickness,
                          kLayerExtent,      kLayerOpticalDepth, kWindSpeed,          kTime,
                          kSmallestNear,     kFarClip,           kObjectSize,         kColour,
                          kIntensity,        kImageFileBytes,    kImageSide,          kImagePixels,
                          kShaderFileBytes};
}  // namespace

std::span<const Limit> allLimits() { return kAll; }

std::string limitValueText(const Limit& limit) {
    const double v = limit.value;
    if (limit.unit == "bytes" && v >= 1024.0 * 1024.0 && std::fmod(v, 1024.0 * 1024.0) == 0) {
        const double mib = v / (1024.0 * 1024.0);
        return std::fmod(mib, 1024.0) == 0 ? std::to_string(std::int64_t(mib / 1024)) + " GiB"
                                           : std::to_string(std::int64_t(mib)) + " MiB";
    }
    char buf[400];  // shortest text that reads back: "100000", "0.01", "1e+20"
    const bool fixed = std::abs(v) >= 1e-4 && std::abs(v) < 1e15;
    const auto end = fixed ? std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed).ptr
                           : std::to_chars(buf, buf + sizeof buf, v).ptr;
    return std::string(buf, end) + (limit.unit.empty() ? "" : " " + std::string(limit.unit));
}

std::string limitText(const Limit& limit) {
    return "'" + std::string(limit.name) + "' (" + limitValueText(limit) + ")";
}

std::string limitsHelp() {
    std::string s = "Limits (a scene or file past one is rejected with a message naming it; see data/scene-format.md):";
    std::size_t lineStart = 0;
    for (const Limit& l : allLimits()) {
        const std::string one = std::string(l.name) + (l.minimum ? " >= " : " <= ") + limitValueText(l) + ";";
        if (s.size() - lineStart + 1 + one.size() > 90) {  // wrapped for a terminal
            s += "\n ";
            lineStart = s.size() - 1;
        }
        s += " " + one;
    }
    s.back() = '.';
    return s;
}

}  // namespace nephele
