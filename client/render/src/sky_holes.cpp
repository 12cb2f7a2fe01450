#include <terrain/render/sky_holes.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace terrain::render {

SkyHoles countSkyHoles(const io::RgbImage& image, glm::vec3 sky) {
    constexpr int kTolerance = 10;
    constexpr std::size_t kKept = 8;
    const int ref[3] = {
        static_cast<int>(std::lround(std::clamp(sky.x, 0.0f, 1.0f) * 255.0f)),
        static_cast<int>(std::lround(std::clamp(sky.y, 0.0f, 1.0f) * 255.0f)),
        static_cast<int>(std::lround(std::clamp(sky.z, 0.0f, 1.0f) * 255.0f))};
    const auto isSky = [&](int x, int y) {
        const std::size_t i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) +
                               static_cast<std::size_t>(x)) *
                              3;
        for (int c = 0; c < 3; ++c)
            if (std::abs(int{image.rgb[i + static_cast<std::size_t>(c)]} - ref[c]) >= kTolerance)
                return false;
        return true;
    };
    SkyHoles holes;
    for (int x = 0; x < image.width; ++x) {
        int y = 0;
        while (y < image.height && isSky(x, y))
            ++y;
        // the next pixel may still blend into the sky along the horizon
        for (y += 2; y < image.height; ++y)
            if (isSky(x, y)) {
                ++holes.count;
                if (holes.first.size() < kKept)
                    holes.first.push_back({x, y});
            }
    }
    return holes;
}

} // namespace terrain::render
