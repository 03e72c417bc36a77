// Comparing two renders of the same view: exposure-fitted error, SSIM and alpha agreement.
#pragma once

#include "nephele/api.hpp"
#include "nephele/image.hpp"

#include <string>

NEPHELE_API_BEGIN
namespace nephele {

struct RenderComparison {
    double exposure = 1;  // the scale s fitted so that s * A best matches B (least squares over RGB)
    double rmse = 0;      // of s*A - B over RGB, linear radiance
    double psnr = 0;      // dB, peak = max value of B (or 1 if B's max < 1); +inf when s*A == B
    double ssim = 0;      // mean SSIM of sRGB-encoded luminance (see ssimLuminance); of A against B, no exposure fit
    bool hasAlpha = false;
    double alphaMae = 0;  // mean |alphaA - alphaB| when both have alpha
    double alphaIou = 0;  // IoU of the (alpha > 0.5) masks; 1 when both masks are empty
};

// a, b: RGB (3 channels, linear). alphaA / alphaB: grey images of the same size, or nullptr;
// alpha is compared only when both are given. Throws ImageError on size or channel mismatch
// and on empty images or non-finite values.
RenderComparison compareRenders(const Image& a, const Image& b, const Image* alphaA = nullptr,
                                const Image* alphaB = nullptr);

// Mean SSIM (Wang et al. 2004) of the luminance of two RGB images: Rec. 709 weights on linear
// RGB, then sRGB-encoded and clamped to [0, 1]; 11x11 Gaussian window, sigma 1.5, K1 0.01,
// K2 0.03, L 1, averaged over the window positions that lie inside the image ("valid"). A
// side shorter than 11 pixels shrinks the window to that side (weights renormalised).
double ssimLuminance(const Image& a, const Image& b);

// Mean |a - b| over every value of two images of the same size and channels, each value
// clamped to [0, 1] first: the frame-to-frame change of fly-throughs and the flicker bench.
// Throws ImageError on a size or channel mismatch.
double meanClampedDifference(const Image& a, const Image& b);

// The box-counting dimension of the silhouette of the (alpha > 0.5) mask of a grey image
// (channel 0): the mask's boundary pixels are those with a 4-neighbour inside the image that is
// not in the mask (the image's own edge is no boundary); N(s) counts the s x s boxes of a grid
// from the top-left pixel that hold a boundary pixel, for s = 2, 4, ..., 32; the dimension is the
// least-squares slope of log N(s) against log(1 / s). A straight or smooth edge measures about 1,
// cloud perimeters about 1.35 (Lovejoy 1982). Returns 0 when no box at 32 px holds a boundary pixel.
double silhouetteDimension(const Image& alpha);

// One line of JSON: {"exposure":..,"rmse":..,"psnr":..,"ssim":..} plus "alpha_mae" and
// "alpha_iou" when hasAlpha. Numbers are shortest round-trip decimals. JSON has no infinity:
// a non-finite value is written as null, so "psnr":null means the images match exactly.
std::string toJson(const RenderComparison& c);

}  // namespace nephele
NEPHELE_API_END
