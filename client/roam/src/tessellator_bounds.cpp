// The tessellator's diamond ids, vertex heights and nested error bounds.

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

namespace {

std::int32_t halfOfLevel(int level) {
    const int t = level % 2 == 0 ? (18 - level) / 2 : (19 - level) / 2;
    return 1 << t;
}

std::int32_t reachOfLevel(int level) {
    return (level % 2 == 0 ? 3 : 2) * halfOfLevel(level);
}

} // namespace

// ---- ids and heights ----------------------------------------------------------------------

DiamondId Tessellator::idOf(LatticePoint p) const {
    if (!insideMap(p))
        return kNoDiamond;
    if (isGridVertex(p))
        return static_cast<DiamondId>(p.y / kLatticePerCell) * static_cast<DiamondId>(grid_w_) +
               static_cast<DiamondId>(p.x / kLatticePerCell);
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

std::int64_t Tessellator::heightAt(LatticePoint p) const {
    // the eager diamonds (the grid's and the cells' centres) have grid vertices only; the
    // vertices below the grid are the blocks' (BlockBounds)
    TERRAIN_ASSERT(isGridVertex(p));
    return static_cast<std::int64_t>(
               terrain_->sample(p.x / kLatticePerCell, p.y / kLatticePerCell)) *
           kFineUnitsPerQuantum;
}

void Tessellator::resizeDiamondState() {
    pool_.resizeBlocks(static_cast<std::size_t>(blocks_.capacity()));
    for (int g = 0; g < kGrains; ++g)
        space_.resizeChunks(g, pool_.chunkCount(g));
    space_.resizeCentres(static_cast<std::size_t>(blocks_.recordCapacity()));
    policy_.resizeIds(space_.eagerCount(), space_.pooledCounts());
}

// ---- error bounds -------------------------------------------------------------------------

bool Tessellator::storeBounds(DiamondId id, float delta, float zlo, float zhi) {
    TERRAIN_ASSERT(id < grid_count_);
    return space_.storeBounds(id, {delta, zlo, zhi});
}

double Tessellator::childBounds(LatticePoint c, double& zlo, double& zhi) const {
    const DiamondId id = idOf(c);
    if (id != kNoDiamond) {
        const Bounds b = bounds(id);
        zlo = std::min(zlo, static_cast<double>(b.zlo));
        zhi = std::max(zhi, static_cast<double>(b.zhi));
        TERRAIN_ASSERT(id < kPooled); // the grid's children are grid vertices and centres
        return b.delta;
    }
    // a cell without a record is drawn with its base triangles, which are the true surface
    const Diamond d = diamondAt(c);
    for (const LatticePoint corner : hypotenuseEnds(d)) {
        const double z = static_cast<double>(heightAt(corner)) * metres_per_fine_;
        zlo = std::min(zlo, z);
        zhi = std::max(zhi, z);
    }
    for (const LatticePoint corner : apexes(d))
        if (insideMap(corner)) {
            const double z = static_cast<double>(heightAt(corner)) * metres_per_fine_;
            zlo = std::min(zlo, z);
            zhi = std::max(zhi, z);
        }
    return 0.0;
}

namespace {

/// The part of a diamond's bound its own vertices give: the range of its centre, hypotenuse ends
/// and apexes (fine units), and how far the centre is from the hypotenuse the unsplit triangles
/// interpolate (metres). `height` reads a vertex; `inside` says whether an apex is on the map.
struct OwnSpan {
    std::int64_t lo = 0;
    std::int64_t hi = 0;
    double local = 0.0;
};

template <class Height, class Inside>
OwnSpan ownSpan(const Diamond& d, const Height& height, const Inside& inside, double per_fine) {
    const auto ends = hypotenuseEnds(d);
    const std::int64_t zc = height(d.centre);
    const std::int64_t z0 = height(ends[0]);
    const std::int64_t z1 = height(ends[1]);
    OwnSpan s{std::min({zc, z0, z1}), std::max({zc, z0, z1}), 0.0};
    for (const LatticePoint a : apexes(d))
        if (inside(a)) {
            const std::int64_t z = height(a);
            s.lo = std::min(s.lo, z);
            s.hi = std::max(s.hi, z);
        }
    s.local = static_cast<double>(std::llabs(2 * zc - z0 - z1)) * 0.5 * per_fine;
    return s;
}

} // namespace

namespace {

/// Range (fine units) of a cell without a record: its base triangles, exact.
double cornerLo(const CellCorners& c) {
    return static_cast<double>(std::min({c.h00, c.h10, c.h01, c.h11})) * kFineUnitsPerQuantum;
}

double cornerHi(const CellCorners& c) {
    return static_cast<double>(std::max({c.h00, c.h10, c.h01, c.h11})) * kFineUnitsPerQuantum;
}

} // namespace

float Tessellator::cellCap(std::int32_t cx, std::int32_t cy) const {
    const std::int32_t r = blocks_.recordOf(cx, cy);
    if (r < 0)
        return 0.0f;
    return roundUp(static_cast<double>(blocks_.cellError(r)) * metres_per_fine_);
}

Tessellator::Bounds Tessellator::centreBounds(std::int32_t record) const {
    // the centre's triangles are the cell's base triangles, and its descendants (children across
    // the cell's borders, theirs shrinking towards its corners) lie in the 3 x 3 cells around
    // it: any triangle there is within the cellError of its cell, and every vertex within its
    // cell's range (DetailBlocks::summarise). Derived, not stored: records are many.
    const DetailBlocks::CellXY c = blocks_.recordCell(record);
    if (c.x > grid_w_ - 2 || c.y > grid_h_ - 2)
        return {}; // a virtual cell's centre is off the map
    return windowBounds(c.x, c.y);
}

Tessellator::Bounds Tessellator::windowBounds(std::int32_t cx, std::int32_t cy) const {
    const WindowBound w = windowBound(cx, cy);
    return space_.codec().outward(
        {w.cap, roundDown(w.lo * metres_per_fine_ - w.cap),
         roundUp(w.hi * metres_per_fine_ + w.cap)});
}

Tessellator::WindowBound Tessellator::windowBound(std::int32_t cx, std::int32_t cy) const {
    WindowBound w;
    for (std::int32_t y = cy - 1; y <= cy + 1; ++y)
        for (std::int32_t x = cx - 1; x <= cx + 1; ++x) {
            if (x < 0 || y < 0 || x > grid_w_ - 2 || y > grid_h_ - 2)
                continue; // no surface past the padded grid
            w.cap = std::max(w.cap, cellCap(x, y));
            if (const std::int32_t r = blocks_.recordOf(x, y); r >= 0) {
                w.lo = std::min(w.lo, static_cast<double>(blocks_.vertexLo(r)));
                w.hi = std::max(w.hi, static_cast<double>(blocks_.vertexHi(r)));
            } else {
                const CellCorners k = terrain_->corners(x, y);
                w.lo = std::min(w.lo, cornerLo(k));
                w.hi = std::max(w.hi, cornerHi(k));
            }
        }
    return w;
}

bool Tessellator::computeBounds(const Diamond& d, DiamondId id) {
    // a diamond of the grid (levels 0-11): its vertices are grid vertices, its children grid
    // vertices or, at level 11, the centres of the cells around it
    TERRAIN_ASSERT(d.level < kCellTriangleLevel && id < grid_count_);
    const OwnSpan own = ownSpan(
        d, [&](LatticePoint p) { return heightAt(p); },
        [&](LatticePoint p) { return insideMap(p); }, metres_per_fine_);
    double child = 0.0;
    double lo = kInfinity;
    double hi = -kInfinity;
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i)
        if (insideMap(kids[idx(i)]))
            child = std::max(child, childBounds(kids[idx(i)], lo, hi));
    // the box widened by the bound still holds the surface over the diamond and every
    // descendant's box
    const float kept = roundUp(own.local + child);
    const double widen = kept;
    return storeBounds(
        id, kept, roundDown(std::min(static_cast<double>(own.lo) * metres_per_fine_ - widen, lo)),
        roundUp(std::max(static_cast<double>(own.hi) * metres_per_fine_ + widen, hi)));
}

