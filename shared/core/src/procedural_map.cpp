#include <terrain/procedural_map.h>

#include <cmath>
#include <vector>

namespace terrain {
namespace {

// SplitMix64 finaliser: a well-mixed 64-bit hash of a lattice point
std::uint64_t mix(std::uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// lattice value in [-2^16, 2^16]
std::int64_t lattice(std::uint64_t seed, int octave, std::int64_t ix, std::int64_t iy) {
    const std::uint64_t h =
        mix(seed ^ mix(static_cast<std::uint64_t>(octave) ^
                       mix(static_cast<std::uint64_t>(ix) ^ mix(static_cast<std::uint64_t>(iy)))));
    return static_cast<std::int64_t>(h >> 47) - (std::int64_t{1} << 16);
}

// smoothstep in 16.16
std::int64_t fade(std::int64_t f) {
    return (((f * f) >> 16) * ((3 << 16) - 2 * f)) >> 16;
}

std::int64_t lerp16(std::int64_t a, std::int64_t b, std::int64_t t) {
    return a + (((b - a) * t) >> 16);
}

// value noise at a point given in 16.16 lattice units, result in [-2^16, 2^16]
std::int64_t valueNoise(std::uint64_t seed, int octave, std::int64_t x16, std::int64_t y16) {
    const std::int64_t ix = x16 >> 16;
    const std::int64_t iy = y16 >> 16;
    const std::int64_t fx = fade(x16 & 0xFFFF);
    const std::int64_t fy = fade(y16 & 0xFFFF);
    const std::int64_t a =
        lerp16(lattice(seed, octave, ix, iy), lattice(seed, octave, ix + 1, iy), fx);
    const std::int64_t b =
        lerp16(lattice(seed, octave, ix, iy + 1), lattice(seed, octave, ix + 1, iy + 1), fx);
    return lerp16(a, b, fy);
}

} // namespace

Result<Terrain> makeProceduralMap(const ProceduralMapOptions& o) {
    for (double v : {o.spacing_metres, o.wavelength_metres, o.patch_tolerance_metres})
        if (!std::isfinite(v) || v <= 0.0)
            return makeError(
                ErrorCode::kOutOfRange, "procedural map lengths must be positive and finite");
    if (!std::isfinite(o.base_metres) || !std::isfinite(o.amplitude_metres) ||
        std::abs(o.base_metres) + 2.0 * std::abs(o.amplitude_metres) > 100000.0)
        return makeError(
            ErrorCode::kOutOfRange, "procedural heights must be finite and within 100 km");
    if (o.octaves < 1 || o.octaves > 16)
        return makeError(ErrorCode::kOutOfRange, "octaves must be 1..16");

    // range-check before the integer casts below
    if (o.spacing_metres > 10000.0 || o.patch_tolerance_metres > 100000.0 ||
        o.wavelength_metres > 1e9 || o.spacing_metres / o.wavelength_metres > 1e3)
        return makeError(
            ErrorCode::kOutOfRange,
            "procedural spacing must be at most 10 km and below 1000 wavelengths");
    WorldSpec spec;
    spec.width = o.width;
    spec.height = o.height;
    spec.spacing = static_cast<std::int32_t>(std::llround(o.spacing_metres * spec.units_per_metre));
    spec.patch_tolerance =
        static_cast<std::int32_t>(std::llround(o.patch_tolerance_metres * spec.units_per_metre));
    if (auto status = spec.validate(); !status)
        return status.error();

    // lattice step per vertex of the first octave, in 16.16
    const auto step16 =
        static_cast<std::int64_t>(std::llround(o.spacing_metres / o.wavelength_metres * 65536.0));
    const std::int64_t base_q = std::llround(o.base_metres * spec.units_per_metre);
    const std::int64_t amp_q = std::llround(o.amplitude_metres * spec.units_per_metre);
    std::vector<std::int32_t> samples(
        static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height));
    for (std::int32_t y = 0; y < spec.height; ++y)
        for (std::int32_t x = 0; x < spec.width; ++x) {
            std::int64_t z = 0;
            std::int64_t amp = amp_q;
            for (int octave = 0; octave < o.octaves; ++octave) {
                const std::int64_t s = step16 << octave;
                z += (valueNoise(o.seed, octave, x * s, y * s) * amp) >> 16;
                amp /= 2;
            }
            samples
                [static_cast<std::size_t>(y) * static_cast<std::size_t>(spec.width) +
                 static_cast<std::size_t>(x)] = clampHeight(base_q + z);
        }
    return Terrain::create(spec, samples);
}

} // namespace terrain
