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
    static const int kTypes[] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGBA};
    if (image.channels < 1 || image.channels > 4) throw ImageError(path + ": cannot write " + std::to_string(image.channels) + " channels");
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
        for (int y = 0; y < image.height; ++y)
            png_write_row(png, bytes.data() + std::size_t(y) * image.width * c);
        png_write_end(png, nullptr);
    } catch (...) {
        png_destroy_write_struct(&png, &info);
        throw;
    }
    png_destroy_write_struct(&png, &info);
    if (std::fflush(file.get()) != 0) throw ImageError(path + ": write failed: " + std::strerror(errno));
}

Image readPng(const std::string& path) {
    detail::OpenedFile file = openImage(path);
    std::string where = path;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &where, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!info) {
        png_destroy_read_struct(&png, nullptr, nullptr);
        throw ImageError(path + ": libpng could not start");
    }
    Image image;
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
        png_set_interlace_handling(png);  // Adam7: libpng merges the passes into whole rows
        png_read_update_info(png, info);
        const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
        const std::size_t rowBytes = png_get_rowbytes(png, info);
        checkClaimedSize(path, w, h, std::uint64_t(rowBytes + 1) * h, file.size, true);
        image = Image(int(w), int(h), int(png_get_channels(png, info)));
        std::vector<png_byte> bytes(rowBytes * h);
        std::vector<png_bytep> rows(h);
        for (png_uint_32 y = 0; y < h; ++y) rows[y] = bytes.data() + rowBytes * y;
        png_read_image(png, rows.data());
        const std::size_t rowValues = std::size_t(image.width) * image.channels;
        for (png_uint_32 y = 0; y < h; ++y)
            for (std::size_t i = 0; i < rowValues; ++i) image.pixels[y * rowValues + i] = rows[y][i] / 255.0f;
    } catch (...) {
        png_destroy_read_struct(&png, &info, nullptr);
        throw;
    }
    png_destroy_read_struct(&png, &info, nullptr);
    return image;
}

}  // namespace nephele
