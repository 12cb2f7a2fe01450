// Lattice measures and the mapping between lattice points and diamond ids (lattice_ids.h).

#include "tessellator_internal.h"

#include <terrain/roam/lattice_ids.h>

#include <algorithm>

namespace terrain::roam {

using namespace detail;

LatticeGeometry LatticeGeometry::of(const WorldSpec& spec) {
    LatticeGeometry g;
    g.metres_per_lattice = spec.spacingMetres() / kLatticePerCell;
    g.metres_per_fine = spec.metresPerUnit() / static_cast<double>(kFineUnitsPerQuantum);
    g.grid_w = spec.paddedWidth();
    g.grid_h = spec.paddedHeight();
    g.max_x = (g.grid_w - 1) * kLatticePerCell;
    g.max_y = (g.grid_h - 1) * kLatticePerCell;
    g.real_x = spec.cellsX() * kLatticePerCell;
    g.real_y = spec.cellsY() * kLatticePerCell;
    g.grid_count = static_cast<std::uint32_t>(g.grid_w) * static_cast<std::uint32_t>(g.grid_h);
    return g;
}

Box LatticeGeometry::boxOf(const Diamond& d, const DiamondBounds& bounds) const {
    const std::int32_t r = subtreeReach(d);
    // only the real map is drawn; padding contributes nothing
    const std::int32_t x0 = std::max(d.centre.x - r, 0);
    const std::int32_t y0 = std::max(d.centre.y - r, 0);
    const std::int32_t x1 = std::min(d.centre.x + r, real_x);
    const std::int32_t y1 = std::min(d.centre.y + r, real_y);
    Box b;
    b.lo = {x0 * metres_per_lattice, y0 * metres_per_lattice, bounds.zlo};
    b.hi = {x1 * metres_per_lattice, y1 * metres_per_lattice, bounds.zhi};
    if (x0 >= x1 || y0 >= y1)
        b.lo.x = b.hi.x + 1.0; // empty
    return b;
}

LatticePoint LatticeIds::pointOf(DiamondId id) const {
    if (id < geo_.grid_count) {
        const auto w = static_cast<DiamondId>(geo_.grid_w);
        return {
            static_cast<std::int32_t>(id % w) * kLatticePerCell,
            static_cast<std::int32_t>(id / w) * kLatticePerCell};
    }
    if (id < kPooledIds) {
        const DetailBlocks::CellXY c = blocks_.recordCell(space_.recordOfCentre(id));
        return {c.x * kLatticePerCell + kCentreLocal, c.y * kLatticePerCell + kCentreLocal};
    }
    const int g = DiamondSpace::grainOfId(id);
    const std::int32_t block = pool_.blockOf(g, DiamondSpace::chunkOfId(id, g));
    const std::int32_t local =
        grainTables().diamond_local[static_cast<std::size_t>(g)][DiamondSpace::slotOfId(id, g)];
    const DetailBlocks::CellXY c = blocks_.cellOf(block);
    return {
        c.x * kLatticePerCell + local % kLatticePerCell,
        c.y * kLatticePerCell + local / kLatticePerCell};
}

} // namespace terrain::roam
