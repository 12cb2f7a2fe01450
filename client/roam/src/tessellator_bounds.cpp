// The tessellator's diamond ids, vertex heights and nested error bounds.

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

float roundUp(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) < v)
        f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

float roundDown(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) > v)
        f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    return f;
}

/// Local positions (l * 16 + k) of the sub-cell diamonds of each level inside one cell; the
/// level depends only on the position within the cell (cell origins are multiples of 16).
const std::array<std::vector<std::uint8_t>, kFinestTriangleLevel>& localPositionsByLevel() {
    static const auto table = [] {
        std::array<std::vector<std::uint8_t>, kFinestTriangleLevel> t;
        for (std::int32_t l = 0; l < kLatticePerCell; ++l)
            for (std::int32_t k = 0; k < kLatticePerCell; ++k) {
                if (k == 0 && l == 0)
                    continue;
                const Diamond d = diamondAt({k, l});
                t[static_cast<std::size_t>(d.level)].push_back(
                    static_cast<std::uint8_t>(l * kLatticePerCell + k));
            }
        return t;
    }();
    return table;
}

std::int32_t halfOfLevel(int level) {
    const int t = level % 2 == 0 ? (18 - level) / 2 : (19 - level) / 2;
    return 1 << t;
}

std::int32_t reachOfLevel(int level) {
    return (level % 2 == 0 ? 3 : 2) * halfOfLevel(level);
}

} // namespace

// ---- ids and heights ----------------------------------------------------------------------

Tessellator::DiamondId Tessellator::idOf(LatticePoint p) const {
    if (!insideMap(p))
        return kNoDiamond;
    if (isGridVertex(p))
        return static_cast<DiamondId>(p.y / kLatticePerCell) * static_cast<DiamondId>(grid_w_) +
               static_cast<DiamondId>(p.x / kLatticePerCell);
    const std::int32_t block = blocks_.blockOf(p.x / kLatticePerCell, p.y / kLatticePerCell);
    if (block < 0)
        return kNoDiamond;
    return grid_count_ + static_cast<DiamondId>(block) * kDiamondsPerBlock +
           static_cast<DiamondId>(
               (p.y % kLatticePerCell) * kLatticePerCell + p.x % kLatticePerCell);
}

LatticePoint Tessellator::pointOf(DiamondId id) const {
    if (id < grid_count_) {
        const auto w = static_cast<DiamondId>(grid_w_);
        return {
            static_cast<std::int32_t>(id % w) * kLatticePerCell,
            static_cast<std::int32_t>(id / w) * kLatticePerCell};
    }
    const DiamondId r = id - grid_count_;
    const auto block = static_cast<std::int32_t>(r / kDiamondsPerBlock);
    const auto local = static_cast<std::int32_t>(r % kDiamondsPerBlock);
    const DetailBlocks::CellXY c = blocks_.cellOf(block);
    return {
        c.x * kLatticePerCell + local % kLatticePerCell,
        c.y * kLatticePerCell + local / kLatticePerCell};
}

std::int64_t Tessellator::heightAt(LatticePoint p) const {
    if (isGridVertex(p))
        return static_cast<std::int64_t>(
                   terrain_->sample(p.x / kLatticePerCell, p.y / kLatticePerCell)) *
               kFineUnitsPerQuantum;
    std::int32_t cx = p.x / kLatticePerCell;
    std::int32_t cy = p.y / kLatticePerCell;
    std::int32_t k = p.x % kLatticePerCell;
    std::int32_t l = p.y % kLatticePerCell;
    // a point on the map's last line belongs to the real cell before it (the virtual cells past
    // the grid hold diamond state, not heights)
    if (cx >= grid_w_ - 1) {
        cx -= 1;
        k += kLatticePerCell;
    }
    if (cy >= grid_h_ - 1) {
        cy -= 1;
        l += kLatticePerCell;
    }
    // on the real map's last line the surface is the real cell's (its patch border faces the
    // padding and need not be straight), as drawn; the padding's cells start past it
    if (k == 0 && cx == spec_.cellsX())
        if (const std::int32_t b = blocks_.blockOf(cx - 1, cy); b >= 0)
            return blocks_.height(b, kLatticePerCell, l);
    if (l == 0 && cy == spec_.cellsY())
        if (const std::int32_t b = blocks_.blockOf(cx, cy - 1); b >= 0)
            return blocks_.height(b, k, kLatticePerCell);
    if (const std::int32_t b = blocks_.blockOf(cx, cy); b >= 0)
        return blocks_.height(b, k, l);
    if (k == 0)
        if (const std::int32_t b = blocks_.blockOf(cx - 1, cy); b >= 0)
            return blocks_.height(b, kLatticePerCell, l);
    if (l == 0)
        if (const std::int32_t b = blocks_.blockOf(cx, cy - 1); b >= 0)
            return blocks_.height(b, k, kLatticePerCell);
    // a cell without a block: the base triangles, exact in fine units
    return baseHeightScaled(terrain_->corners(cx, cy), cellDiagonal(cx, cy), k, l, kLatticePerCell);
}

