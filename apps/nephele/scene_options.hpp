// The options every rendering command shares (`render`, `flythrough`, `ig`): the method and its
// settings, the frame's size, a display channel, the caches. Typed on the command line into
// SceneArgs, then checked into RenderOptions.
#pragma once

#include "render_command.hpp"

#include <string>

namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace nephele::cli {

// The options as typed on the command line.
struct SceneArgs {
    std::string scene, method = "auto", backend = "egl";
    int width = 0, height = 0;
    double scale = 0;
    int minTile = 8, maxTile = 512;
    std::string atlas, precision = "f16", draws = "instanced", flythrough = "fraction", colourMatrix = "fused";
    std::string tileGeometry = "mesh", exactOrder = "ellipsoid";
    std::string composite = EllipsoidSettings().order == CompositeOrder::Weighted ? "weighted" : "back-to-front";
    CLI::Option *widthOpt = nullptr, *heightOpt = nullptr, *scaleOpt = nullptr;
    CLI::Option *nearRadiusOpt = nullptr, *blendBandOpt = nullptr, *lod0RadiusOpt = nullptr;
    RaymarchSettings raymarch;
    RadianceGridSettings light;       // --light-grid, --photons (sky photons = sun photons)
    std::string lightGridFit = "on";  // --light-grid-fit
    std::string reuse;                // --reuse: on | off; empty: on under auto, off otherwise
    std::string cloudLod;             // --cloud-lod: on | off; empty: on under auto, off otherwise
    double reuseError = EllipsoidSettings().reuseErrorPixels, reuseBudget = EllipsoidSettings().reuseBudget;
    double cloudLodError = EllipsoidSettings().cloudLodErrorPixels;
    int closeDownsample = EllipsoidSettings().closeDownsample;
    PathTraceSettings pathtrace;
    LayeredSettings layered;
    std::string lightSize = "256x256x32";
    std::string frustum;                    // --frustum L,R,B,T
    double yawOffset = 0, pitchOffset = 0;  // --yaw-offset, --pitch-offset (degrees)
    std::string cache;
    bool noCache = false;
};

// Adds the options to a command.
void addSceneOptions(CLI::App* cmd, SceneArgs& args);
// Checks them into `options`. Throws UsageError for values the parser could not judge alone
// (ResourceError for a lighting volume over the memory available).
void applySceneArgs(const SceneArgs& args, RenderOptions& options);

}  // namespace nephele::cli
