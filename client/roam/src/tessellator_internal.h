#pragma once

// Constants and small helpers shared by the tessellator's translation units (bounds, mesh,
// frames). Private to terrain_roam.

#include <terrain/roam/lattice.h>
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

} // namespace terrain::roam::detail
