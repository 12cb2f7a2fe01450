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

/// A cell of the 3 x 3 around a diamond's own, as (dy + 1) * 3 + (dx + 1); 4 is its own.
constexpr int kOwnCell = 4;

using Offset = std::array<std::int8_t, 2>;

/// A vertex read: which cell's heights (its closed square, the diamond's own preferred) and
/// where in them.
struct VertexRef {
    Offset at{}; ///< relative to the diamond's cell origin
    std::uint8_t cell = kOwnCell;
    std::uint16_t index = 0; ///< l * 17 + k in that cell
};

/// A child read: the cell that owns it (half-open squares) and its local position there.
struct ChildRef {
    Offset at{};
    std::uint8_t cell = kOwnCell;
    std::uint8_t local = 0;
    std::array<VertexRef, 4> corners{}; ///< its hypotenuse ends, then its apexes
};

/// A sub-grid diamond's geometry relative to its cell's origin (lattice units; the same in every
/// cell, as cell origins are multiples of 16).
struct LocalDiamond {
    std::uint8_t local = 0; ///< l * 16 + k
    std::int8_t k = 0;
    std::int8_t l = 0;
    VertexRef centre;
    std::array<VertexRef, 2> ends{};
    std::array<VertexRef, 2> apexes{};
    std::array<ChildRef, 4> kids{}; ///< none at level 19
    /// Level 19: the cell (0..8) of the triangle with apexes[i].
    std::array<std::uint8_t, 2> finest_cells{};
};

using Mask = std::array<std::uint64_t, 4>; ///< one bit per local position

bool test(const Mask& m, std::uint32_t local) {
    return ((m[local / 64] >> (local % 64)) & 1u) != 0;
}

void set(Mask& m, std::uint32_t local) {
    m[local / 64] |= std::uint64_t{1} << (local % 64);
}

struct Tables {
    std::array<std::vector<LocalDiamond>, kFinestTriangleLevel> by_level;
    /// The diamonds of each cell of a target's 3 x 3 that the target's bounds depend on (its
    /// own 255, and the descendants of its border diamonds in its neighbours).
    std::array<Mask, 9> closure{};
};

int cellIndex(std::int32_t dx, std::int32_t dy) {
    return (dy + 1) * 3 + (dx + 1);
}

VertexRef vertexRef(std::int32_t x, std::int32_t y) {
    // the diamond's own closed square first: a vertex on its border is the same in both cells
    const std::int32_t dx = x < 0 ? -1 : (x > kLatticePerCell ? 1 : 0);
    const std::int32_t dy = y < 0 ? -1 : (y > kLatticePerCell ? 1 : 0);
    TERRAIN_ASSERT(
        x >= -kLatticePerCell && y >= -kLatticePerCell && x <= 2 * kLatticePerCell &&
        y <= 2 * kLatticePerCell);
    VertexRef r;
    r.at = {static_cast<std::int8_t>(x), static_cast<std::int8_t>(y)};
    r.cell = static_cast<std::uint8_t>(cellIndex(dx, dy));
    r.index =
        static_cast<std::uint16_t>((y - dy * kLatticePerCell) * kSide + (x - dx * kLatticePerCell));
    return r;
}

/// Floor division into a cell offset and the position in it.
std::int32_t cellOf(std::int32_t v) {
    return v < 0 ? -1 : (v >= kLatticePerCell ? 1 : 0);
}

