#include "float_rounding.h"
#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/block_bounds.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace terrain::roam {

using namespace detail;

namespace {

constexpr std::int32_t kSide = kBlockSide; // 17 vertices a side

/// A sub-grid diamond's geometry relative to its cell's origin (lattice units; the same in every
/// cell, as cell origins are multiples of 16).
struct LocalDiamond {
    using Offset = std::array<std::int8_t, 2>;
    std::uint8_t local = 0; ///< l * 16 + k
    std::int8_t k = 0;
    std::int8_t l = 0;
    std::array<Offset, 2> ends{};
    std::array<Offset, 2> apexes{};
    std::array<Offset, 4> kids{}; ///< none at level 19
    /// Level 19: the cell (offset from this one) of the triangle with apexes[i].
    std::array<Offset, 2> finest_cells{};
    /// Every vertex read is in the cell's closed square and every child in its half-open one.
    bool interior = false;
};

struct Tables {
    std::array<std::vector<LocalDiamond>, kFinestTriangleLevel> by_level;
};

bool inClosed(LocalDiamond::Offset o) {
    return o[0] >= 0 && o[1] >= 0 && o[0] <= kLatticePerCell && o[1] <= kLatticePerCell;
}

const Tables& tables() {
    static const Tables t = [] {
        Tables out;
        // a cell away from the origin, so that every offset is a plain difference
        const LatticePoint o{kLatticePerCell, kLatticePerCell};
        const auto rel = [&](LatticePoint p) {
            return LocalDiamond::Offset{
                static_cast<std::int8_t>(p.x - o.x), static_cast<std::int8_t>(p.y - o.y)};
        };
        for (std::int32_t l = 0; l < kLatticePerCell; ++l)
            for (std::int32_t k = 0; k < kLatticePerCell; ++k) {
                if ((k | l) == 0)
                    continue;
                const Diamond d = diamondAt({o.x + k, o.y + l});
                LocalDiamond ld;
                ld.local = static_cast<std::uint8_t>(l * kLatticePerCell + k);
                ld.k = static_cast<std::int8_t>(k);
                ld.l = static_cast<std::int8_t>(l);
                const auto ends = hypotenuseEnds(d);
                const auto tips = roam::apexes(d);
                bool interior = true;
                for (std::size_t i = 0; i < 2; ++i) {
                    ld.ends[i] = rel(ends[i]);
                    ld.apexes[i] = rel(tips[i]);
                    interior = interior && inClosed(ld.ends[i]) && inClosed(ld.apexes[i]);
                }
                if (d.level == kMaxDiamondLevel) {
                    for (std::size_t i = 0; i < 2; ++i) {
                        const LatticePoint c3 = centroidTimes3(triangleOf(d, tips[i]));
                        ld.finest_cells[i] = {
                            static_cast<std::int8_t>(c3.x / (3 * kLatticePerCell) - 1),
                            static_cast<std::int8_t>(c3.y / (3 * kLatticePerCell) - 1)};
                        interior =
                            interior && ld.finest_cells[i][0] == 0 && ld.finest_cells[i][1] == 0;
                    }
                } else {
                    std::array<LatticePoint, 4> kids{};
                    children(d, kids);
                    for (std::size_t i = 0; i < 4; ++i) {
                        ld.kids[i] = rel(kids[i]);
                        const auto [kx, ky] = ld.kids[i];
                        interior = interior && kx >= 0 && ky >= 0 && kx < kLatticePerCell &&
                                   ky < kLatticePerCell && (kx | ky) != 0;
                    }
                }
                ld.interior = interior;
                out.by_level[static_cast<std::size_t>(d.level)].push_back(ld);
            }
        return out;
    }();
    return t;
}

} // namespace

bool BlockBounds::special(std::int32_t cx, std::int32_t cy) const {
    const BlockGeometry& g = geometry_;
    return cx == g.cells_x || cy == g.cells_y || cx > g.grid_w - 2 || cy > g.grid_h - 2;
}