void Tessellator::resizeDiamondState() {
    const std::size_t n =
        grid_count_ + static_cast<std::size_t>(blocks_.capacity()) * kDiamondsPerBlock;
    // ids are uint32 with kNoDiamond reserved: 16 M blocks on the largest map, far beyond memory
    TERRAIN_ASSERT(n < kNoDiamond);
    delta_.resize(n, 0.0f);
    zlo_.resize(n, 0.0f);
    zhi_.resize(n, 0.0f);
    state_.resize(n, 0);
    heap_.resizeIds(n);
    block_local_.resize(idx(blocks_.capacity()), -1);
}

// ---- error bounds -------------------------------------------------------------------------

bool Tessellator::storeBounds(DiamondId id, float delta, float zlo, float zhi) {
    const bool changed = delta_[id] != delta || zlo_[id] != zlo || zhi_[id] != zhi;
    delta_[id] = delta;
    zlo_[id] = zlo;
    zhi_[id] = zhi;
    return changed;
}

double Tessellator::childBounds(LatticePoint c, double& zlo, double& zhi) const {
    const DiamondId id = idOf(c);
    if (id != kNoDiamond) {
        zlo = std::min(zlo, static_cast<double>(zlo_[id]));
        zhi = std::max(zhi, static_cast<double>(zhi_[id]));
        return delta_[id];
    }
    // a cell without a block is drawn with its base triangles, which are the true surface
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

bool Tessellator::finishBounds(
    DiamondId id, std::int64_t own_lo, std::int64_t own_hi, double delta, double lo, double hi) {
    return storeBounds(
        id, roundUp(delta),
        roundDown(std::min(static_cast<double>(own_lo) * metres_per_fine_ - delta, lo)),
        roundUp(std::max(static_cast<double>(own_hi) * metres_per_fine_ + delta, hi)));
}

bool Tessellator::computeBounds(const Diamond& d, DiamondId id) {
    const OwnSpan own = ownSpan(
        d, [&](LatticePoint p) { return heightAt(p); },
        [&](LatticePoint p) { return insideMap(p); }, metres_per_fine_);
    double child = 0.0;
    double lo = kInfinity;
    double hi = -kInfinity;
    if (d.level == kMaxDiamondLevel) {
        for (const LatticePoint a : apexes(d)) {
            if (!insideMap(a))
                continue;
            const LatticePoint c3 = centroidTimes3(triangleOf(d, a));
            const std::int32_t block =
                blocks_.blockOf(c3.x / (3 * kLatticePerCell), c3.y / (3 * kLatticePerCell));
            if (block >= 0)
                child = std::max(
                    child, static_cast<double>(blocks_.finestError(block)) * metres_per_fine_);
        }
    } else {
        std::array<LatticePoint, 4> kids{};
        const int n = children(d, kids);
        for (int i = 0; i < n; ++i)
            if (insideMap(kids[idx(i)]))
                child = std::max(child, childBounds(kids[idx(i)], lo, hi));
    }
    return finishBounds(id, own.lo, own.hi, own.local + child, lo, hi);
}

bool Tessellator::computeBlockBounds(const Diamond& d, DiamondId id, std::int32_t block) {
    // computeBounds for a diamond strictly inside its cell (local x and y both > 0): its centre,
    // hypotenuse ends, apexes and children all lie in the cell's 17 x 17 block, so heights come
    // straight from the block and most child ids from the block's own id range. The same
    // arithmetic as computeBounds, so the same floats (checked bit for bit over a battle when it
    // was written; RoamMesh's fresh-build tests compare whole tessellators).
    const std::int32_t ox = blocks_.cellOf(block).x * kLatticePerCell;
    const std::int32_t oy = blocks_.cellOf(block).y * kLatticePerCell;
    const OwnSpan own = ownSpan(
        d, [&](LatticePoint p) { return blocks_.height(block, p.x - ox, p.y - oy); },
        [](LatticePoint) { return true; }, metres_per_fine_);
    double child = 0.0;
    double lo = kInfinity;
    double hi = -kInfinity;
    if (d.level == kMaxDiamondLevel) {
        // both triangles lie in this cell
        child = static_cast<double>(blocks_.finestError(block)) * metres_per_fine_;
    } else {
        std::array<LatticePoint, 4> kids{};
        const int n = children(d, kids);
        const DiamondId base = grid_count_ + static_cast<DiamondId>(block) * kDiamondsPerBlock;
        for (int i = 0; i < n; ++i) {
            const LatticePoint c = kids[idx(i)];
            const std::int32_t k = c.x - ox;
            const std::int32_t l = c.y - oy;
            if (k < kLatticePerCell && l < kLatticePerCell && (k | l) != 0) {
                const DiamondId cid = base + static_cast<DiamondId>(l * kLatticePerCell + k);
                lo = std::min(lo, static_cast<double>(zlo_[cid]));
                hi = std::max(hi, static_cast<double>(zhi_[cid]));
                child = std::max(child, static_cast<double>(delta_[cid]));
            } else {
                child = std::max(child, childBounds(c, lo, hi));
            }
        }
    }
    return finishBounds(id, own.lo, own.hi, own.local + child, lo, hi);
}

void Tessellator::recomputeBounds(
    std::int32_t lx0, std::int32_t ly0, std::int32_t lx1, std::int32_t ly1, bool collect) {
    const auto& positions = localPositionsByLevel();
    const bool whole = lx0 <= 0 && ly0 <= 0 && lx1 >= max_x_ && ly1 >= max_y_;
    for (int level = kMaxDiamondLevel; level >= kCellTriangleLevel; --level) {
        const std::int32_t reach = reachOfLevel(level) + kLatticePerCell;
        const std::int32_t cx0 = std::max(0, (lx0 - reach) / kLatticePerCell);
        const std::int32_t cy0 = std::max(0, (ly0 - reach) / kLatticePerCell);
        const std::int32_t cx1 = std::min(blocks_.cellsX() - 1, (lx1 + reach) / kLatticePerCell);
        const std::int32_t cy1 = std::min(blocks_.cellsY() - 1, (ly1 + reach) / kLatticePerCell);
        auto visit_block = [&](std::int32_t block) {
            const DetailBlocks::CellXY c = blocks_.cellOf(block);
            // a cell of the padded grid, not a virtual one past it
            const bool inner_cell = c.x < grid_w_ - 1 && c.y < grid_h_ - 1;
            for (const std::uint8_t local : positions[idx(level)]) {
                const LatticePoint p{
                    c.x * kLatticePerCell + local % kLatticePerCell,
                    c.y * kLatticePerCell + local / kLatticePerCell};
                if (!insideMap(p))
                    continue; // a virtual cell's diamonds past the map's last line
                const DiamondId id =
                    grid_count_ + static_cast<DiamondId>(block) * kDiamondsPerBlock + local;
                const bool changed =
                    inner_cell && local % kLatticePerCell != 0 && local >= kLatticePerCell
                        ? computeBlockBounds(diamondAt(p), id, block)
                        : computeBounds(diamondAt(p), id);
                if (collect && changed)
                    recomputed_.push_back(id);
            }
        };
        if (whole) {
            for (std::int32_t b = 0; b < blocks_.capacity(); ++b)
                if (blocks_.inUse(b))
                    visit_block(b);
        } else {
            for (std::int32_t cy = cy0; cy <= cy1; ++cy)
                for (std::int32_t cx = cx0; cx <= cx1; ++cx)
                    if (const std::int32_t b = blocks_.blockOf(cx, cy); b >= 0)
                        visit_block(b);
        }
    }
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
}

Box Tessellator::boxOf(const Diamond& d, DiamondId id) const {
    const std::int32_t r = subtreeReach(d);
    // only the real map is drawn; padding contributes nothing
    const std::int32_t x0 = std::max(d.centre.x - r, 0);
    const std::int32_t y0 = std::max(d.centre.y - r, 0);
    const std::int32_t x1 = std::min(d.centre.x + r, real_x_);
    const std::int32_t y1 = std::min(d.centre.y + r, real_y_);
    Box b;
    b.lo = {x0 * metres_per_lattice_, y0 * metres_per_lattice_, zlo_[id]};
    b.hi = {x1 * metres_per_lattice_, y1 * metres_per_lattice_, zhi_[id]};
    if (x0 >= x1 || y0 >= y1)
        b.lo.x = b.hi.x + 1.0; // empty
    return b;
}

double Tessellator::priority(const ViewMetric& m, const Diamond& d, DiamondId id) const {
    const Box b = boxOf(d, id);
    if (b.lo.x > b.hi.x)
        return 0.0;
    return m.screenError(b, delta_[id]);
}

double Tessellator::deltaAt(LatticePoint p) const {
    const DiamondId id = idOf(p);
    if (id == kNoDiamond || !diamondAt(p).valid())
        return -1.0;
    return delta_[id];
}

} // namespace terrain::roam
