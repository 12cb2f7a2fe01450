// The bounds along an op's paths: the grid's diamonds from their vertices and children, the
// centres from their cells' records, the blocks' grains from BlockBounds passes.

#include "float_rounding.h"
#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/fixed_point.h>
#include <terrain/roam/bounds_update.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <utility>

namespace terrain::roam {

using namespace detail;

namespace {

std::size_t idx(std::int64_t v) {
    return static_cast<std::size_t>(v);
}

std::int32_t halfOfLevel(int level) {
    const int t = level % 2 == 0 ? (18 - level) / 2 : (19 - level) / 2;
    return 1 << t;
}

std::int32_t reachOfLevel(int level) {
    return (level % 2 == 0 ? 3 : 2) * halfOfLevel(level);
}

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

/// Range (fine units) of a cell without a record: its base triangles, exact.
double cornerLo(const CellCorners& c) {
    return static_cast<double>(std::min({c.h00, c.h10, c.h01, c.h11})) * kFineUnitsPerQuantum;
}

double cornerHi(const CellCorners& c) {
    return static_cast<double>(std::max({c.h00, c.h10, c.h01, c.h11})) * kFineUnitsPerQuantum;
}

} // namespace

BoundsUpdate::BoundsUpdate(
    const DetailBlocks& blocks, BlockPool& pool, DiamondSpace& space, TileVertexArrays& vertices)
    : blocks_(blocks), pool_(pool), space_(space), vertices_(vertices) {}

void BoundsUpdate::reset(const Terrain& terrain, const Geometry& geometry) {
    terrain_ = &terrain;
    spec_ = geometry.spec;
    metres_per_fine_ = geometry.metres_per_fine;
    grid_w_ = spec_.paddedWidth();
    grid_h_ = spec_.paddedHeight();
    max_x_ = geometry.max_x;
    max_y_ = geometry.max_y;
    bounded_cell_ = {};
    stale_.clear();
    moved_.clear();
}

std::size_t BoundsUpdate::memoryBytes() const {
    std::size_t bytes = kernel_.memoryBytes() + centre_cache_.capacity() * sizeof(DiamondBounds);
    for (const PassScratch& s : scratch_)
        bytes += s.kernel.memoryBytes() + s.moved.capacity() * sizeof(DiamondId) +
                 s.marks.capacity() * sizeof(VertexMark);
    return bytes;
}

std::int32_t BoundsUpdate::tileOfCell(DetailBlocks::CellXY c) const {
    return detail::tileOfCell(c, spec_);
}

std::int64_t BoundsUpdate::heightAt(LatticePoint p) const {
    // the eager diamonds (the grid's and the cells' centres) have grid vertices only; the
    // vertices below the grid are the blocks' (BlockBounds)
    TERRAIN_ASSERT(isGridVertex(p));
    return static_cast<std::int64_t>(
               terrain_->sample(p.x / kLatticePerCell, p.y / kLatticePerCell)) *
           kFineUnitsPerQuantum;
}

DiamondId BoundsUpdate::eagerId(LatticePoint p) const {
    if (!insideMap(p))
        return kNoDiamond;
    if (isGridVertex(p))
        return gridVertexId(p, grid_w_);
    TERRAIN_ASSERT(p.x % kLatticePerCell == kCentreLocal && p.y % kLatticePerCell == kCentreLocal);
    const std::int32_t record = blocks_.recordOf(p.x / kLatticePerCell, p.y / kLatticePerCell);
    return record < 0 ? kNoDiamond : space_.centreId(record);
}

// ---- derived bounds -----------------------------------------------------------------------

float BoundsUpdate::cellCap(std::int32_t cx, std::int32_t cy) const {
    const std::int32_t r = blocks_.recordOf(cx, cy);
    if (r < 0)
        return 0.0f;
    return roundUp(static_cast<double>(blocks_.cellError(r)) * metres_per_fine_);
}

DiamondBounds BoundsUpdate::centreBounds(std::int32_t record) const {
    // the centre's triangles are the cell's base triangles, and its descendants (children across
    // the cell's borders, theirs shrinking towards its corners) lie in the 3 x 3 cells around
    // it: any triangle there is within the cellError of its cell, and every vertex within its
    // cell's range (DetailBlocks::summarise)
    const DetailBlocks::CellXY c = blocks_.recordCell(record);
    if (c.x > grid_w_ - 2 || c.y > grid_h_ - 2)
        return {}; // a virtual cell's centre is off the map
    return windowBounds(c.x, c.y);
}

DiamondBounds BoundsUpdate::windowBounds(std::int32_t cx, std::int32_t cy) const {
    const WindowBound w = windowBound(cx, cy);
    return space_.codec().outward(
        {w.cap, roundDown(w.lo * metres_per_fine_ - w.cap),
         roundUp(w.hi * metres_per_fine_ + w.cap)});
}

BoundsUpdate::WindowBound BoundsUpdate::windowBound(std::int32_t cx, std::int32_t cy) const {
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

// ---- the grid -----------------------------------------------------------------------------

double BoundsUpdate::childBounds(LatticePoint c, double& zlo, double& zhi) const {
    const DiamondId id = eagerId(c);
    if (id != kNoDiamond) {
        const DiamondBounds b = bounds(id);
        zlo = std::min(zlo, static_cast<double>(b.zlo));
        zhi = std::max(zhi, static_cast<double>(b.zhi));
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

bool BoundsUpdate::computeGridBounds(const Diamond& d, DiamondId id) {
    // a diamond of the grid (levels 0-11): its vertices are grid vertices, its children grid
    // vertices or, at level 11, the centres of the cells around it
    TERRAIN_ASSERT(d.level < kCellTriangleLevel && id < space_.gridCount());
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
    return space_.storeBounds(
        id, {kept, roundDown(std::min(static_cast<double>(own.lo) * metres_per_fine_ - widen, lo)),
             roundUp(std::max(static_cast<double>(own.hi) * metres_per_fine_ + widen, hi))});
}

void BoundsUpdate::recomputeGrid(
    std::int32_t lx0, std::int32_t ly0, std::int32_t lx1, std::int32_t ly1, bool collect) {
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
                const DiamondId id = eagerId(d.centre);
                if (computeGridBounds(d, id) && collect)
                    moved_.push_back(id);
            }
    }
}

// ---- an op --------------------------------------------------------------------------------

void BoundsUpdate::noteCentres(CellRect r) {
    // a centre's bound reads the records of its 3 x 3 cells, and records change in the
    // rectangle and appear or go one cell around it
    centre_rect_ = {
        std::max(0, r.x0 - 2), std::max(0, r.y0 - 2), std::min(blocks_.cellsX() - 1, r.x1 + 2),
        std::min(blocks_.cellsY() - 1, r.y1 + 2)};
    centre_before_.clear();
    for (std::int32_t cy = centre_rect_.y0; cy <= centre_rect_.y1; ++cy)
        for (std::int32_t cx = centre_rect_.x0; cx <= centre_rect_.x1; ++cx) {
            const std::int32_t rec = blocks_.recordOf(cx, cy);
            centre_before_.push_back(
                rec < 0 ? DiamondBounds{-1.0f, 0.0f, 0.0f} : centreBounds(rec));
        }
}

void BoundsUpdate::markStale(CellRect cells) {
    stale_.mark(cells, blocks_, spec_.cellsX(), spec_.cellsY());
}

void BoundsUpdate::recomputeAround(CellRect cells) {
    moved_.clear();
    // the centres whose bounds moved since noteCentres()
    std::size_t i = 0;
    for (std::int32_t cy = centre_rect_.y0; cy <= centre_rect_.y1; ++cy)
        for (std::int32_t cx = centre_rect_.x0; cx <= centre_rect_.x1; ++cx, ++i)
            if (const std::int32_t r = blocks_.recordOf(cx, cy); r >= 0) {
                const DiamondBounds before = centre_before_[i];
                const DiamondBounds now = centreBounds(r);
                if (before.delta != now.delta || before.zlo != now.zlo || before.zhi != now.zhi)
                    moved_.push_back(space_.centreId(r));
            }
    // then the grid diamonds whose subtree reaches a cell whose 3 x 3 window meets the change
    const CellRect around{
        std::max(0, cells.x0 - 1), std::max(0, cells.y0 - 1),
        std::min(blocks_.cellsX() - 1, cells.x1 + 1), std::min(blocks_.cellsY() - 1, cells.y1 + 1)};
    recomputeGrid(
        around.x0 * kLatticePerCell, around.y0 * kLatticePerCell, (around.x1 + 1) * kLatticePerCell,
        (around.y1 + 1) * kLatticePerCell, true);
}

void BoundsUpdate::recomputeAll() {
    pass_.clear();
    for (std::int32_t b = 0; b < blocks_.capacity(); ++b)
        if (blocks_.inUse(b))
            pass_.push_back(b);
    if (!pass_.empty())
        boundBlocks(pass_, false, nullptr);
    // the grid pass reads every centre about four times: each is computed once for it
    centre_cache_.resize(idx(blocks_.recordCapacity()));
    for (std::int32_t r = 0; r < blocks_.recordCapacity(); ++r)
        centre_cache_[idx(r)] = blocks_.recordInUse(r) ? centreBounds(r) : DiamondBounds{};
    moved_.clear(); // everything may have moved: the caller rebuilds
    recomputeGrid(0, 0, max_x_, max_y_, false);
    std::vector<DiamondBounds>().swap(centre_cache_);
}

std::int64_t BoundsUpdate::drainStale(std::int64_t budget) {
    // oldest first; a block evicted since is skipped, and one made since has its bounds from
    // the terrain as it is; the pass stores their heights too
    moved_.clear();
    stale_.take(budget, pass_);
    if (pass_.empty())
        return 0;
    // below this many blocks, handing out work costs more than it saves
    constexpr std::size_t kParallelBlocks = 32;
    if (runner_ != nullptr && runner_->threads() > 1 && pass_.size() >= kParallelBlocks) {
        boundBlocksParallel(pass_);
        ++parallel_passes_;
    } else
        boundBlocks(pass_, true, nullptr);
    return static_cast<std::int64_t>(pass_.size());
}

void BoundsUpdate::freshenHeights() {
    // the blocks the budget left stale: their heights now, at their grains' vertices only
    stale_.takeHeights(heights_due_);
    for (const std::int32_t b : heights_due_) {
        const BlockPool::Chunks& chunks = pool_.chunksOf(b);
        const std::int32_t stride = chunks[2] >= 0 ? 1 : chunks[1] >= 0 ? 2 : 4;
        const DetailBlocks::CellXY c = blocks_.cellOf(b);
        fillCellHeights(*terrain_, c.x, c.y, heights_, stride);
        storeHeights(b, 7u);
    }
}

// ---- blocks -------------------------------------------------------------------------------

void BoundsUpdate::boundGrains(std::int32_t block, unsigned grain_mask) {
    const DetailBlocks::CellXY cell = blocks_.cellOf(block);
    // a split that needs a block often needs its next grain soon after (the pass computed every
    // grain's bounds): the last pass is reused while the terrain has not changed since
    if (bounded_cell_.x != cell.x || bounded_cell_.y != cell.y) {
        const BlockGeometry geometry{
            metres_per_fine_, grid_w_, grid_h_, spec_.cellsX(), spec_.cellsY()};
        kernel_.compute(
            *terrain_, blocks_, geometry, std::span<const DetailBlocks::CellXY>(&cell, 1));
        bounded_cell_ = cell;
    }
    storePass(0, block, grain_mask, false);
    if (const std::int32_t tile = tileOfCell(cell); tile >= 0)
        vertices_.bumpVersion(tile);
}

void BoundsUpdate::boundBlocks(std::span<const std::int32_t> blocks, PassListener* listener) {
    boundBlocks(blocks, false, listener);
}

void BoundsUpdate::boundGrainsOf(std::span<const std::pair<std::int32_t, unsigned>> requests) {
    if (requests.empty())
        return;
    std::vector<std::int32_t>& blocks = requested_;
    blocks.clear();
    for (const auto& [block, mask] : requests) {
        if (static_cast<std::size_t>(block) >= grain_masks_.size())
            grain_masks_.resize(static_cast<std::size_t>(block) + 1, 0);
        grain_masks_[static_cast<std::size_t>(block)] = mask;
        blocks.push_back(block);
    }
    boundBlocks(blocks, false, nullptr);
    for (const std::int32_t block : blocks) {
        grain_masks_[static_cast<std::size_t>(block)] = 0;
        if (const std::int32_t tile = tileOfCell(blocks_.cellOf(block)); tile >= 0)
            vertices_.bumpVersion(tile);
    }
}

void BoundsUpdate::boundBlocks(
    std::span<const std::int32_t> blocks, bool collect, PassListener* listener) {
    sortIntoSquares(blocks);
    const BlockGeometry geometry{
        metres_per_fine_, grid_w_, grid_h_, spec_.cellsX(), spec_.cellsY()};
    bounded_cell_ = {}; // the scratch no longer holds a single block's pass
    for (std::size_t q = 0; q < square_ends_.size();) {
        const std::size_t end = passEnd(q, square_ends_.size());
        boundSquares(q, end, collect, geometry, listener);
        q = end;
    }
}

void BoundsUpdate::boundSquares(
    std::size_t first_square,
    std::size_t end_square,
    bool collect,
    BlockGeometry geometry,
    PassListener* listener) {
    const std::size_t first = first_square == 0 ? 0 : square_ends_[first_square - 1];
    const std::size_t last = square_ends_[end_square - 1];
    pass_cells_.clear();
    for (std::size_t i = first; i < last; ++i)
        pass_cells_.push_back(blocks_.cellOf(pass_blocks_[i]));
    kernel_.compute(*terrain_, blocks_, geometry, pass_cells_);
    for (std::size_t i = first; i < last; ++i) {
        const std::int32_t b = pass_blocks_[i];
        const unsigned mask = static_cast<std::size_t>(b) < grain_masks_.size()
                                  ? grain_masks_[static_cast<std::size_t>(b)]
                                  : 0u;
        storePass(i - first, b, mask != 0 ? mask : residentGrains(b), collect);
        if (listener != nullptr)
            listener->bounded(i - first, b);
    }
}

namespace {
constexpr std::int32_t kSquareCells = 16;
/// A kernel pass's squares span at most this many a side (its scratch follows the cells it
/// bounds, its per-cell tables the box: 66 x 66 cells at most).
constexpr std::int32_t kPassSquares = 4;
} // namespace

unsigned BoundsUpdate::residentGrains(std::int32_t block) const {
    unsigned mask = 0;
    for (int g = 0; g < kGrains; ++g)
        if (pool_.chunkOf(block, g) >= 0)
            mask |= 1u << g;
    return mask;
}

void BoundsUpdate::sortIntoSquares(std::span<const std::int32_t> blocks) {
    // one BlockBounds pass per square of cells, or per few neighbouring ones (passEnd), so that
    // a pass's scratch stays small however scattered the blocks are (a pass spans its cells'
    // bounding box)
    pass_blocks_.assign(blocks.begin(), blocks.end());
    const auto square = [&](std::int32_t b) {
        const DetailBlocks::CellXY c = blocks_.cellOf(b);
        return std::pair{c.y / kSquareCells, c.x / kSquareCells};
    };
    std::sort(pass_blocks_.begin(), pass_blocks_.end(), [&](std::int32_t a, std::int32_t b) {
        return std::pair{square(a), a} < std::pair{square(b), b};
    });
    square_ends_.clear();
    square_at_.clear();
    for (std::size_t i = 1; i <= pass_blocks_.size(); ++i)
        if (i == pass_blocks_.size() || square(pass_blocks_[i]) != square(pass_blocks_[i - 1])) {
            square_ends_.push_back(i);
            const auto [sy, sx] = square(pass_blocks_[i - 1]);
            square_at_.push_back({sx, sy});
        }
}

std::size_t BoundsUpdate::passEnd(std::size_t first, std::size_t last) const {
    std::array<std::int32_t, 2> lo = square_at_[first];
    std::array<std::int32_t, 2> hi = lo;
    std::size_t end = first + 1;
    for (; end < last; ++end) {
        const std::array<std::int32_t, 2> at = square_at_[end];
        const std::array<std::int32_t, 2> nlo{std::min(lo[0], at[0]), std::min(lo[1], at[1])};
        const std::array<std::int32_t, 2> nhi{std::max(hi[0], at[0]), std::max(hi[1], at[1])};
        if (nhi[0] - nlo[0] >= kPassSquares || nhi[1] - nlo[1] >= kPassSquares)
            break;
        lo = nlo;
        hi = nhi;
    }
    return end;
}

void BoundsUpdate::storeGrains(std::size_t i, std::int32_t block, unsigned grain_mask) {
    storePass(i, block, grain_mask, false);
}

void BoundsUpdate::storePass(std::size_t i, std::int32_t block, unsigned grain_mask, bool collect) {
    storePassFrom(kernel_, heights_, i, block, grain_mask, collect ? &moved_ : nullptr, nullptr);
}

void BoundsUpdate::storePassFrom(
    const BlockBounds& kernel,
    std::array<std::int64_t, kBlockVertices>& heights,
    std::size_t i,
    std::int32_t block,
    unsigned grain_mask,
    std::vector<DiamondId>* moved,
    std::vector<VertexMark>* marks) {
    const GrainTables& tables = grainTables();
    kernel.heights(i, heights);
    storeHeightsFrom(heights, block, grain_mask, marks);
    for (int g = 0; g < kGrains; ++g) {
        if ((grain_mask & (1u << g)) == 0)
            continue;
        const std::int32_t chunk = pool_.chunkOf(block, g);
        const auto diamonds = static_cast<std::size_t>(kGrainDiamonds[static_cast<std::size_t>(g)]);
        for (std::size_t slot = 0; slot < diamonds; ++slot) {
            const std::uint8_t local = tables.diamond_local[static_cast<std::size_t>(g)][slot];
            if (g == 0 && (local == 0 || local == kCentreLocal * kLatticePerCell + kCentreLocal))
                continue; // the grid vertex and the (eager) centre
            const DiamondId id = DiamondSpace::pooledId(g, chunk, static_cast<std::uint32_t>(slot));
            if (space_.storeBounds(id, kernel.bounds(i, local)) && moved != nullptr)
                moved->push_back(id);
        }
    }
}

void BoundsUpdate::storeHeights(std::int32_t block, unsigned grain_mask) {
    storeHeightsFrom(heights_, block, grain_mask, nullptr);
}

void BoundsUpdate::storeHeightsFrom(
    const std::array<std::int64_t, kBlockVertices>& heights_in,
    std::int32_t block,
    unsigned grain_mask,
    std::vector<VertexMark>* marks) {
    const GrainTables& tables = grainTables();
    for (int g = 0; g < kGrains; ++g) {
        const std::int32_t chunk = pool_.chunkOf(block, g);
        if ((grain_mask & (1u << g)) == 0 || chunk < 0)
            continue;
        const auto vertices = static_cast<std::size_t>(kGrainVertices[static_cast<std::size_t>(g)]);
        const auto& local = tables.vertex_local[static_cast<std::size_t>(g)];
        std::int64_t lowest = heights_in[local[0]];
        for (std::size_t v = 1; v < vertices; ++v)
            lowest = std::min(lowest, heights_in[local[v]]);
        bool moved = pool_.base(g, chunk) != lowest;
        pool_.base(g, chunk) = lowest;
        const std::span<std::uint32_t> heights = pool_.heights(g, chunk);
        for (std::size_t v = 0; v < vertices; ++v) {
            const auto h = static_cast<std::uint32_t>(heights_in[local[v]] - lowest);
            std::uint32_t& stored = heights[v];
            moved = moved || stored != h;
            stored = h;
        }
        // the tile's vertex array changed: a renderer that took its version before must look
        // again (heights freshened after the op's own bump, or by a later bounds pass)
        if (moved)
            if (const std::int32_t tile = tileOfCell(blocks_.cellOf(block)); tile >= 0) {
                std::uint32_t first = 0;
                std::uint32_t end = 0;
                if (const std::int32_t segment = pool_.segment(g, chunk); segment >= 0) {
                    first = vertices_.firstVertex(tile, segment);
                    end = first + static_cast<std::uint32_t>(vertices);
                }
                if (marks != nullptr) {
                    marks->push_back({tile, first, end});
                } else {
                    vertices_.bumpVersion(tile);
                    if (end > first)
                        vertices_.mark(tile, first, end);
                }
            }
    }
}

void BoundsUpdate::boundBlocksParallel(std::span<const std::int32_t> blocks) {
    // the serial pass's order and squares (boundBlocks), the squares in groups of consecutive
    // ones, each group on one thread with its own kernel; each block's state is its own, the
    // rest is listed per group and made here in the groups' order: the serial order
    sortIntoSquares(blocks);
    const std::size_t groups = std::min<std::size_t>(runner_->threads(), square_ends_.size());
    if (scratch_.size() < groups)
        scratch_.resize(groups);
    // about as many blocks per group
    group_ends_.assign(groups, square_ends_.size());
    for (std::size_t k = 0, g = 0; k < square_ends_.size() && g + 1 < groups; ++k)
        if (square_ends_[k] * groups >= (g + 1) * pass_blocks_.size())
            group_ends_[g++] = k + 1;
    const BlockGeometry geometry{
        metres_per_fine_, grid_w_, grid_h_, spec_.cellsX(), spec_.cellsY()};
    bounded_cell_ = {}; // kernel_ is not this pass's
    runner_->run(groups, [&](std::size_t group) {
        PassScratch& scratch = scratch_[group];
        scratch.moved.clear();
        scratch.marks.clear();
        const std::size_t first_square = group == 0 ? 0 : group_ends_[group - 1];
        for (std::size_t q = first_square; q < group_ends_[group];) {
            const std::size_t end = passEnd(q, group_ends_[group]);
            const std::size_t first = q == 0 ? 0 : square_ends_[q - 1];
            const std::size_t last = square_ends_[end - 1];
            q = end;
            scratch.cells.clear();
            for (std::size_t i = first; i < last; ++i)
                scratch.cells.push_back(blocks_.cellOf(pass_blocks_[i]));
            scratch.kernel.compute(*terrain_, blocks_, geometry, scratch.cells);
            for (std::size_t i = first; i < last; ++i) {
                const std::int32_t b = pass_blocks_[i];
                storePassFrom(
                    scratch.kernel, scratch.heights, i - first, b, residentGrains(b),
                    &scratch.moved, &scratch.marks);
            }
        }
    });
    for (std::size_t group = 0; group < groups; ++group) {
        const PassScratch& scratch = scratch_[group];
        moved_.insert(moved_.end(), scratch.moved.begin(), scratch.moved.end());
        for (const VertexMark& m : scratch.marks) {
            vertices_.bumpVersion(m.tile);
            if (m.end > m.begin)
                vertices_.mark(m.tile, m.begin, m.end);
        }
    }
}

} // namespace terrain::roam