void BlockBounds::fillRuled(
    std::int32_t cx, std::int32_t cy, std::span<std::int64_t, kBlockVertices> out) {
    // the height of each point as the mesh has it: a cell's own, except on the real map's last
    // lines, where the surface is the real cell's (its patch border faces the padding and need
    // not be straight), and in a virtual cell past the grid, whose first line belongs to the cell
    // before it. A cell's own diamonds off its borders read its own heights (as its block draws
    // them), whatever the rules say about its first line.
    const BlockGeometry& g = geometry_;
    const bool virtual_x = cx > g.grid_w - 2;
    const bool virtual_y = cy > g.grid_h - 2;
    if (virtual_x || virtual_y) {
        std::fill(out.begin(), out.end(), std::int64_t{0});
        if (virtual_x && virtual_y) {
            out[0] = std::int64_t{terrain_->sample(cx, cy)} * kFineUnitsPerQuantum;
            return;
        }
        std::array<std::int64_t, kBlockVertices> before{};
        fillRuled(virtual_x ? cx - 1 : cx, virtual_x ? cy : cy - 1, before);
        for (std::int32_t i = 0; i < kSide; ++i) {
            if (virtual_x)
                out[static_cast<std::size_t>(i * kSide)] =
                    before[static_cast<std::size_t>(i * kSide + kLatticePerCell)];
            else
                out[static_cast<std::size_t>(i)] =
                    before[static_cast<std::size_t>(kLatticePerCell * kSide + i)];
        }
        return;
    }
    fillCellHeights(*terrain_, cx, cy, out);
    if (cx == g.cells_x && cx >= 1 && cy < g.cells_y &&
        terrain_->findPatch(cx - 1, cy) != nullptr) {
        fillCellHeights(*terrain_, cx - 1, cy, scratch_);
        for (std::int32_t l = 1; l < kSide; ++l)
            out[static_cast<std::size_t>(l * kSide)] =
                scratch_[static_cast<std::size_t>(l * kSide + kLatticePerCell)];
    }
    if (cy == g.cells_y && cy >= 1 && cx < g.cells_x &&
        terrain_->findPatch(cx, cy - 1) != nullptr) {
        fillCellHeights(*terrain_, cx, cy - 1, scratch_);
        for (std::int32_t k = 1; k < kSide; ++k)
            out[static_cast<std::size_t>(k)] =
                scratch_[static_cast<std::size_t>(kLatticePerCell * kSide + k)];
    }
}

