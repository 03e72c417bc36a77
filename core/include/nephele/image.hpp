// Float images, PFM files, and the metrics the tests use (PNG: nephele/png.hpp).
#pragma once

#include "nephele/api.hpp"
#include <glm/glm.hpp>

#include <stdexcept>
#include <string>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// Row 0 is the top row. Values are linear radiance (colour) or opacity (grey) unless a
// function says otherwise.
struct Image {
    int width = 0;
    int height = 0;
    int channels = 0;           // 1 (grey), 3 (RGB) or 4 (RGBA)
    std::vector<float> pixels;  // row-major, interleaved

    Image() = default;
    Image(int w, int h, int c, float fill = 0.0f)
        : width(w), height(h), channels(c), pixels(std::size_t(w) * h * c, fill) {}
    float& at(int x, int y, int c) { return pixels[(std::size_t(y) * width + x) * channels + c]; }
    float at(int x, int y, int c) const { return pixels[(std::size_t(y) * width + x) * channels + c]; }
    bool empty() const { return pixels.empty(); }
};

// What an image file's header says (readPngShape, readPfmShape): read before decoding.
struct ImageShape {
    int width = 0, height = 0, channels = 0;
};

class ImageError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

float linearToSrgb(float linear);  // IEC 61966-2-1, input clamped to [0, 1]
float srgbToLinear(float encoded);

// PNG files: nephele/png.hpp (Nephele::platform, libpng).
// Portable float map: "PF" (RGB) or "Pf" (grey), little-endian, linear floats.
void writePfm(const std::string& path, const Image& image);
Image readPfm(const std::string& path);
// The header of a PFM file, checked as readPfm checks it, without reading the pixels.
ImageShape readPfmShape(const std::string& path);

// The channels [first, first+count) of an image, e.g. RGB of an RGBA image.
Image channels(const Image& image, int first, int count);

struct ImageDifference {
    double maxAbs = 0;        // largest per-channel absolute difference
    double meanAbs = 0;       // mean over all channels and pixels
    double fractionOver = 0;  // fraction of pixels with any channel differing by > threshold
};
// Throws ImageError when sizes or channel counts differ.
ImageDifference compareImages(const Image& a, const Image& b, double threshold);
// |a - b| per channel, scaled by `gain`, for a person to look at.
Image differenceImage(const Image& a, const Image& b, float gain = 4.0f);
// Peak signal-to-noise ratio in dB over all channels, peak 1.
double psnr(const Image& a, const Image& b);

}  // namespace nephele
NEPHELE_API_END
