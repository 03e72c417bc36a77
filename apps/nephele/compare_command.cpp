#include "compare_command.hpp"

#include "render_command.hpp"  // UsageError

#include "nephele/image.hpp"
#include "nephele/limits.hpp"
#include "nephele/metrics.hpp"
#include "nephele/png.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>
#include <span>

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

// The header of an image, read before any image is decoded (issue 38): compare refuses images
// of different sizes, or past its memory budget, without decoding them.
ImageShape shapeOf(const std::string& path) {
    try {
        return isPng(path) ? readPngShape(path) : readPfmShape(path);
    } catch (const ImageError& e) {
        throw UsageError(e.what());  // ImageError messages start with the path
    }
}

// What compare holds for one image: linear RGB floats, and grey alpha floats when the file
// has alpha or an alpha file is given. The budget is one float RGBA image of the largest size
// (limits::kImagePixels: 8192^2, 1 GiB); compare holds two.
constexpr double kImageBudgetBytes = limits::kImagePixels.value * 4 * sizeof(float);

void checkBudget(const std::string& path, const ImageShape& s, bool alpha) {
    const double bytes = double(s.width) * double(s.height) * (3 + (alpha ? 1 : 0)) * sizeof(float);
    if (bytes > kImageBudgetBytes)
        throw UsageError(path + ": " + std::to_string(s.width) + "x" + std::to_string(s.height) + " decodes to " +
                         std::to_string(std::uint64_t(bytes)) + " bytes, over compare's budget of " +
                         std::to_string(std::uint64_t(kImageBudgetBytes)) + " bytes an image");
}

void checkSize(const ImageShape& img, const std::string& path, const ImageShape& ref, const std::string& refPath) {
    if (img.width != ref.width || img.height != ref.height)
        throw UsageError(path + ": size " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                         " differs from " + refPath + " (" + std::to_string(ref.width) + "x" +
                         std::to_string(ref.height) + ")");
}

void checkFinite(const Image& img, const std::string& path) {
    if (!std::all_of(img.pixels.begin(), img.pixels.end(), [](float v) { return std::isfinite(v); }))
        throw UsageError(path + ": has NaN or infinite values");
}

Image decode(const std::string& path, std::span<const int> pick) {
    try {
        return readPng(path, pick);
    } catch (const ImageError& e) {
        throw UsageError(e.what());
    }
}

Image readPfmChecked(const std::string& path) {
    try {
        Image img = readPfm(path);
        checkFinite(img, path);
        return img;
    } catch (const ImageError& e) {
        throw UsageError(e.what());
    }
}

// Decodes straight into what compare keeps (no full-size intermediate copies): a PNG's colour
// channels to linear RGB, its alpha (stored linear) to grey.
// An alpha file given for the image replaces the file's own alpha, which is then not decoded.
Loaded loadColor(const std::string& path, const ImageShape& shape, bool fileAlpha) {
    const int c = shape.channels;
    Loaded out;
    if (isPng(path)) {
        static const int grey[] = {0, 0, 0}, rgb[] = {0, 1, 2};
        out.color = decode(path, c >= 3 ? std::span<const int>(rgb) : std::span<const int>(grey));
        for (float& v : out.color.pixels) v = srgbToLinear(v);
        if (fileAlpha && (c == 2 || c == 4)) {
            const int alpha[] = {c - 1};
            out.alpha = decode(path, alpha);
        }
        return out;
    }
    Image img = readPfmChecked(path);
    if (img.channels == 3) {
        out.color = std::move(img);
        return out;
    }
    out.color = Image(img.width, img.height, 3);  // grey PFM: grey colour
    for (std::size_t p = 0; p < img.pixels.size(); ++p)
        for (int k = 0; k < 3; ++k) out.color.pixels[p * 3 + k] = img.pixels[p];
    return out;
}

Image loadAlpha(const std::string& path, const ImageShape& shape) {
    if (shape.channels != 1)
        throw UsageError(path + ": an alpha file must be grey (1 channel), this one has " +
                         std::to_string(shape.channels));
    if (!isPng(path)) return readPfmChecked(path);
    const int grey[] = {0};
    return decode(path, grey);
}

}  // namespace

int runCompare(const CompareOptions& o) {
    try {
        if (o.a.empty() || o.b.empty()) throw UsageError("compare needs two images, A and B");
        // Every header first: sizes and the budget are checked before any image is decoded.
        const ImageShape sa = shapeOf(o.a), sb = shapeOf(o.b);
        checkSize(sb, o.b, sa, o.a);
        std::optional<ImageShape> saa, sba;
        if (!o.alphaA.empty()) checkSize(*(saa = shapeOf(o.alphaA)), o.alphaA, sa, o.a);
        if (!o.alphaB.empty()) checkSize(*(sba = shapeOf(o.alphaB)), o.alphaB, sa, o.a);
        const auto fileAlpha = [&](const std::string& path, const ImageShape& s) {
            return isPng(path) && (s.channels == 2 || s.channels == 4);
        };
        checkBudget(o.a, sa, saa || fileAlpha(o.a, sa));
        checkBudget(o.b, sb, sba || fileAlpha(o.b, sb));
        Loaded a = loadColor(o.a, sa, !saa);
        if (saa) a.alpha = loadAlpha(o.alphaA, *saa);
        Loaded b = loadColor(o.b, sb, !sba);
        if (sba) b.alpha = loadAlpha(o.alphaB, *sba);
        if (a.alpha.has_value() != b.alpha.has_value() && !(o.alphaA.empty() && o.alphaB.empty()))
            std::cerr << "nephele: " << (a.alpha ? o.b : o.a) << " gives no alpha; alpha not compared\n";
        const RenderComparison c =
            compareRenders(a.color, b.color, a.alpha ? &*a.alpha : nullptr, b.alpha ? &*b.alpha : nullptr);
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
