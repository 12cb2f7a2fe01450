#pragma once

// Constants and small helpers shared by the tessellator's translation units (bounds, mesh,
// frames). Private to terrain_roam.

#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/lattice.h>
#include <terrain/roam/lattice_ids.h>
#include <terrain/world_spec.h>

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

namespace terrain::roam::detail {

inline constexpr std::int32_t kBaseVertices = kTileVertices * kTileVertices;
/// Diamond ids per block: the cell's 16 x 16 half-open lattice (position 0 is a grid vertex).
inline constexpr std::uint32_t kDiamondsPerBlock = kLatticePerCell * kLatticePerCell;
inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

// How split/merge follows a binding triangle cap (SplitMerge::followCap): a rebuild fills this
// share of the cap; the threshold rises by kCapStepUp (up to kCapStepMax when many splits were
// refused) when the cap refuses a split, and falls by kCapStepDown while the mesh is under
// kCapLow of the cap.
inline constexpr double kCapTarget = 0.92;
inline constexpr double kCapLow = 0.8;
inline constexpr double kCapStepUp = 1.1;
inline constexpr double kCapStepMax = 2.0;
inline constexpr double kCapStepDown = 1.05;
/// A tile's index list with slack (TileMesh::hasSlack) for this many frames is shrunk, each
/// tile checked every kTileShrinkEvery frames.
inline constexpr std::uint64_t kTileSlackFrames = 600;
inline constexpr std::uint64_t kTileShrinkEvery = 64;
/// The threshold falls only this many frames after the block pool last refused a split.
inline constexpr std::uint64_t kPoolQuietFrames = 30;
/// A threshold move re-examines the candidates keyed against the old one over this many frames.
inline constexpr std::size_t kRekeyFrames = 8;
inline constexpr std::size_t kRekeyAtOnce = 16384; ///< or at least this many per frame

/// The tile a cell belongs to; -1 for the virtual cells past the grid.
inline std::int32_t tileOfCell(DetailBlocks::CellXY c, const WorldSpec& spec) {
    if (c.x < 0 || c.y < 0 || c.x >= spec.tilesX() * kTileCells ||
        c.y >= spec.tilesY() * kTileCells)
        return -1;
    return (c.y / kTileCells) * spec.tilesX() + c.x / kTileCells;
}

} // namespace terrain::roam::detail
