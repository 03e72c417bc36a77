// PNG files (libpng), in Nephele::platform: a host that links only Nephele::core gets no libpng.
#pragma once

#include "nephele/image.hpp"

#include <string>

namespace nephele {

enum class Encoding { Srgb, Linear };
// 8-bit PNG of 1, 3 or 4 channels. Srgb encodes colour channels (never alpha); Linear
// writes values as they are (opacity maps). Values are clamped to [0, 1].
void writePng(const std::string& path, const Image& image, Encoding encoding = Encoding::Srgb);
// Reads an 8-bit PNG (grey, grey+alpha, RGB or RGBA) into values in [0, 1], as stored
// (no sRGB decoding).
Image readPng(const std::string& path);

}  // namespace nephele