const Tables& tables() {
    static const Tables t = [] {
        Tables out;
        // a cell away from the origin, so that every offset is a plain difference
        const LatticePoint o{2 * kLatticePerCell, 2 * kLatticePerCell};
        for (std::int32_t l = 0; l < kLatticePerCell; ++l)
            for (std::int32_t k = 0; k < kLatticePerCell; ++k) {
                if ((k | l) == 0)
                    continue;
                const Diamond d = diamondAt({o.x + k, o.y + l});
                LocalDiamond ld;
                ld.local = static_cast<std::uint8_t>(l * kLatticePerCell + k);
                ld.k = static_cast<std::int8_t>(k);
                ld.l = static_cast<std::int8_t>(l);
                ld.centre = vertexRef(k, l);
                const auto ends = hypotenuseEnds(d);
                const auto tips = roam::apexes(d);
                for (std::size_t i = 0; i < 2; ++i) {
                    ld.ends[i] = vertexRef(ends[i].x - o.x, ends[i].y - o.y);
                    ld.apexes[i] = vertexRef(tips[i].x - o.x, tips[i].y - o.y);
                }
                if (d.level == kMaxDiamondLevel) {
                    for (std::size_t i = 0; i < 2; ++i) {
                        const LatticePoint c3 = centroidTimes3(triangleOf(d, tips[i]));
                        ld.finest_cells[i] = static_cast<std::uint8_t>(cellIndex(
                            c3.x / (3 * kLatticePerCell) - 2, c3.y / (3 * kLatticePerCell) - 2));
                    }
                } else {
                    std::array<LatticePoint, 4> kids{};
                    children(d, kids);
                    for (std::size_t i = 0; i < 4; ++i) {
                        const std::int32_t x = kids[i].x - o.x;
                        const std::int32_t y = kids[i].y - o.y;
                        ChildRef& c = ld.kids[i];
                        c.at = {static_cast<std::int8_t>(x), static_cast<std::int8_t>(y)};
                        const std::int32_t dx = cellOf(x);
                        const std::int32_t dy = cellOf(y);
                        c.cell = static_cast<std::uint8_t>(cellIndex(dx, dy));
                        c.local = static_cast<std::uint8_t>(
                            (y - dy * kLatticePerCell) * kLatticePerCell +
                            (x - dx * kLatticePerCell));
                        const Diamond cd = diamondAt(kids[i]);
                        const auto ce = hypotenuseEnds(cd);
                        const auto ca = roam::apexes(cd);
                        for (std::size_t j = 0; j < 2; ++j) {
                            c.corners[j] = vertexRef(ce[j].x - o.x, ce[j].y - o.y);
                            c.corners[2 + j] = vertexRef(ca[j].x - o.x, ca[j].y - o.y);
                        }
                    }
                }
                out.by_level[static_cast<std::size_t>(d.level)].push_back(ld);
            }
        // the closure: a target's diamonds and, recursively, their children
        std::vector<LatticePoint> stack;
        for (std::int32_t local = 1; local < kLatticePerCell * kLatticePerCell; ++local)
            stack.push_back({o.x + local % kLatticePerCell, o.y + local / kLatticePerCell});
        while (!stack.empty()) {
            const LatticePoint p = stack.back();
            stack.pop_back();
            const std::int32_t dx = cellOf(p.x - o.x);
            const std::int32_t dy = cellOf(p.y - o.y);
            // every read of a diamond the target depends on stays in the target's 3 x 3
            TERRAIN_ASSERT(p.x - o.x >= -kLatticePerCell + 1 && p.x - o.x < 2 * kLatticePerCell);
            TERRAIN_ASSERT(p.y - o.y >= -kLatticePerCell + 1 && p.y - o.y < 2 * kLatticePerCell);
            const auto local = static_cast<std::uint32_t>(
                (p.y - o.y - dy * kLatticePerCell) * kLatticePerCell +
                (p.x - o.x - dx * kLatticePerCell));
            Mask& m = out.closure[static_cast<std::size_t>(cellIndex(dx, dy))];
            if (test(m, local))
                continue;
            set(m, local);
            const Diamond d = diamondAt(p);
            // and so does every height it or a child without bounds reads
            const auto within = [&](LatticePoint q) {
                return q.x - o.x >= -kLatticePerCell && q.x - o.x <= 2 * kLatticePerCell &&
                       q.y - o.y >= -kLatticePerCell && q.y - o.y <= 2 * kLatticePerCell;
            };
            for (const LatticePoint q : hypotenuseEnds(d))
                TERRAIN_ASSERT(within(q));
            for (const LatticePoint q : roam::apexes(d))
                TERRAIN_ASSERT(within(q));
            std::array<LatticePoint, 4> kids{};
            const int n = children(d, kids);
            for (int i = 0; i < n; ++i)
                stack.push_back(kids[static_cast<std::size_t>(i)]);
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
    const Tables& tab = tables();
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
    // the targets' 3 x 3 windows; cells 0 .. grid - 1, the last column and row being the
    // virtual ones past the padded grid
    rx0_ = std::max(0, x0 - 1);
    ry0_ = std::max(0, y0 - 1);
    const std::int32_t rx1 = std::min(g.grid_w - 1, x1 + 1);
    const std::int32_t ry1 = std::min(g.grid_h - 1, y1 + 1);
    rw_ = rx1 - rx0_ + 1;
    rh_ = ry1 - ry0_ + 1;
    const auto region = static_cast<std::size_t>(rw_) * static_cast<std::size_t>(rh_);
    needed_.assign(region, {});
    height_slot_.assign(region, -1);
    ruled_slot_.assign(region, -1);
    bound_slot_.assign(region, -1);
    cell_caps_.resize(region);
    for (const auto& c : cells)
        for (std::int32_t dy = -1; dy <= 1; ++dy)
            for (std::int32_t dx = -1; dx <= 1; ++dx) {
                const std::int32_t x = c.x + dx;
                const std::int32_t y = c.y + dy;
                if (x < rx0_ || y < ry0_ || x > rx1 || y > ry1)
                    continue;
                Mask& m = needed_[static_cast<std::size_t>(regionIndex(x, y))];
                const Mask& add = tab.closure[static_cast<std::size_t>(cellIndex(dx, dy))];
                for (std::size_t w = 0; w < m.size(); ++w)
                    m[w] |= add[w];
            }
    // heights for every cell of the windows, bounds for the detail cells among them
    bound_cells_.clear();
    std::int32_t heights = 0;
    std::int32_t ruled = 0;
    for (std::int32_t y = ry0_; y <= ry1; ++y)
        for (std::int32_t x = rx0_; x <= rx1; ++x) {
            const auto at = static_cast<std::size_t>(regionIndex(x, y));
            const std::int32_t r = records.recordOf(x, y);
            cell_caps_[at] =
                r < 0 ? 0.0f
                      : roundUp(static_cast<double>(records.cellError(r)) * g.metres_per_fine);
            const Mask& m = needed_[at];
            if ((m[0] | m[1] | m[2] | m[3]) == 0)
                continue;
            height_slot_[at] = heights++;
            if (special(x, y))
                ruled_slot_[at] = ruled++;
            if (r >= 0) {
                bound_slot_[at] = static_cast<std::int32_t>(bound_cells_.size());
                bound_cells_.push_back({x, y});
            }
        }
    heights_.resize(static_cast<std::size_t>(heights) * kBlockVertices);
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
    frames_.clear();
    for (const auto& c : bound_cells_)
        frames_.push_back(frameOf(c.x, c.y));
    for (int level = kMaxDiamondLevel; level > kCellTriangleLevel; --level)
        for (const CellFrame& f : frames_)
            boundLevel(f, level);
    for (const auto& c : cells) {
        const std::int32_t slot = bound_slot_[static_cast<std::size_t>(regionIndex(c.x, c.y))];
        TERRAIN_ASSERT(slot >= 0); // a target must be a detail cell
        target_bounds_.push_back(static_cast<std::size_t>(slot));
    }
}

BlockBounds::CellFrame BlockBounds::frameOf(std::int32_t cx, std::int32_t cy) const {
    const BlockGeometry& g = geometry_;
    const double mpf = g.metres_per_fine;
    CellFrame f;
    f.cx = cx;
    f.cy = cy;
    const auto region = static_cast<std::size_t>(regionIndex(cx, cy));
    f.needed = &needed_[region];
    const auto slot = static_cast<std::size_t>(bound_slot_[region]);
    f.own_raw = heights_.data() + static_cast<std::size_t>(height_slot_[region]) * kBlockVertices;
    f.own_bounds = slot * kCellDiamonds;
    // the 3 x 3 around: the heights as the mesh's rules read them, the bounds, the caps and the
    // finest triangles' errors
    for (std::int32_t dy = -1; dy <= 1; ++dy)
        for (std::int32_t dx = -1; dx <= 1; ++dx) {
            const std::size_t n = static_cast<std::size_t>(cellIndex(dx, dy));
            const std::int32_t x = cx + dx;
            const std::int32_t y = cy + dy;
            const std::int32_t r = records_->recordOf(x, y);
            f.finest[n] = r < 0 ? 0.0 : static_cast<double>(records_->finestError(r)) * mpf;
            if (x >= rx0_ && y >= ry0_ && x < rx0_ + rw_ && y < ry0_ + rh_) {
                const auto at = static_cast<std::size_t>(regionIndex(x, y));
                if (const std::int32_t rs = ruled_slot_[at]; rs >= 0)
                    f.heights[n] = ruled_.data() + static_cast<std::size_t>(rs) * kBlockVertices;
                else if (const std::int32_t h = height_slot_[at]; h >= 0)
                    f.heights[n] = heights_.data() + static_cast<std::size_t>(h) * kBlockVertices;
                f.bounds[n] = bound_slot_[at];
                f.caps[n] = cell_caps_[at];
            } else {
                f.caps[n] =
                    r < 0 ? 0.0f : roundUp(static_cast<double>(records_->cellError(r)) * mpf);
            }
        }
    // a cell whose every neighbour's points are on the map needs no map checks
    f.clear = cx >= 1 && cy >= 1 && cx <= g.grid_w - 3 && cy <= g.grid_h - 3;
    // a cell of the padded grid (not a virtual one past it)
    f.inner = cx <= g.grid_w - 2 && cy <= g.grid_h - 2;
    return f;
}

void BlockBounds::boundLevel(const CellFrame& f, int level) {
    if (f.clear)
        boundLevelOf<true>(f, level);
    else
        boundLevelOf<false>(f, level);
}

template <bool kClear> void BlockBounds::boundLevelOf(const CellFrame& f, int level) {
    const BlockGeometry& g = geometry_;
    const double mpf = g.metres_per_fine;
    const std::int32_t max_x = (g.grid_w - 1) * kLatticePerCell;
    const std::int32_t max_y = (g.grid_h - 1) * kLatticePerCell;
    const std::int32_t ox = f.cx * kLatticePerCell;
    const std::int32_t oy = f.cy * kLatticePerCell;
    const Mask& needed = *f.needed;
    const std::int64_t* own_raw = f.own_raw;
    DiamondBounds* own_bounds = bounds_.data() + f.own_bounds;
    float* own_caps = caps_.data() + f.own_bounds;
    const auto inside = [&](Offset q) {
        if constexpr (kClear) {
            return true;
        } else {
            const std::int32_t x = ox + q[0];
            const std::int32_t y = oy + q[1];
            return x >= 0 && y >= 0 && x <= max_x && y <= max_y;
        }
    };
    const auto height = [&](const VertexRef& v) {
        TERRAIN_ASSERT(f.heights[v.cell] != nullptr);
        return f.heights[v.cell][v.index];
    };
    const float cap = f.caps[kOwnCell];
    const float cap_left = std::max(cap, f.caps[static_cast<std::size_t>(cellIndex(-1, 0))]);
    const float cap_below = std::max(cap, f.caps[static_cast<std::size_t>(cellIndex(0, -1))]);
    const bool inner = kClear || f.inner;
    for (const LocalDiamond& d : tables().by_level[static_cast<std::size_t>(level)]) {
        if (!test(needed, d.local))
            continue; // no target's bound depends on it
        DiamondBounds& out = own_bounds[d.local];
        if (!inside({d.k, d.l})) {
            out = {};
            own_caps[d.local] = 0.0f;
            continue; // a virtual cell's diamonds past the map's last line
        }
        // its own vertices: the centre, the hypotenuse ends, the apexes on the map; a diamond
        // off the cell's borders has them all in the cell, as its block has them
        const bool in_block = inner && d.k != 0 && d.l != 0;
        const auto vertex = [&](const VertexRef& v) {
            return in_block ? own_raw[v.index] : height(v);
        };
        const std::int64_t zc = vertex(d.centre);
        const std::int64_t z0 = vertex(d.ends[0]);
        const std::int64_t z1 = vertex(d.ends[1]);
        std::int64_t own_lo = std::min({zc, z0, z1});
        std::int64_t own_hi = std::max({zc, z0, z1});
        for (const VertexRef& a : d.apexes)
            if (in_block || inside(a.at)) {
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
            for (std::size_t i = 0; i < 2; ++i)
                if (inside(d.apexes[i].at))
                    child = std::max(child, f.finest[d.finest_cells[i]]);
        } else {
            // the children's bounds in floats: min and max are exact, so this is the same as
            // taking them in doubles
            float kid_lo = std::numeric_limits<float>::infinity();
            float kid_hi = -std::numeric_limits<float>::infinity();
            float kid_delta = 0.0f;
            for (const ChildRef& c : d.kids) {
                if (!inside(c.at))
                    continue;
                if (const std::int32_t s = f.bounds[c.cell]; s >= 0) {
                    const std::size_t at = static_cast<std::size_t>(s) * kCellDiamonds + c.local;
                    const DiamondBounds& b = bounds_[at];
                    kid_lo = std::min(kid_lo, b.zlo);
                    kid_hi = std::max(kid_hi, b.zhi);
                    nested_cap = std::max(nested_cap, caps_[at]);
                    kid_delta = std::max(kid_delta, b.delta);
                    continue;
                }
                // a cell without a record: drawn with its base triangles, which are the surface
                nested_cap = std::max(nested_cap, f.caps[c.cell]);
                for (std::size_t j = 0; j < c.corners.size(); ++j) {
                    if (j >= 2 && !inside(c.corners[j].at))
                        continue; // an apex off the map
                    const double z = static_cast<double>(height(c.corners[j])) * mpf;
                    lo = std::min(lo, z);
                    hi = std::max(hi, z);
                }
            }
            lo = std::min(lo, static_cast<double>(kid_lo));
            hi = std::max(hi, static_cast<double>(kid_hi));
            child = static_cast<double>(kid_delta);
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
           needed_.capacity() * sizeof(needed_[0]) +
           (heights_.capacity() + ruled_.capacity()) * sizeof(std::int64_t) +
           bounds_.capacity() * sizeof(DiamondBounds) +
           (caps_.capacity() + cell_caps_.capacity()) * sizeof(float) +
           bound_cells_.capacity() * sizeof(DetailBlocks::CellXY) +
           frames_.capacity() * sizeof(CellFrame) +
           target_bounds_.capacity() * sizeof(std::size_t) +
           targets_.capacity() * sizeof(DetailBlocks::CellXY);
}

} // namespace terrain::roam
