#pragma once

// A seeded procedural map, so the main job and the tests need no file. Integer value noise
// (fractal sum of octaves), computed in fixed point: the same seed gives the same bits anywhere.
// Pure: no I/O.

#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstdint>

namespace terrain {

struct ProceduralMapOptions {
    std::uint64_t seed = 1;
    std::int32_t width = 1025;  ///< vertices
    std::int32_t height = 1025; ///< vertices
    double spacing_metres = 1.0;
    double base_metres = 40.0;        ///< mean height
    double amplitude_metres = 24.0;   ///< largest octave's amplitude
    double wavelength_metres = 256.0; ///< largest octave's feature size
    int octaves = 7;
    double patch_tolerance_metres = 1.0 / 32.0;
};

/// Errors: the spec's rules; kOutOfRange for non-finite or non-positive options.
Result<Terrain> makeProceduralMap(const ProceduralMapOptions& options);

} // namespace terrain
