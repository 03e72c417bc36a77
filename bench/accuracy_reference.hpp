// The accuracy bench's yardstick: the path-traced reference of a case split by light source
// (the sun alone, the sky and ground alone, the sun's single scattering), its own noise, and
// a fast method's error split the same way (issue #10's diagnosis).
#pragma once

#include "nephele/camera.hpp"
#include "nephele/image.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"

#include <functional>
#include <string>

namespace nephele::cli {

// The mean of each block x block square of pixels (RGBA), the last partial ones dropped.
Image blockMean(const Image& image, int block);

// Relative RMSE of `a` against reference `b` over the pixels where either has cloud
// (alpha > 0.02), normalised by the reference's mean radiance there. 0 when no pixel has cloud.
double relativeRmse(const Image& a, const Image& b);

// The path-traced reference of one case, at block means. total = sun + sky.
struct Reference {
    Image total, sun, sky, single;  // RGBA block means; a = cloud opacity (the sun part's)
    Image full;                     // RGBA at the frame's resolution: sun + sky, for looking at
    double noise = 0;               // relative RMSE of `total` from its own Monte Carlo noise
    int spp = 0;                    // samples per pixel of the sun part it took (orders 0..kReferenceBounces)
    int highSpp = 0;                // of the orders past kReferenceBounces
    double highShare = 0;           // their share of the mean radiance over the cloud
    double seconds = 0;             // wall time of the path traces (near 0 when all were cached)
    double scratchSeconds = 0;      // estimated wall time of all its traces made afresh here (pilots)
    double highScratchSeconds = 0;  // of them, the orders past kReferenceBounces
    int traced = 0;                 // path-traced images computed (not from the cache)
};
// The scattering orders the reference's main pieces hold; the orders past it, up to
// PathTraceSettings' maxBounces, are traced apart (makeReference). 32 keeps the reference
// cache's pieces traced with 32 bounces valid as main pieces.
inline constexpr int kReferenceBounces = 32;

struct ReferenceSettings {
    // The sun part in pieces of `pieceSpp` samples per pixel of independent seeds, added until
    // the noise of their mean (measured by their spread) is at most `targetNoise`, or `spp`.
    int spp = 1024;
    int pieceSpp = 32;
    double targetNoise = 0.02;
    int skySpp = 256;    // the sky part's samples per `spp` (smoother: skylight comes from every side)
    int singleSpp = 64;  // of the sun's single scattering (bounces 0)
    int block = 4;
    std::string cacheDir;  // "" = no cache
};
Reference makeReference(const Scene& scene, const View& view, const NoiseVolume& noise, const ReferenceSettings& s);

// A fast method's error against the reference, split by light (all relative RMSE against the
// reference's mean total radiance over the cloud's blocks): the sun's single scattering, its
// multiple scattering, the sky's and the ground's light, and the opacity alone (the
// background through the cloud: (alpha_ref - alpha) times the background).
struct ComponentErrors {
    double total = 0, single = 0, multiple = 0, sky = 0, opacity = 0;
};
// `render(scene, singleOnly)` draws the method's image of `scene` (RGBA, the view's size);
// with singleOnly it must light by single scattering alone (no diffuse light).
ComponentErrors componentErrors(const Scene& scene, const View& view, const Reference& ref, int block,
                                const std::function<Image(const Scene&, bool singleOnly)>& render);

// The reference's mean radiance over the cloud's blocks by source: single scattering,
// multiple scattering, the sky (including the background seen through the cloud), each as a
// share of the total.
struct ReferenceShares {
    double single = 0, multiple = 0, sky = 0;
};
ReferenceShares referenceShares(const Reference& ref);

}  // namespace nephele::cli