void Tessellator::boundBlocks(std::span<const std::int32_t> blocks, bool collect) {
    // one BlockBounds pass per square of cells, so that a pass's scratch stays small however
    // scattered the blocks are (a pass spans its cells' bounding box)
    constexpr std::int32_t kSquare = 16;
    pass_blocks_.assign(blocks.begin(), blocks.end());
    const auto square = [&](std::int32_t b) {
        const DetailBlocks::CellXY c = blocks_.cellOf(b);
        return std::pair{c.y / kSquare, c.x / kSquare};
    };
    std::sort(pass_blocks_.begin(), pass_blocks_.end(), [&](std::int32_t a, std::int32_t b) {
        return std::pair{square(a), a} < std::pair{square(b), b};
    });
    const BlockGeometry geometry{
        metres_per_fine_, grid_w_, grid_h_, spec_.cellsX(), spec_.cellsY()};
    bounded_cell_ = {}; // the scratch no longer holds a single block's pass
    for (std::size_t first = 0; first < pass_blocks_.size();) {
        std::size_t last = first;
        pass_cells_.clear();
        while (last < pass_blocks_.size() &&
               square(pass_blocks_[last]) == square(pass_blocks_[first]))
            pass_cells_.push_back(blocks_.cellOf(pass_blocks_[last++]));
        block_bounds_.compute(*terrain_, blocks_, geometry, pass_cells_);
        for (std::size_t i = first; i < last; ++i) {
            const std::int32_t b = pass_blocks_[i];
            unsigned mask = 0;
            for (int g = 0; g < kGrains; ++g)
                if (pool_.chunkOf(b, g) >= 0)
                    mask |= 1u << g;
            storeGrains(i - first, b, mask, collect);
            if (prefetch_view_ != nullptr)
                prefetchGrains(i - first, b);
        }
        first = last;
    }
}

