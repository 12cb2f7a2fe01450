#pragma once

#include <terrain/fixed_point.h>
#include <terrain/result.h>

#include <cstdint>

namespace terrain {

/// Cells per tile side. A tile holds (kTileCells + 1)^2 vertices; edge vertices are shared with
/// the neighbouring tile. Tiles are the unit of hashing, snapshot chunks and client buffers.
inline constexpr int kTileCells = 64;
inline constexpr int kTileVertices = kTileCells + 1;

/// Limits on map shape. Larger maps are possible in principle; these keep every index in int32
/// and every fixed-point intermediate in int64.
inline constexpr int kMaxMapVertices = 1 << 15; // per side
inline constexpr std::int32_t kMaxUnitsPerMetre = 1 << 16;

/// Everything that defines a world besides its samples and patches. Server and every client
/// must hold the same spec; it is part of the snapshot header and of the world hash.
struct WorldSpec {
    std::int32_t width = 0;                               ///< vertices along x (columns), >= 2
    std::int32_t height = 0;                              ///< vertices along y (rows), >= 2
    std::int32_t spacing = kDefaultUnitsPerMetre;         ///< grid spacing in quanta (> 0)
    std::int32_t units_per_metre = kDefaultUnitsPerMetre; ///< quanta per metre
    /// A cell gets a detail patch when the base triangles would be more than this far (quanta,
    /// vertically) from the deformed surface, and loses it when they are within it again.
    std::int32_t patch_tolerance = kDefaultUnitsPerMetre / 32;

    std::int32_t cellsX() const { return width - 1; }
    std::int32_t cellsY() const { return height - 1; }
    std::int32_t tilesX() const { return (cellsX() + kTileCells - 1) / kTileCells; }
    std::int32_t tilesY() const { return (cellsY() + kTileCells - 1) / kTileCells; }
    std::int32_t tileCount() const { return tilesX() * tilesY(); }
    /// Internal grid, padded so that every tile is full.
    std::int32_t paddedWidth() const { return tilesX() * kTileCells + 1; }
    std::int32_t paddedHeight() const { return tilesY() * kTileCells + 1; }

    double metresPerUnit() const { return 1.0 / units_per_metre; }
    double spacingMetres() const { return static_cast<double>(spacing) / units_per_metre; }
    /// Map extent in metres along x and y (vertex 0 at 0, vertex width-1 at extentX()).
    double extentX() const { return cellsX() * spacingMetres(); }
    double extentY() const { return cellsY() * spacingMetres(); }

    /// Checks every rule above; the error names the one broken.
    Status validate() const;

    friend bool operator==(const WorldSpec&, const WorldSpec&) = default;
};

} // namespace terrain
