#pragma once

// Pixel comparisons for rendered frames: how many pixels differ, where, and by how much.

#include <terrain/io/png_image.h>

#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <optional>
#include <string>

namespace terrain::testing {

/// Largest channel difference of pixel (x, y) between two images of one size.
inline int pixelDifference(const io::RgbImage& a, const io::RgbImage& b, int x, int y) {
    const std::size_t i = (static_cast<std::size_t>(y) * a.width + x) * 3;
    int d = 0;
    for (int c = 0; c < 3; ++c)
        d = std::max(d, std::abs(int{a.rgb[i + c]} - int{b.rgb[i + c]}));
    return d;
}

struct PixelCount {
    std::int64_t counted = 0; ///< pixels where `where` held
    std::int64_t differing = 0;
    double fraction() const { return counted == 0 ? 0.0 : double(differing) / double(counted); }
};

/// Pixels (where `where(x, y)`) whose largest channel difference exceeds `threshold`.
inline PixelCount countDiffering(
    const io::RgbImage& a,
    const io::RgbImage& b,
    int threshold,
    const std::function<bool(int, int)>& where = [](int, int) { return true; }) {
    PixelCount n;
    if (a.width != b.width || a.height != b.height || a.rgb.size() != b.rgb.size()) {
        ADD_FAILURE() << "images of different sizes: " << a.width << " x " << a.height << " and "
                      << b.width << " x " << b.height;
        return n;
    }
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            if (!where(x, y))
                continue;
            ++n.counted;
            if (pixelDifference(a, b, x, y) > threshold)
                ++n.differing;
        }
    return n;
}

/// Distinct colours (8 bits per channel) in the image, up to `cap`.
inline int distinctColours(const io::RgbImage& image, int cap = 1 << 20) {
    std::vector<std::uint32_t> colours;
    colours.reserve(image.rgb.size() / 3);
    for (std::size_t i = 0; i + 2 < image.rgb.size(); i += 3)
        colours.push_back(
            std::uint32_t{image.rgb[i]} << 16 | std::uint32_t{image.rgb[i + 1]} << 8 |
            image.rgb[i + 2]);
    std::sort(colours.begin(), colours.end());
    const auto n = std::unique(colours.begin(), colours.end()) - colours.begin();
    return static_cast<int>(std::min<std::ptrdiff_t>(n, cap));
}

/// Reads any PNG as 8-bit RGB (libpng's simplified API); nothing if it cannot.
inline std::optional<io::RgbImage> readRgbPngForTest(const std::string& path) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (png_image_begin_read_from_file(&png, path.c_str()) == 0)
        return std::nullopt;
    png.format = PNG_FORMAT_RGB;
    io::RgbImage image;
    image.width = static_cast<std::int32_t>(png.width);
    image.height = static_cast<std::int32_t>(png.height);
    image.rgb.resize(PNG_IMAGE_SIZE(png));
    if (png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr) == 0) {
        png_image_free(&png);
        return std::nullopt;
    }
    return image;
}

} // namespace terrain::testing
