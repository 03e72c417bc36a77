#include "compare_command.hpp"

#include "render_command.hpp"  // UsageError

#include "nephele/image.hpp"
#include "nephele/metrics.hpp"
#include "nephele/png.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>

namespace nephele::cli {

namespace {

struct Loaded {
    Image color;                 // RGB, linear
    std::optional<Image> alpha;  // grey, linear
};

bool isPng(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".png") return true;
    if (ext == ".pfm") return false;
    throw UsageError(path + ": unknown image type '" + ext + "' (expected .png or .pfm)");
}

Image read(const std::string& path) {
    Image img;
    try {
        img = isPng(path) ? readPng(path) : readPfm(path);
    } catch (const ImageError& e) {
        throw UsageError(e.what());  // ImageError messages start with the path
    }
    if (!std::all_of(img.pixels.begin(), img.pixels.end(), [](float v) { return std::isfinite(v); }))
        throw UsageError(path + ": has NaN or infinite values");
    return img;
}

Loaded loadColor(const std::string& path) {
    const bool png = isPng(path);
    const Image img = read(path);
    const int c = img.channels, colour = c >= 3 ? 3 : 1;  // grey (+alpha) PNGs and grey PFMs are grey colour
    Loaded out{Image(img.width, img.height, 3), std::nullopt};
    if (c == 2 || c == 4) out.alpha = channels(img, c - 1, 1);  // PNG alpha is stored linear
    for (std::size_t p = 0; p < std::size_t(img.width) * img.height; ++p)
        for (int k = 0; k < 3; ++k) {
            const float v = img.pixels[p * c + (colour == 3 ? k : 0)];
            out.color.pixels[p * 3 + k] = png ? srgbToLinear(v) : v;
        }
    return out;
}

Image loadAlpha(const std::string& path) {
    Image img = read(path);
    if (img.channels != 1)
        throw UsageError(path + ": an alpha file must be grey (1 channel), this one has " + std::to_string(img.channels));
    return img;
}

void checkSize(const Image& img, const std::string& path, const Image& ref, const std::string& refPath) {
    if (img.width != ref.width || img.height != ref.height)
        throw UsageError(path + ": size " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                         " differs from " + refPath + " (" + std::to_string(ref.width) + "x" +
                         std::to_string(ref.height) + ")");
}

}  // namespace

int runCompare(const CompareOptions& o) {
    try {
        if (o.a.empty() || o.b.empty()) throw UsageError("compare needs two images, A and B");
        Loaded a = loadColor(o.a), b = loadColor(o.b);
        checkSize(b.color, o.b, a.color, o.a);
        if (!o.alphaA.empty()) a.alpha = loadAlpha(o.alphaA);
        if (!o.alphaB.empty()) b.alpha = loadAlpha(o.alphaB);
        if (a.alpha) checkSize(*a.alpha, o.alphaA.empty() ? o.a : o.alphaA, a.color, o.a);
        if (b.alpha) checkSize(*b.alpha, o.alphaB.empty() ? o.b : o.alphaB, a.color, o.a);
        if (a.alpha.has_value() != b.alpha.has_value() && !(o.alphaA.empty() && o.alphaB.empty()))
            std::cerr << "nephele: " << (a.alpha ? o.b : o.a) << " gives no alpha; alpha not compared\n";
        const RenderComparison c = compareRenders(a.color, b.color, a.alpha ? &*a.alpha : nullptr,
                                                  b.alpha ? &*b.alpha : nullptr);
        std::cout << toJson(c) << "\n" << std::flush;
        return 0;
    } catch (const UsageError& e) {
        std::cerr << "nephele: " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "nephele: compare failed: " << e.what() << "\n";
        return 1;
    }
}

}  // namespace nephele::cli
