#pragma once

// Where a diamond lies and which id it has now.
//
// LatticeGeometry: a world's measures in lattice units (lattice.h), derived from its spec once:
// the padded map the lattice covers, the real map that is drawn, metres per lattice and fine
// unit; and the two questions every part asks of them (is a point on the map, is a triangle
// drawn), with a diamond's box in metres.
//
// LatticeIds: the mapping between lattice points and diamond ids (diamond_id.h). A grid vertex's
// id is fixed, a detail cell's centre has its record's, and a finer point has one only while its
// cell's block holds the grain of that point (block_grains.h), so the mapping reads the records
// (DetailBlocks), the pool's chunks (BlockPool) and the id layout (DiamondSpace).
// Owns: the geometry. Reads, never changes: the records, the pool, the diamond space; it never
// makes a block (the tessellator's resolve does). Pure, single-threaded.

#include <terrain/roam/block_grains.h>
#include <terrain/roam/block_pool.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/diamond_id.h>
#include <terrain/roam/diamond_space.h>
#include <terrain/roam/lattice.h>
#include <terrain/roam/packed_bounds.h>
#include <terrain/world_spec.h>

#include <algorithm>
#include <cstdint>

namespace terrain::roam {

/// Local position (x and y) of a cell's centre diamond, whose triangles are its base triangles.
inline constexpr std::int32_t kCentreLocal = kLatticePerCell / 2;

/// The id of grid vertex `p` (diamond_id.h: the grid's ids come first, row by row).
inline DiamondId gridVertexId(LatticePoint p, std::int32_t grid_w) {
    return static_cast<DiamondId>(p.y / kLatticePerCell) * static_cast<DiamondId>(grid_w) +
           static_cast<DiamondId>(p.x / kLatticePerCell);
}

struct LatticeGeometry {
    /// The measures of `spec`'s map.
    static LatticeGeometry of(const WorldSpec& spec);

    double metres_per_lattice = 0.0;
    double metres_per_fine = 0.0; ///< metres per height fine unit
    std::int32_t grid_w = 0;      ///< grid vertices across the padded map
    std::int32_t grid_h = 0;
    std::int32_t max_x = 0; ///< lattice extent of the padded map
    std::int32_t max_y = 0;
    std::int32_t real_x = 0; ///< lattice extent of the real map
    std::int32_t real_y = 0;
    std::uint32_t grid_count = 0; ///< grid_w * grid_h: the grid's ids

    bool insideMap(LatticePoint p) const {
        return p.x >= 0 && p.y >= 0 && p.x <= max_x && p.y <= max_y;
    }
    /// Whether the triangle covers any of the real map (only that is drawn; padding is not).
    bool emitted(const Triangle& t) const {
        const std::int32_t min_x = std::min({t.apex.x, t.left.x, t.right.x});
        const std::int32_t min_y = std::min({t.apex.y, t.left.y, t.right.y});
        return min_x < real_x && min_y < real_y;
    }
    /// The box (metres) holding everything the diamond's refinement can produce on the real
    /// map, with `bounds`' z range; empty (lo.x > hi.x) where its reach misses the real map.
    Box boxOf(const Diamond& d, const DiamondBounds& bounds) const;
};

class LatticeIds {
  public:
    /// The parts it reads; they outlive it (the tessellator owns them all).
    LatticeIds(const DetailBlocks& blocks, const BlockPool& pool, const DiamondSpace& space)
        : blocks_(blocks), pool_(pool), space_(space) {}
    LatticeIds(const LatticeIds&) = delete;
    LatticeIds& operator=(const LatticeIds&) = delete;

    /// A world's measures from now on.
    void reset(const LatticeGeometry& geometry) { geo_ = geometry; }
    const LatticeGeometry& geometry() const { return geo_; }

    /// The id of the diamond centred at `p`; kNoDiamond off the map, in a cell without a record,
    /// or in a cell whose block does not hold the point's grain.
    DiamondId idOf(LatticePoint p) const;
    /// The id of diamond `local` (l * 16 + k) of `block`, or kNoDiamond if its grain is not
    /// resident.
    DiamondId pooledId(std::int32_t block, std::uint32_t local) const;
    /// The centre of the diamond `id` (which must be in use).
    LatticePoint pointOf(DiamondId id) const;
    /// Whether the diamond centred at `p` exists and is split.
    bool active(LatticePoint p) const { return space_.active(idOf(p)); }
    const DiamondSpace& space() const { return space_; }

  private:
    const DetailBlocks& blocks_;
    const BlockPool& pool_;
    const DiamondSpace& space_;
    LatticeGeometry geo_;
};

// inline: the lattice walk asks for ids per diamond it looks at
inline DiamondId LatticeIds::idOf(LatticePoint p) const {
    if (!geo_.insideMap(p))
        return kNoDiamond;
    if (isGridVertex(p))
        return gridVertexId(p, geo_.grid_w);
    const std::int32_t record = blocks_.recordOf(p.x / kLatticePerCell, p.y / kLatticePerCell);
    if (record < 0)
        return kNoDiamond;
    const std::int32_t k = p.x % kLatticePerCell;
    const std::int32_t l = p.y % kLatticePerCell;
    if (k == kCentreLocal && l == kCentreLocal)
        return space_.centreId(record);
    const std::int32_t block = blocks_.blockOfRecord(record);
    if (block < 0)
        return kNoDiamond;
    return pooledId(block, static_cast<std::uint32_t>(l * kLatticePerCell + k));
}

inline DiamondId LatticeIds::pooledId(std::int32_t block, std::uint32_t local) const {
    const int g = grainOf(
        static_cast<std::int32_t>(local % kLatticePerCell),
        static_cast<std::int32_t>(local / kLatticePerCell));
    const std::int32_t chunk = pool_.chunkOf(block, g);
    if (chunk < 0)
        return kNoDiamond;
    return DiamondSpace::pooledId(g, chunk, grainTables().diamond_slot[local]);
}

} // namespace terrain::roam
