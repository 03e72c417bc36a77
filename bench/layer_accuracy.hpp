// The layered sky and auto's hand-off against physics (issue #10, item 6): views of
// data/scenes/near_and_far.json's layer (its explicit clouds removed) rendered with
// `--method layered`, `--method auto` and the path tracer, which renders the layer as a volume
// of the layered sky's own density (nephele/layer_volume.hpp). Per view:
// - the error of each against the path tracer, with the accuracy bench's definition
//   (relativeRmse() of bench/accuracy_reference.hpp on block x block pixel means), and the
//   layered sky's error split by light as the accuracy bench splits it (componentErrors());
// - the near LOD against the layer it stands for within auto's reach (near radius + blend band):
//   the near cumulus alone (every cell at weight 1) and the layer alone cut at the reach, over
//   the pixels whose ray meets the layer's slab within the reach: their mean opacities (and the
//   volume's own, the CPU integral of layerDensity()), and their mean radiance over the pixels
//   whose ray meets the slab across the blend band.
#pragma once

#include "accuracy_reference.hpp"
#include "bench_command.hpp"

#include "nephele/context.hpp"

#include <string>
#include <vector>

namespace nephele::cli {

struct LayerAccuracyOptions {
    BenchOptions bench;  // layer_accuracy.md; quick: one view at 64 px, 4 spp, one frame
    int width = 320;     // px, the views' width (16:9)
    int referenceSpp =
        256;  // samples per pixel of the reference's sun part (1/4 of it for the sky part and the single scattering)
    std::string imageDir;  // "" = none; else the block-mean images of each view (reference, layered, auto) as PNG
    int block = 4;         // errors on block x block pixel means
    int frames = 3;        // timed frames per GPU method (median)
};

struct LayerViewAccuracy {
    std::string view;
    double referenceSeconds = 0;             // wall time of the reference and its noise estimate (about 0 when cached)
    double referenceNoise = 0;               // the reference's own relative RMSE, from its two halves
    double layeredError = 0, autoError = 0;  // relative RMSE against the reference
    double layeredRatio = 0, autoRatio = 0;  // mean radiance over the cloud blocks / the reference's
    double referenceOpacity = 0, layeredOpacity = 0;  // mean alpha over the frame
    ComponentErrors layeredParts;                     // the layered sky's error split by light (accuracy_reference.hpp)
    ReferenceShares shares;                           // the reference's radiance split by light
    double layeredMs = 0, autoMs = 0;                 // median ms per frame
    // Over the blocks whose centre's ray meets the layer within auto's reach (where auto draws
    // the near LOD): error and mean ratio against the reference of the layered sky, of auto, and
    // of auto with the near cumulus lit each as a cloud alone (NearLodSettings::tiledLight off).
    int nearBlocks = 0;
    double layeredNearError = 0, layeredNearRatio = 0, autoNearError = 0, autoNearRatio = 0;
    double aloneNearError = 0, aloneNearRatio = 0;
    // The same mean ratios over the blocks that meet the layer across the blend band only.
    double layeredBandRatio = 0, autoBandRatio = 0, aloneBandRatio = 0;
    // The band's mean ratios by light: each method lit by the sun alone against the reference's
    // sun part, by the sky and the ground alone against its sky part ([0] layered, [1] auto).
    double bandSunRatio[2] = {0, 0}, bandSkyRatio[2] = {0, 0};
    // The near LOD against the layer within auto's reach.
    int reachPixels = 0, bandPixels = 0;
    double nearOpacity = 0, layerOpacity = 0, volumeOpacity = 0;  // mean over the reach pixels
    double nearRadiance = 0, layerRadiance = 0;                   // mean luminance over the band pixels
};

// Needs a current OpenGL 4.5 context. Throws on failure (std::invalid_argument for bad options).
std::vector<LayerViewAccuracy> measureLayerAccuracy(const LayerAccuracyOptions& options);

// The results as markdown tables (the errors; the near LOD against the layer).
std::string layerAccuracyMarkdown(const std::vector<LayerViewAccuracy>& results, const LayerAccuracyOptions& options);

// `nephele bench --layer-accuracy`: makes a context, measures, prints the markdown on stdout.
// Returns the exit code (2 bad options, 1 a runtime failure).
int runLayerAccuracyBench(const LayerAccuracyOptions& options);

}  // namespace nephele::cli
