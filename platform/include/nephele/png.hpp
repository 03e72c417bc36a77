// PNG files (libpng), in Nephele::platform: a host that links only Nephele::core gets no libpng.
#pragma once

#include "nephele/api.hpp"
#include "nephele/image.hpp"

#include <span>
#include <string>

NEPHELE_API_BEGIN
namespace nephele {

enum class Encoding { Srgb, Linear };
// 8-bit PNG of 1, 3 or 4 channels. Srgb encodes colour channels (never alpha); Linear
// writes values as they are (opacity maps). Values are clamped to [0, 1].
void writePng(const std::string& path, const Image& image, Encoding encoding = Encoding::Srgb);
// Reads an 8-bit PNG (grey, grey+alpha, RGB or RGBA) into values in [0, 1], as stored
// (no sRGB decoding).
Image readPng(const std::string& path);

// What a PNG's header says: its size and its channels after expansion to 8-bit grey, grey +
// alpha, RGB or RGBA (as readPng returns them). Checks the limits and the file size as readPng
// does, without decoding the pixels. Throws ImageError naming the path.
ImageShape readPngShape(const std::string& path);

// readPng keeping only some channels: output channel k is the file's channel pick[k] (so
// {0, 0, 0} makes a grey file RGB, {3} is the alpha of RGBA). Decodes row by row (a whole
// 8-bit copy only for interlaced files), so what it holds is the result's floats.
Image readPng(const std::string& path, std::span<const int> pick);

}  // namespace nephele
NEPHELE_API_END
