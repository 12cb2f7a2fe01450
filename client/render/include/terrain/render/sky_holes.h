#pragma once

// Holes in a terrain frame: sky-coloured pixels below the horizon. A closed terrain mesh drawn
// over a sky-coloured clear shows the sky only above the ground; going down each column from
// the top, once a pixel is not sky, every sky-coloured pixel after the next one is a hole (a
// missing or misplaced triangle, a crack). The check of ../shared/gpu/holes.py, in the client.

#include <terrain/io/png_image.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace terrain::render {

struct SkyHoles {
    std::int64_t count = 0;
    struct Pixel {
        int x = 0;
        int y = 0; ///< from the top
    };
    std::vector<Pixel> first; ///< the first few, column by column
};

/// `sky`: the clear colour (0..1 per channel); a pixel within 10/255 of it on every channel is
/// sky-coloured.
SkyHoles countSkyHoles(const io::RgbImage& image, glm::vec3 sky);

} // namespace terrain::render