void Tessellator::storeGrains(
    std::size_t i, std::int32_t block, unsigned grain_mask, bool collect) {
    const GrainTables& tables = grainTables();
    block_bounds_.heights(i, heights_scratch_);
    storeHeights(block, grain_mask);
    for (int g = 0; g < kGrains; ++g) {
        if ((grain_mask & (1u << g)) == 0)
            continue;
        const std::int32_t chunk = pool_.chunkOf(block, g);
        const auto diamonds = static_cast<std::size_t>(kGrainDiamonds[static_cast<std::size_t>(g)]);
        for (std::size_t slot = 0; slot < diamonds; ++slot) {
            const std::uint8_t local = tables.diamond_local[static_cast<std::size_t>(g)][slot];
            if (g == 0 && (local == 0 || local == kCentreLocal * kLatticePerCell + kCentreLocal))
                continue; // the grid vertex and the (eager) centre
            const DiamondId id = grainId(g, chunk, static_cast<std::uint32_t>(slot));
            if (space_.storeBounds(id, block_bounds_.bounds(i, local)) && collect)
                recomputed_.push_back(id);
        }
    }
}

void Tessellator::storeHeights(std::int32_t block, unsigned grain_mask) {
    const GrainTables& tables = grainTables();
    for (int g = 0; g < kGrains; ++g) {
        const std::int32_t chunk = pool_.chunkOf(block, g);
        if ((grain_mask & (1u << g)) == 0 || chunk < 0)
            continue;
        const auto vertices = static_cast<std::size_t>(kGrainVertices[static_cast<std::size_t>(g)]);
        const auto& local = tables.vertex_local[static_cast<std::size_t>(g)];
        std::int64_t lowest = heights_scratch_[local[0]];
        for (std::size_t v = 1; v < vertices; ++v)
            lowest = std::min(lowest, heights_scratch_[local[v]]);
        bool moved = pool_.base(g, chunk) != lowest;
        pool_.base(g, chunk) = lowest;
        const std::span<std::uint32_t> heights = pool_.heights(g, chunk);
        for (std::size_t v = 0; v < vertices; ++v) {
            const auto h = static_cast<std::uint32_t>(heights_scratch_[local[v]] - lowest);
            std::uint32_t& stored = heights[v];
            moved = moved || stored != h;
            stored = h;
        }
        // the tile's vertex array changed: a renderer that took its version before must look
        // again (heights freshened after the op's own bump, or by a later bounds pass)
        if (moved)
            if (const std::int32_t tile = tileOfCell(blocks_.cellOf(block)); tile >= 0) {
                vertices_.bumpVersion(tile);
                if (const std::int32_t segment = pool_.segment(g, chunk); segment >= 0) {
                    const std::uint32_t first = vertices_.firstVertex(tile, segment);
                    vertices_.mark(tile, first, first + static_cast<std::uint32_t>(vertices));
                }
            }
    }
}

