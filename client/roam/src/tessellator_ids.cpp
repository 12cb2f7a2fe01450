// The tessellator's diamond ids (to and from lattice points, materialising blocks on demand)
// and the priorities the policy orders them by.

#include "float_rounding.h"
#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/fixed_point.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace terrain::roam {

using namespace detail;

// ---- ids ----------------------------------------------------------------------------------

DiamondId Tessellator::idOf(LatticePoint p) const {
    if (!insideMap(p))
        return kNoDiamond;
    if (isGridVertex(p))
        return gridVertexId(p, grid_w_);
    const std::int32_t record = blocks_.recordOf(p.x / kLatticePerCell, p.y / kLatticePerCell);
    if (record < 0)
        return kNoDiamond;
    const std::int32_t k = p.x % kLatticePerCell;
    const std::int32_t l = p.y % kLatticePerCell;
    if (k == kCentreLocal && l == kCentreLocal)
        return centreId(record);
    const std::int32_t block = blocks_.blockOfRecord(record);
    if (block < 0)
        return kNoDiamond;
    return pooledId(block, static_cast<std::uint32_t>(l * kLatticePerCell + k));
}

DiamondId Tessellator::pooledId(std::int32_t block, std::uint32_t local) const {
    const int g = grainOf(
        static_cast<std::int32_t>(local % kLatticePerCell),
        static_cast<std::int32_t>(local / kLatticePerCell));
    const std::int32_t chunk = pool_.chunkOf(block, g);
    if (chunk < 0)
        return kNoDiamond;
    return grainId(g, chunk, grainTables().diamond_slot[local]);
}

DiamondId Tessellator::resolve(LatticePoint p) {
    const DiamondId id = idOf(p);
    if (id != kNoDiamond) {
        if (id >= kPooled)
            markUsed(id);
        return id;
    }
    if (!insideMap(p) || isGridVertex(p))
        return kNoDiamond;
    const std::int32_t record = blocks_.recordOf(p.x / kLatticePerCell, p.y / kLatticePerCell);
    if (record < 0)
        return kNoDiamond;
    std::int32_t block = blocks_.blockOfRecord(record);
    if (block < 0 && (block = materialise(record)) < 0)
        return kNoDiamond; // the pool refused
    const int g = grainOf(p.x % kLatticePerCell, p.y % kLatticePerCell);
    if (pool_.chunkOf(block, g) < 0)
        materialiseGrain(block, g);
    const DiamondId made = idOf(p);
    if (made != kNoDiamond && made >= kPooled)
        markUsed(made);
    return made;
}

LatticePoint Tessellator::pointOf(DiamondId id) const {
    if (id < grid_count_) {
        const auto w = static_cast<DiamondId>(grid_w_);
        return {
            static_cast<std::int32_t>(id % w) * kLatticePerCell,
            static_cast<std::int32_t>(id / w) * kLatticePerCell};
    }
    if (id < kPooled) {
        const DetailBlocks::CellXY c =
            blocks_.recordCell(static_cast<std::int32_t>(id - grid_count_));
        return {c.x * kLatticePerCell + kCentreLocal, c.y * kLatticePerCell + kCentreLocal};
    }
    const int g = grainOfId(id);
    const std::int32_t block = pool_.blockOf(g, DiamondSpace::chunkOfId(id, g));
    const std::int32_t local =
        grainTables().diamond_local[static_cast<std::size_t>(g)][DiamondSpace::slotOfId(id, g)];
    const DetailBlocks::CellXY c = blocks_.cellOf(block);
    return {
        c.x * kLatticePerCell + local % kLatticePerCell,
        c.y * kLatticePerCell + local / kLatticePerCell};
}

void Tessellator::resizeDiamondState() {
    pool_.resizeBlocks(static_cast<std::size_t>(blocks_.capacity()));
    for (int g = 0; g < kGrains; ++g)
        space_.resizeChunks(g, pool_.chunkCount(g));
    space_.resizeCentres(static_cast<std::size_t>(blocks_.recordCapacity()));
    policy_.resizeIds(space_.eagerCount(), space_.pooledCounts());
}

// ---- priorities ---------------------------------------------------------------------------

Box Tessellator::boxOf(const Diamond& d, const Bounds& bounds) const {
    const std::int32_t r = subtreeReach(d);
    // only the real map is drawn; padding contributes nothing
    const std::int32_t x0 = std::max(d.centre.x - r, 0);
    const std::int32_t y0 = std::max(d.centre.y - r, 0);
    const std::int32_t x1 = std::min(d.centre.x + r, real_x_);
    const std::int32_t y1 = std::min(d.centre.y + r, real_y_);
    Box b;
    b.lo = {x0 * metres_per_lattice_, y0 * metres_per_lattice_, bounds.zlo};
    b.hi = {x1 * metres_per_lattice_, y1 * metres_per_lattice_, bounds.zhi};
    if (x0 >= x1 || y0 >= y1)
        b.lo.x = b.hi.x + 1.0; // empty
    return b;
}

double Tessellator::priority(const ViewMetric& m, const Diamond& d, DiamondId id) const {
    return priority(m, d, bounds(id));
}

double Tessellator::priority(const ViewMetric& m, const Diamond& d, const Bounds& bounds_of) const {
    const Box b = boxOf(d, bounds_of);
    if (b.lo.x > b.hi.x)
        return 0.0;
    return m.screenError(b, bounds_of.delta);
}

double Tessellator::recordPriority(const ViewMetric& m, const Diamond& d) const {
    // the records of the cells its subtree reaches bound its delta and every vertex of its
    // subtree, so this is at least the priority its block would give
    // its descendants reach at most the 3 x 3 cells around its cell (see computeCentreBounds)
    // packed as the centre's: the block's own bounds, packed, stay within it
    const Bounds window =
        bounds_.windowBounds(d.centre.x / kLatticePerCell, d.centre.y / kLatticePerCell);
    if (window.zlo > window.zhi)
        return 0.0; // no cell of the window has a surface
    const std::int32_t reach = subtreeReach(d);
    const std::int32_t x0 = std::max(d.centre.x - reach, 0);
    const std::int32_t y0 = std::max(d.centre.y - reach, 0);
    const std::int32_t x1 = std::min(d.centre.x + reach, real_x_);
    const std::int32_t y1 = std::min(d.centre.y + reach, real_y_);
    if (x0 >= x1 || y0 >= y1)
        return 0.0;
    Box b;
    b.lo = {x0 * metres_per_lattice_, y0 * metres_per_lattice_, window.zlo};
    b.hi = {x1 * metres_per_lattice_, y1 * metres_per_lattice_, window.zhi};
    return m.screenError(b, window.delta);
}

double Tessellator::deltaAt(LatticePoint p) const {
    const DiamondId id = idOf(p);
    if (id == kNoDiamond || !diamondAt(p).valid())
        return -1.0;
    return bounds(id).delta;
}

} // namespace terrain::roam