void BlockBounds::compute(
    const Terrain& t,
    const DetailBlocks& records,
    const BlockGeometry& g,
    std::span<const DetailBlocks::CellXY> cells) {
    terrain_ = &t;
    records_ = &records;
    geometry_ = g;
    targets_.assign(cells.begin(), cells.end());
    target_bounds_.clear();
    if (cells.empty())
        return;
    std::int32_t x0 = cells[0].x;
    std::int32_t y0 = cells[0].y;
    std::int32_t x1 = x0;
    std::int32_t y1 = y0;
    for (const auto& c : cells) {
        x0 = std::min(x0, c.x);
        y0 = std::min(y0, c.y);
        x1 = std::max(x1, c.x);
        y1 = std::max(y1, c.y);
    }
    // cells 0 .. grid - 1: the last column and row are the virtual ones past the padded grid
    rx0_ = std::max(0, x0 - 2);
    ry0_ = std::max(0, y0 - 2);
    const std::int32_t rx1 = std::min(g.grid_w - 1, x1 + 2);
    const std::int32_t ry1 = std::min(g.grid_h - 1, y1 + 2);
    rw_ = rx1 - rx0_ + 1;
    rh_ = ry1 - ry0_ + 1;
    const auto region = static_cast<std::size_t>(rw_) * static_cast<std::size_t>(rh_);
    height_slot_.assign(region, -1);
    ruled_slot_.assign(region, -1);
    bound_slot_.assign(region, -1);
    cell_caps_.resize(region);
    for (std::int32_t y = ry0_; y <= ry1; ++y)
        for (std::int32_t x = rx0_; x <= rx1; ++x) {
            const std::int32_t r = records.recordOf(x, y);
            cell_caps_[static_cast<std::size_t>(regionIndex(x, y))] =
                r < 0 ? 0.0f
                      : roundUp(static_cast<double>(records.cellError(r)) * g.metres_per_fine);
        }

    // bounds for every detail cell of the targets' 3 x 3 windows, heights one cell further
    bound_cells_.clear();
    for (const auto& c : cells)
        for (std::int32_t y = std::max(ry0_, c.y - 1); y <= std::min(ry1, c.y + 1); ++y)
            for (std::int32_t x = std::max(rx0_, c.x - 1); x <= std::min(rx1, c.x + 1); ++x) {
                std::int32_t& slot = bound_slot_[static_cast<std::size_t>(regionIndex(x, y))];
                if (slot < 0 && records.recordOf(x, y) >= 0) {
                    slot = static_cast<std::int32_t>(bound_cells_.size());
                    bound_cells_.push_back({x, y});
                }
            }
    std::int32_t heights = 0;
    for (const auto& c : bound_cells_)
        for (std::int32_t y = std::max(ry0_, c.y - 1); y <= std::min(ry1, c.y + 1); ++y)
            for (std::int32_t x = std::max(rx0_, c.x - 1); x <= std::min(rx1, c.x + 1); ++x) {
                std::int32_t& slot = height_slot_[static_cast<std::size_t>(regionIndex(x, y))];
                if (slot < 0)
                    slot = heights++;
            }
    heights_.resize(static_cast<std::size_t>(heights) * kBlockVertices);
    std::int32_t ruled = 0;
    for (std::int32_t y = ry0_; y <= ry1; ++y)
        for (std::int32_t x = rx0_; x <= rx1; ++x)
            if (height_slot_[static_cast<std::size_t>(regionIndex(x, y))] >= 0 && special(x, y))
                ruled_slot_[static_cast<std::size_t>(regionIndex(x, y))] = ruled++;
    ruled_.resize(static_cast<std::size_t>(ruled) * kBlockVertices);
    for (std::int32_t y = ry0_; y <= ry1; ++y)
        for (std::int32_t x = rx0_; x <= rx1; ++x) {
            const auto at = static_cast<std::size_t>(regionIndex(x, y));
            if (const std::int32_t slot = height_slot_[at]; slot >= 0)
                fillCellHeights(
                    t, x, y,
                    std::span<std::int64_t, kBlockVertices>(
                        heights_.data() + static_cast<std::size_t>(slot) * kBlockVertices,
                        kBlockVertices));
            if (const std::int32_t slot = ruled_slot_[at]; slot >= 0)
                fillRuled(
                    x, y,
                    std::span<std::int64_t, kBlockVertices>(
                        ruled_.data() + static_cast<std::size_t>(slot) * kBlockVertices,
                        kBlockVertices));
        }
    bounds_.assign(bound_cells_.size() * kCellDiamonds, DiamondBounds{});
    caps_.assign(bound_cells_.size() * kCellDiamonds, 0.0f);
    for (int level = kMaxDiamondLevel; level > kCellTriangleLevel; --level)
        for (const auto& c : bound_cells_)
            boundCell(c.x, c.y, level);
    for (const auto& c : cells) {
        const std::int32_t slot = bound_slot_[static_cast<std::size_t>(regionIndex(c.x, c.y))];
        TERRAIN_ASSERT(slot >= 0); // a target must be a detail cell
        target_bounds_.push_back(static_cast<std::size_t>(slot));
    }
}

