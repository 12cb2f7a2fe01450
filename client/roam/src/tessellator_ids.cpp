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

void Tessellator::resizeDiamondState() {
    pool_.resizeBlocks(static_cast<std::size_t>(blocks_.capacity()));
    for (int g = 0; g < kGrains; ++g)
        space_.resizeChunks(g, pool_.chunkCount(g));
    space_.resizeCentres(static_cast<std::size_t>(blocks_.recordCapacity()));
    policy_.resizeIds(space_.eagerCount(), space_.pooledCounts());
}

// ---- priorities ---------------------------------------------------------------------------

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
    const std::int32_t x1 = std::min(d.centre.x + reach, geo().real_x);
    const std::int32_t y1 = std::min(d.centre.y + reach, geo().real_y);
    if (x0 >= x1 || y0 >= y1)
        return 0.0;
    Box b;
    b.lo = {x0 * geo().metres_per_lattice, y0 * geo().metres_per_lattice, window.zlo};
    b.hi = {x1 * geo().metres_per_lattice, y1 * geo().metres_per_lattice, window.zhi};
    return m.screenError(b, window.delta);
}

double Tessellator::deltaAt(LatticePoint p) const {
    const DiamondId id = idOf(p);
    if (id == kNoDiamond || !diamondAt(p).valid())
        return -1.0;
    return bounds(id).delta;
}

} // namespace terrain::roam
