// PNG files through libpng (Nephele::platform).
#include "nephele/png.hpp"

#include "nephele/limits.hpp"

#include "image_file.hpp"

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <vector>

namespace nephele {

using namespace detail;  // image_file.hpp: what PNG files share with core's PFM files

namespace {

[[noreturn]] void pngError(png_structp png, png_const_charp message) {
    auto* where = static_cast<std::string*>(png_get_error_ptr(png));
    throw ImageError(*where + ": " + message);
}
// libpng reports a size over png_set_user_limits as a warning before a vaguer "Invalid IHDR
// data": that warning is the error.
void pngWarning(png_structp png, png_const_charp message) {
    if (std::string(message).find("exceeds user limit") == std::string::npos) return;
    auto* where = static_cast<std::string*>(png_get_error_ptr(png));
    throw ImageError(*where + ": " + message + ", over the limit " + limitText(limits::kImageSide));
}

}  // namespace

void writePng(const std::string& path, const Image& image, Encoding encoding) {
    checkShape(image, path);
    static const int kTypes[] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                 PNG_COLOR_TYPE_RGBA};
    if (image.channels < 1 || image.channels > 4)
        throw ImageError(path + ": cannot write " + std::to_string(image.channels) + " channels");
    const int c = image.channels;
    const bool hasAlpha = (c == 2 || c == 4);
    std::vector<png_byte> bytes(image.pixels.size());
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        const int channel = int(i % c);
        float v = image.pixels[i];
        const bool colour = !(hasAlpha && channel == c - 1);
        if (encoding == Encoding::Srgb && colour) v = linearToSrgb(v);
        bytes[i] = png_byte(std::lround(std::clamp(std::isfinite(v) ? v : 0.0f, 0.0f, 1.0f) * 255.0f));
    }
    FilePtr file = openFile(path, "wb");
    std::string where = path;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &where, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!info) {
        png_destroy_write_struct(&png, nullptr);
        throw ImageError(path + ": libpng could not start");
    }
    try {
        png_init_io(png, file.get());
        png_set_IHDR(png, info, image.width, image.height, 8, kTypes[c], PNG_INTERLACE_NONE,
                     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        if (encoding == Encoding::Srgb) png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
        png_write_info(png, info);
        for (int y = 0; y < image.height; ++y) png_write_row(png, bytes.data() + std::size_t(y) * image.width * c);
        png_write_end(png, nullptr);
    } catch (...) {
        png_destroy_write_struct(&png, &info);
        throw;
    }
    png_destroy_write_struct(&png, &info);
    if (std::fflush(file.get()) != 0) throw ImageError(path + ": write failed: " + std::strerror(errno));
}

namespace {

// A PNG opened for reading, its header read and its transformations set (8-bit, expanded).
struct PngReader {
    detail::OpenedFile file;
    std::string where;
    png_structp png = nullptr;
    png_infop info = nullptr;

    explicit PngReader(const std::string& path) : file(openImage(path)), where(path) {
        png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &where, pngError, pngWarning);
        info = png ? png_create_info_struct(png) : nullptr;
        if (!info) {
            png_destroy_read_struct(&png, nullptr, nullptr);
            throw ImageError(path + ": libpng could not start");
        }
        try {
            png_init_io(png, file.file.get());
            // libpng's own guards: the IHDR size, and ancillary chunks (text, ICC) that inflate.
            png_set_user_limits(png, png_uint_32(limits::kImageSide.value), png_uint_32(limits::kImageSide.value));
            png_set_chunk_malloc_max(png, 8 << 20);
            png_set_chunk_cache_max(png, 1000);
            png_read_info(png, info);
            png_set_expand(png);
            png_set_strip_16(png);
            png_set_packing(png);
            passes = png_set_interlace_handling(png);  // Adam7: libpng merges the passes into whole rows
            png_read_update_info(png, info);
            shape.width = int(png_get_image_width(png, info));
            shape.height = int(png_get_image_height(png, info));
            shape.channels = int(png_get_channels(png, info));
            rowBytes = png_get_rowbytes(png, info);
            checkClaimedSize(path, std::uint64_t(shape.width), std::uint64_t(shape.height),
                             std::uint64_t(rowBytes + 1) * std::uint64_t(shape.height), file.size, true);
        } catch (...) {
            png_destroy_read_struct(&png, &info, nullptr);
            throw;
        }
    }
    ~PngReader() { png_destroy_read_struct(&png, &info, nullptr); }
    PngReader(const PngReader&) = delete;
    PngReader& operator=(const PngReader&) = delete;

    ImageShape shape;
    std::size_t rowBytes = 0;
    int passes = 1;
};

}  // namespace

ImageShape readPngShape(const std::string& path) { return PngReader(path).shape; }

namespace {

Image decode(PngReader& r, const std::string& path, std::span<const int> pick) {
    const int c = r.shape.channels, n = int(pick.size());
    for (const int k : pick)
        if (k < 0 || k >= c)
            throw ImageError(path + ": has " + std::to_string(c) + " channels, channel " + std::to_string(k) +
                             " asked for");
    Image image(r.shape.width, r.shape.height, n);
    const std::size_t w = std::size_t(r.shape.width), h = std::size_t(r.shape.height);
    auto convert = [&](std::size_t y, const png_byte* row) {
        float* out = image.pixels.data() + y * w * n;
        for (std::size_t x = 0; x < w; ++x)
            for (int k = 0; k < n; ++k) out[x * n + k] = row[x * c + pick[k]] / 255.0f;
    };
    if (r.passes == 1) {  // row by row: one row of bytes at a time
        std::vector<png_byte> row(r.rowBytes);
        for (std::size_t y = 0; y < h; ++y) {
            png_read_row(r.png, row.data(), nullptr);
            convert(y, row.data());
        }
    } else {  // Adam7: every pass adds pixels to every row, so all rows are held
        std::vector<png_byte> bytes(r.rowBytes * h);
        std::vector<png_bytep> rows(h);
        for (std::size_t y = 0; y < h; ++y) rows[y] = bytes.data() + r.rowBytes * y;
        png_read_image(r.png, rows.data());
        for (std::size_t y = 0; y < h; ++y) convert(y, rows[y]);
    }
    return image;
}

}  // namespace

Image readPng(const std::string& path, std::span<const int> pick) {
    PngReader r(path);
    return decode(r, path, pick);
}

Image readPng(const std::string& path) {
    PngReader r(path);
    const int all[] = {0, 1, 2, 3};
    return decode(r, path, std::span<const int>(all, std::size_t(r.shape.channels)));
}

}  // namespace nephele
