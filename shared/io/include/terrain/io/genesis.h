#pragma once

// The world a new game starts from (its genesis), chosen the same way by every program that
// makes one (terrain-server on a new data dir, terrain-sim, terrain-replay's soak): a DEM if one
// is named, else a grayscale PNG, else the procedural map of a seed and size.

#include <terrain/io/dem_import.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace terrain::io {

struct GenesisOptions {
    /// A DEM's sidecar JSON (dem_import.h); wins over everything else.
    std::filesystem::path dem;
    /// A 16- or 8-bit grayscale PNG: height = value * png_vertical_scale metres; needs
    /// spacing_metres.
    std::filesystem::path png;
    double png_vertical_scale = 1.0;
    /// The procedural map (procedural_map.h), when neither is named.
    std::uint64_t seed = 1;
    std::int32_t size = 1025; ///< vertices per side
    /// Grid spacing; unset: the DEM's sidecar, or 1 m for the procedural map.
    std::optional<double> spacing_metres;
    /// Patch tolerance; unset: the source's default (a DEM: spacing / 64, at least 1/32 m; the
    /// procedural map: 1/32 m).
    std::optional<double> patch_tolerance_metres;
};

struct Genesis {
    Terrain terrain;
    std::string source; ///< what it was made from, for logs and reports
};

/// Errors: those of importDem / importPng / makeProceduralMap, and kOutOfRange for a PNG without
/// a spacing.
Result<Genesis> makeGenesis(const GenesisOptions& options);

} // namespace terrain::io
