#pragma once

// PNG reading and writing through libpng. I/O edge only.

#include <terrain/result.h>

#include <cstdint>
#include <filesystem>
#include <vector>

namespace terrain::io {

struct GrayImage {
    std::int32_t width = 0;
    std::int32_t height = 0;
    int bit_depth = 16;                ///< 8 or 16
    std::vector<std::uint16_t> pixels; ///< row-major, values as stored (no gamma applied)
};

struct RgbImage {
    std::int32_t width = 0;
    std::int32_t height = 0;
    std::vector<std::uint8_t> rgb; ///< row-major, 3 bytes per pixel
};

/// Errors: kIo (cannot open), kBadFormat (not a PNG, corrupt), kUnsupported (not grayscale).
Result<GrayImage> readGrayPng(const std::filesystem::path& path);

/// Errors: kIo.
Status writeRgbPng(const std::filesystem::path& path, const RgbImage& image);

} // namespace terrain::io