void BlockBounds::boundCell(std::int32_t cx, std::int32_t cy, int level) {
    const BlockGeometry& g = geometry_;
    const double mpf = g.metres_per_fine;
    const std::int32_t max_x = (g.grid_w - 1) * kLatticePerCell;
    const std::int32_t max_y = (g.grid_h - 1) * kLatticePerCell;
    const std::int32_t ox = cx * kLatticePerCell;
    const std::int32_t oy = cy * kLatticePerCell;
    const std::int32_t region = regionIndex(cx, cy);
    const auto slot = static_cast<std::size_t>(bound_slot_[static_cast<std::size_t>(region)]);
    // a cell's heights as its block has them, and as the mesh's rules read them
    const auto ruledOf = [&](std::int32_t at) {
        const std::int32_t r = ruled_slot_[static_cast<std::size_t>(at)];
        if (r >= 0)
            return ruled_.data() + static_cast<std::size_t>(r) * kBlockVertices;
        const std::int32_t h = height_slot_[static_cast<std::size_t>(at)];
        TERRAIN_ASSERT(h >= 0);
        return heights_.data() + static_cast<std::size_t>(h) * kBlockVertices;
    };
    const std::int64_t* own_raw =
        heights_.data() +
        static_cast<std::size_t>(height_slot_[static_cast<std::size_t>(region)]) * kBlockVertices;
    const std::int64_t* own = ruledOf(region);
    // a cell of the padded grid (not a virtual one past it)
    const bool inner = cx <= g.grid_w - 2 && cy <= g.grid_h - 2;
    DiamondBounds* own_bounds = bounds_.data() + slot * kCellDiamonds;
    float* own_caps = caps_.data() + slot * kCellDiamonds;
    // a cell whose every neighbour's points are on the map needs no map checks
    const bool clear = cx >= 1 && cy >= 1 && cx <= g.grid_w - 3 && cy <= g.grid_h - 3;
    const auto inside = [&](LocalDiamond::Offset q) {
        const std::int32_t x = ox + q[0];
        const std::int32_t y = oy + q[1];
        return clear || (x >= 0 && y >= 0 && x <= max_x && y <= max_y);
    };
    const auto height = [&](LocalDiamond::Offset q) -> std::int64_t {
        const std::int32_t dx = q[0] < 0 ? -1 : (q[0] > kLatticePerCell ? 1 : 0);
        const std::int32_t dy = q[1] < 0 ? -1 : (q[1] > kLatticePerCell ? 1 : 0);
        if ((dx | dy) == 0)
            return own[q[1] * kSide + q[0]];
        return ruledOf(regionIndex(
            cx + dx,
            cy + dy))[(q[1] - dy * kLatticePerCell) * kSide + (q[0] - dx * kLatticePerCell)];
    };
    const auto cell_cap = [&](std::int32_t x, std::int32_t y) {
        if (x >= rx0_ && y >= ry0_ && x < rx0_ + rw_ && y < ry0_ + rh_)
            return cell_caps_[static_cast<std::size_t>(regionIndex(x, y))];
        const std::int32_t r = records_->recordOf(x, y);
        return r < 0 ? 0.0f : roundUp(static_cast<double>(records_->cellError(r)) * mpf);
    };
    const float cap = cell_caps_[static_cast<std::size_t>(region)];
    const float cap_left = std::max(cap, cell_cap(cx - 1, cy));
    const float cap_below = std::max(cap, cell_cap(cx, cy - 1));
    for (const LocalDiamond& d : tables().by_level[static_cast<std::size_t>(level)]) {
        DiamondBounds& out = own_bounds[d.local];
        if (!inside({d.k, d.l})) {
            out = {};
            own_caps[d.local] = 0.0f;
            continue; // a virtual cell's diamonds past the map's last line
        }
        // its own vertices: the centre, the hypotenuse ends, the apexes on the map; a diamond
        // off the cell's borders has them all in the cell, as its block has them
        const bool in_block = inner && d.k != 0 && d.l != 0;
        const auto vertex = [&](LocalDiamond::Offset q) {
            return in_block ? own_raw[q[1] * kSide + q[0]] : height(q);
        };
        const std::int64_t zc = vertex({d.k, d.l});
        const std::int64_t z0 = vertex(d.ends[0]);
        const std::int64_t z1 = vertex(d.ends[1]);
        std::int64_t own_lo = std::min({zc, z0, z1});
        std::int64_t own_hi = std::max({zc, z0, z1});
        for (const auto& a : d.apexes)
            if (in_block || inside(a)) {
                const std::int64_t z = vertex(a);
                own_lo = std::min(own_lo, z);
                own_hi = std::max(own_hi, z);
            }
        const double local = static_cast<double>(std::llabs(2 * zc - z0 - z1)) * 0.5 * mpf;
        // a border diamond's triangles lie in this cell and the one on its -x or -y side
        float nested_cap = d.k == 0 ? cap_left : d.l == 0 ? cap_below : cap;
        double child = 0.0;
        double lo = kInfinity;
        double hi = -kInfinity;
        if (level == kMaxDiamondLevel) {
            for (std::size_t i = 0; i < 2; ++i) {
                if (!inside(d.apexes[i]))
                    continue;
                const std::int32_t r =
                    records_->recordOf(cx + d.finest_cells[i][0], cy + d.finest_cells[i][1]);
                if (r >= 0)
                    child = std::max(child, static_cast<double>(records_->finestError(r)) * mpf);
            }
        } else {
            for (const auto& q : d.kids) {
                if (!inside(q))
                    continue;
                const std::int32_t dx = q[0] < 0 ? -1 : (q[0] >= kLatticePerCell ? 1 : 0);
                const std::int32_t dy = q[1] < 0 ? -1 : (q[1] >= kLatticePerCell ? 1 : 0);
                std::int32_t s = static_cast<std::int32_t>(slot);
                if ((dx | dy) != 0) {
                    const std::int32_t x = cx + dx;
                    const std::int32_t y = cy + dy;
                    s = x >= rx0_ && y >= ry0_ && x < rx0_ + rw_ && y < ry0_ + rh_
                            ? bound_slot_[static_cast<std::size_t>(regionIndex(x, y))]
                            : -1;
                }
                const std::int32_t kk = q[0] - dx * kLatticePerCell;
                const std::int32_t kl = q[1] - dy * kLatticePerCell;
                if (s >= 0) {
                    const std::size_t at = static_cast<std::size_t>(s) * kCellDiamonds +
                                           static_cast<std::size_t>(kl * kLatticePerCell + kk);
                    const DiamondBounds& b = bounds_[at];
                    lo = std::min(lo, static_cast<double>(b.zlo));
                    hi = std::max(hi, static_cast<double>(b.zhi));
                    nested_cap = std::max(nested_cap, caps_[at]);
                    child = std::max(child, static_cast<double>(b.delta));
                    continue;
                }
                // a cell without bounds here (no record: drawn with its base triangles, which
                // are the surface; or past the window, which no target's bound reaches)
                nested_cap = std::max(nested_cap, cell_cap(cx + dx, cy + dy));
                const Diamond cd = diamondAt({ox + q[0], oy + q[1]});
                for (const LatticePoint e : hypotenuseEnds(cd)) {
                    const double z = static_cast<double>(height(
                                         {static_cast<std::int8_t>(e.x - ox),
                                          static_cast<std::int8_t>(e.y - oy)})) *
                                     mpf;
                    lo = std::min(lo, z);
                    hi = std::max(hi, z);
                }
                for (const LatticePoint a : roam::apexes(cd)) {
                    const LocalDiamond::Offset ao{
                        static_cast<std::int8_t>(a.x - ox), static_cast<std::int8_t>(a.y - oy)};
                    if (!inside(ao))
                        continue;
                    const double z = static_cast<double>(height(ao)) * mpf;
                    lo = std::min(lo, z);
                    hi = std::max(hi, z);
                }
            }
        }
        // the nested bound and the cap are both true bounds: the smaller is kept, and the box
        // widened by it still holds the surface over the diamond and every descendant's box
        const float kept = std::min(roundUp(local + child), nested_cap);
        const double widen = kept;
        out.delta = kept;
        out.zlo = roundDown(std::min(static_cast<double>(own_lo) * mpf - widen, lo));
        out.zhi = roundUp(std::max(static_cast<double>(own_hi) * mpf + widen, hi));
        own_caps[d.local] = nested_cap;
    }
}

void BlockBounds::heights(std::size_t i, std::span<std::int64_t, kBlockVertices> out) const {
    const DetailBlocks::CellXY c = targets_[i];
    const std::int32_t slot = height_slot_[static_cast<std::size_t>(regionIndex(c.x, c.y))];
    std::copy_n(
        heights_.begin() + static_cast<std::ptrdiff_t>(slot) * kBlockVertices, kBlockVertices,
        out.begin());
}

std::size_t BlockBounds::memoryBytes() const {
    return (height_slot_.capacity() + ruled_slot_.capacity() + bound_slot_.capacity()) *
               sizeof(std::int32_t) +
           (heights_.capacity() + ruled_.capacity()) * sizeof(std::int64_t) +
           bounds_.capacity() * sizeof(DiamondBounds) +
           (caps_.capacity() + cell_caps_.capacity()) * sizeof(float) +
           bound_cells_.capacity() * sizeof(DetailBlocks::CellXY) +
           target_bounds_.capacity() * sizeof(std::size_t) +
           targets_.capacity() * sizeof(DetailBlocks::CellXY);
}

} // namespace terrain::roam
