#include "nephele/image.hpp"

#include "nephele/limits.hpp"

#include "image_file.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace nephele {

using detail::checkClaimedSize;
using detail::checkShape;
using detail::FilePtr;
using detail::openFile;
using detail::openImage;

float linearToSrgb(float v) {
    v = std::clamp(v, 0.0f, 1.0f);
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

float srgbToLinear(float v) {
    v = std::clamp(v, 0.0f, 1.0f);
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

namespace {

// What `bytes` of a file can hold: zlib's deflate expands at most 1032:1, so a PNG whose rows
// need more than that is cut short (or a bomb aimed at the reader's memory); checked before
// the image is allocated. A margin for the PNG's own headers keeps small files readable.
bool fitsIn(std::uint64_t rawBytes, std::uint64_t fileBytes) { return rawBytes <= (fileBytes + 1024) * 1032; }

}  // namespace

namespace detail {

void checkClaimedSize(const std::string& path, std::uint64_t w, std::uint64_t h, std::uint64_t rawBytes,
                      std::uint64_t fileBytes, bool compressed) {
    const std::string size = std::to_string(w) + "x" + std::to_string(h);
    if (double(w) > limits::kImageSide.value || double(h) > limits::kImageSide.value)
        throw ImageError(path + ": claims " + size + " pixels, over the limit " + limitText(limits::kImageSide));
    if (double(w) * double(h) > limits::kImagePixels.value)
        throw ImageError(path + ": claims " + size + " pixels, over the limit " + limitText(limits::kImagePixels));
    if (compressed ? !fitsIn(rawBytes, fileBytes) : rawBytes > fileBytes)
        throw ImageError(path + ": claims " + size + " pixels, more than its " + std::to_string(fileBytes) +
                         " bytes can hold (truncated or corrupt)");
}

OpenedFile openImage(const std::string& path) {
    OpenedFile f = openRegularFile(path, limits::kImageFileBytes);
    if (!f.file) throw ImageError(path + ": " + f.fault);
    return f;
}

}  // namespace detail

void writePfm(const std::string& path, const Image& image) {
    checkShape(image, path);
    if (image.channels != 1 && image.channels != 3) throw ImageError(path + ": PFM holds 1 or 3 channels");
    FilePtr file = openFile(path, "wb");
    // Negative scale = little-endian; rows run bottom to top.
    std::fprintf(file.get(), "%s\n%d %d\n-1.0\n", image.channels == 3 ? "PF" : "Pf", image.width, image.height);
    const std::size_t row = std::size_t(image.width) * image.channels;
    for (int y = image.height - 1; y >= 0; --y)
        if (std::fwrite(image.pixels.data() + y * row, sizeof(float), row, file.get()) != row)
            throw ImageError(path + ": write failed: " + std::strerror(errno));
    if (std::fflush(file.get()) != 0) throw ImageError(path + ": write failed: " + std::strerror(errno));
}

namespace {

// Reads and checks a PFM header; `file` is left at the first pixel.
ImageShape pfmHeader(const std::string& path, detail::OpenedFile& file) {
    // The header: "PF" or "Pf", width, height, scale, each followed by one whitespace byte.
    std::string words[4];
    for (std::string& w : words) {
        int c = std::fgetc(file.file.get());
        while (c != EOF && std::isspace(c)) c = std::fgetc(file.file.get());
        while (c != EOF && !std::isspace(c) && w.size() < 32) w += char(c), c = std::fgetc(file.file.get());
        if (c == EOF || w.empty() || w.size() >= 32) throw ImageError(path + ": not a PFM file");
    }
    auto number = [&](const std::string& s, auto& v) {
        const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
        if (r.ec != std::errc() || r.ptr != s.data() + s.size()) throw ImageError(path + ": not a PFM file");
    };
    long long w = 0, h = 0;
    double scale = 0;
    number(words[1], w), number(words[2], h), number(words[3], scale);
    const int c = words[0] == "PF" ? 3 : words[0] == "Pf" ? 1 : 0;
    if (c == 0 || w <= 0 || h <= 0 || !(scale < 0))
        throw ImageError(path + ": unsupported PFM header (need little-endian PF or Pf)");
    const std::uint64_t header = std::uint64_t(std::ftell(file.file.get()));
    checkClaimedSize(path, std::uint64_t(w), std::uint64_t(h), header + std::uint64_t(w) * h * c * sizeof(float),
                     file.size, false);
    return ImageShape{int(w), int(h), c};
}

}  // namespace

ImageShape readPfmShape(const std::string& path) {
    detail::OpenedFile file = openImage(path);
    return pfmHeader(path, file);
}

Image readPfm(const std::string& path) {
    detail::OpenedFile file = openImage(path);
    const ImageShape shape = pfmHeader(path, file);
    const long long w = shape.width, h = shape.height;
    const int c = shape.channels;
    Image image(int(w), int(h), c);
    const std::size_t row = std::size_t(w) * c;
    for (long long y = h - 1; y >= 0; --y)
        if (std::fread(image.pixels.data() + y * row, sizeof(float), row, file.file.get()) != row)
            throw ImageError(path + ": truncated PFM data");
    return image;
}

Image channels(const Image& image, int first, int count) {
    if (first < 0 || first + count > image.channels) throw ImageError("channels: out of range");
    Image out(image.width, image.height, count);
    for (std::size_t p = 0; p < std::size_t(image.width) * image.height; ++p)
        for (int c = 0; c < count; ++c) out.pixels[p * count + c] = image.pixels[p * image.channels + first + c];
    return out;
}

namespace {
void checkSame(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height || a.channels != b.channels)
        throw ImageError("images differ in size: " + std::to_string(a.width) + "x" + std::to_string(a.height) + "x" +
                         std::to_string(a.channels) + " vs " + std::to_string(b.width) + "x" +
                         std::to_string(b.height) + "x" + std::to_string(b.channels));
}
}  // namespace

ImageDifference compareImages(const Image& a, const Image& b, double threshold) {
    checkSame(a, b);
    ImageDifference d;
    std::size_t over = 0;
    const std::size_t n = std::size_t(a.width) * a.height;
    double sum = 0;
    for (std::size_t p = 0; p < n; ++p) {
        bool pixelOver = false;
        for (int c = 0; c < a.channels; ++c) {
            const double e = std::fabs(double(a.pixels[p * a.channels + c]) - b.pixels[p * a.channels + c]);
            d.maxAbs = std::max(d.maxAbs, e);
            sum += e;
            pixelOver |= e > threshold;
        }
        over += pixelOver;
    }
    d.meanAbs = n ? sum / double(n * a.channels) : 0.0;
    d.fractionOver = n ? double(over) / double(n) : 0.0;
    return d;
}

Image differenceImage(const Image& a, const Image& b, float gain) {
    checkSame(a, b);
    Image out(a.width, a.height, a.channels);
    for (std::size_t i = 0; i < a.pixels.size(); ++i) out.pixels[i] = std::fabs(a.pixels[i] - b.pixels[i]) * gain;
    return out;
}

double psnr(const Image& a, const Image& b) {
    checkSame(a, b);
    double se = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
        const double e = double(a.pixels[i]) - b.pixels[i];
        se += e * e;
    }
    const double mse = se / double(std::max<std::size_t>(a.pixels.size(), 1));
    return mse <= 0 ? INFINITY : 10.0 * std::log10(1.0 / mse);
}

}  // namespace nephele