void Tessellator::freshenHeights() {
    // the blocks the budget left stale: their heights now, at their grains' vertices only
    stale_.takeHeights(heights_due_);
    for (const std::int32_t b : heights_due_) {
        const BlockPool::Chunks& chunks = pool_.chunksOf(b);
        const std::int32_t stride = chunks[2] >= 0 ? 1 : chunks[1] >= 0 ? 2 : 4;
        const DetailBlocks::CellXY c = blocks_.cellOf(b);
        fillCellHeights(*terrain_, c.x, c.y, heights_scratch_, stride);
        storeHeights(b, 7u);
    }
}

std::int64_t Tessellator::drainStale(std::int64_t budget) {
    // oldest first; a block evicted since is skipped, and one made since has its bounds from
    // the terrain as it is; the pass stores their heights too
    stale_.take(budget, pass_);
    if (pass_.empty())
        return 0;
    recomputed_.clear();
    boundBlocks(pass_, true);
    if (initialized_ && !needs_rebuild_)
        for (const DiamondId id : recomputed_)
            refreshCandidate(id);
    return static_cast<std::int64_t>(pass_.size());
}

void Tessellator::recomputeBounds(CellRect cells, bool all, bool collect) {
    // resident blocks whose 3 x 3 window meets the change, then the centres (their four edge
    // neighbours), then the grid
    const CellRect around = all ? CellRect{0, 0, blocks_.cellsX() - 1, blocks_.cellsY() - 1}
                                : CellRect{
                                      std::max(0, cells.x0 - 1), std::max(0, cells.y0 - 1),
                                      std::min(blocks_.cellsX() - 1, cells.x1 + 1),
                                      std::min(blocks_.cellsY() - 1, cells.y1 + 1)};
    // (after an op the resident blocks' bounds wait in stale_, within the frames' budget)
    if (all) {
        pass_.clear();
        for (std::int32_t b = 0; b < blocks_.capacity(); ++b)
            if (blocks_.inUse(b))
                pass_.push_back(b);
        if (!pass_.empty())
            boundBlocks(pass_, collect);
    }
    // the centres' bounds follow from the records; their candidates are re-examined
    if (all) {
        // the grid pass reads every centre about four times: each is computed once for it
        centre_cache_.resize(static_cast<std::size_t>(blocks_.recordCapacity()));
        for (std::int32_t r = 0; r < blocks_.recordCapacity(); ++r)
            centre_cache_[idx(r)] = blocks_.recordInUse(r) ? centreBounds(r) : Bounds{};
    } else if (collect) {
        // terrainChanged() kept their bounds from before the change
        std::size_t i = 0;
        for (std::int32_t cy = centre_rect_.y0; cy <= centre_rect_.y1; ++cy)
            for (std::int32_t cx = centre_rect_.x0; cx <= centre_rect_.x1; ++cx, ++i)
                if (const std::int32_t r = blocks_.recordOf(cx, cy); r >= 0) {
                    const Bounds before = centre_before_[i];
                    const Bounds now = centreBounds(r);
                    if (before.delta != now.delta || before.zlo != now.zlo || before.zhi != now.zhi)
                        recomputed_.push_back(centreId(r));
                }
    }
    const std::int32_t lx0 = all ? 0 : around.x0 * kLatticePerCell;
    const std::int32_t ly0 = all ? 0 : around.y0 * kLatticePerCell;
    const std::int32_t lx1 = all ? max_x_ : (around.x1 + 1) * kLatticePerCell;
    const std::int32_t ly1 = all ? max_y_ : (around.y1 + 1) * kLatticePerCell;
    for (int level = kCellTriangleLevel - 1; level >= 0; --level) {
        const std::int32_t h = halfOfLevel(level);
        const std::int32_t reach = reachOfLevel(level);
        const std::int32_t x0 = std::max(0, (lx0 - reach) / h * h);
        const std::int32_t y0 = std::max(0, (ly0 - reach) / h * h);
        const std::int32_t x1 = std::min(max_x_, lx1 + reach);
        const std::int32_t y1 = std::min(max_y_, ly1 + reach);
        for (std::int32_t y = y0; y <= y1; y += h)
            for (std::int32_t x = x0; x <= x1; x += h) {
                const Diamond d = diamondAt({x, y});
                if (d.level != level)
                    continue;
                const DiamondId id = idOf(d.centre);
                if (computeBounds(d, id) && collect)
                    recomputed_.push_back(id);
            }
    }
    std::vector<Bounds>().swap(centre_cache_);
}

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
    const Bounds window = windowBounds(d.centre.x / kLatticePerCell, d.centre.y / kLatticePerCell);
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
