// PNG files through libpng (Nephele::platform).
#include "nephele/png.hpp"

#include "image_file.hpp"

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

namespace nephele {

using detail::checkShape;
using detail::FilePtr;
using detail::openFile;

namespace {

[[noreturn]] void pngError(png_structp png, png_const_charp message) {
    auto* where = static_cast<std::string*>(png_get_error_ptr(png));
    throw ImageError(*where + ": " + message);
}
void pngWarning(png_structp, png_const_charp) {}

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
    FilePtr file = openFile(path, "rb");
    std::string where = path;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &where, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!info) {
        png_destroy_read_struct(&png, nullptr, nullptr);
        throw ImageError(path + ": libpng could not start");
    }
    Image image;
    try {
        png_init_io(png, file.get());
        png_read_info(png, info);
        png_set_expand(png);
        png_set_strip_16(png);
        png_set_packing(png);
        png_read_update_info(png, info);
        image = Image(int(png_get_image_width(png, info)), int(png_get_image_height(png, info)),
                      int(png_get_channels(png, info)));
        std::vector<png_byte> row(png_get_rowbytes(png, info));
        for (int y = 0; y < image.height; ++y) {
            png_read_row(png, row.data(), nullptr);
            for (int i = 0; i < image.width * image.channels; ++i)
                image.pixels[std::size_t(y) * image.width * image.channels + i] = row[i] / 255.0f;
        }
    } catch (...) {
        png_destroy_read_struct(&png, &info, nullptr);
        throw;
    }
    png_destroy_read_struct(&png, &info, nullptr);
    return image;
}

}  // namespace nephele
