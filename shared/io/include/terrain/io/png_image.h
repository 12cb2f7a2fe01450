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

/// Default pixel budget of an import: 8192 x 8192 (a 16-bit image of that size needs about
/// 0.8 GB on its way to a terrain).
inline constexpr std::uint64_t kDefaultMaxPixels = std::uint64_t{8192} * 8192;

/// Reads rows one at a time, so a file that declares a huge size but holds little data fails
/// before much is allocated. Errors: kIo (cannot open), kBadFormat (not a PNG, corrupt or
/// truncated), kUnsupported (not 8/16-bit grayscale, interlaced), kOutOfRange (more pixels than
/// max_pixels, or not enough memory).
Result<GrayImage>
readGrayPng(const std::filesystem::path& path, std::uint64_t max_pixels = kDefaultMaxPixels);

/// Errors: kIo.
Status writeRgbPng(const std::filesystem::path& path, const RgbImage& image);

} // namespace terrain::io
