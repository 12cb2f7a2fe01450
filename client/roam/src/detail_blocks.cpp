#include "float_rounding.h"

#include <terrain/assert.h>
#include <terrain/fixed_point.h>
#include <terrain/roam/detail_blocks.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace terrain::roam {

namespace {

static_assert(kFineUnitsPerQuantum == kBlockSide - 1, "fine units make 1/16-cell points exact");

// fine units are far below 2^53: exact as doubles
float roundedUp(std::int64_t v) {
    return detail::roundUp(static_cast<double>(v));
}

float roundedDown(std::int64_t v) {
    return detail::roundDown(static_cast<double>(v));
}

/// Bound (controls, i.e. sixths of a quantum, per cell^2) on the norm of the patch's Hessian.
/// Its second derivatives are splines whose coefficients are the controls' differences, scaled
/// by the knot spacing of the clamped cubic {0,0,0,0, 1/2, 1,1,1,1}, and a spline stays within
/// its coefficients' range; a symmetric 2 x 2 matrix's norm is at most max(|f_uu|, |f_vv|) +
/// |f_uv| (Gershgorin).
std::int64_t hessianBound(const DetailPatch& p) {
    // first derivative: 3 (c[i+1] - c[i]) / (t[i+4] - t[i+1]); second: 2 (d[i+1] - d[i]) /
    // (t'[i+3] - t'[i+1]) on the derivative's knots {0,0,0, 1/2, 1,1,1}
    constexpr std::array<std::int64_t, 4> kFirst = {6, 3, 3, 6};
    constexpr std::array<std::int64_t, 3> kSecond = {4, 2, 4};
    const auto second = [&](auto control) {
        std::array<std::int64_t, 4> d{};
        for (std::size_t k = 0; k < d.size(); ++k)
            d[k] = kFirst[k] * (control(static_cast<int>(k) + 1) - control(static_cast<int>(k)));
        std::int64_t worst = 0;
        for (std::size_t k = 0; k < kSecond.size(); ++k)
            worst = std::max(worst, std::abs(kSecond[k] * (d[k + 1] - d[k])));
        return worst;
    };
    std::int64_t uu = 0;
    std::int64_t vv = 0;
    std::int64_t uv = 0;
    for (int line = 0; line < bspline::kControls; ++line) {
        uu = std::max(uu, second([&](int i) { return std::int64_t{p.at(i, line)}; }));
        vv = std::max(vv, second([&](int j) { return std::int64_t{p.at(line, j)}; }));
    }
    for (int j = 0; j + 1 < bspline::kControls; ++j)
        for (int i = 0; i + 1 < bspline::kControls; ++i) {
            const std::int64_t twist =
                std::int64_t{p.at(i + 1, j + 1)} - p.at(i, j + 1) - p.at(i + 1, j) + p.at(i, j);
            uv = std::max(
                uv, std::abs(
                        kFirst[static_cast<std::size_t>(i)] * kFirst[static_cast<std::size_t>(j)] *
                        twist));
        }
    return std::max(uu, vv) + uv;
}

std::int64_t exactBaseHeight(const CellCorners& c, Diagonal d, std::int32_t k, std::int32_t l) {
    return baseHeightScaled(c, d, k, l, kBlockSide - 1);
}

} // namespace

void DetailBlocks::reset(const Terrain& t) {
    // one virtual column and row past the padded grid: a diamond on the map's last line belongs
    // to the cell on its +x / +y side, so a patch on an unpadded border needs a record there
    cells_x_ = t.spec().paddedWidth();
    cells_y_ = t.spec().paddedHeight();
    // a record packs its cell's index in 31 bits (kMaxMapVertices per side keeps far below)
    TERRAIN_ASSERT(
        std::uint64_t{static_cast<std::uint32_t>(cells_x_)} * static_cast<std::uint32_t>(cells_y_) <
        kPatchBit);
    pages_x_ = (cells_x_ + kPageCells - 1) / kPageCells;
    const auto pages = static_cast<std::size_t>(pages_x_) *
                       static_cast<std::size_t>((cells_y_ + kPageCells - 1) / kPageCells);
    pages_.assign(pages, {});
    page_records_.assign(pages, 0);
    records_.clear();
    free_records_.clear();
    record_of_block_.clear();
    free_.clear();
    // every patch cell marks its halo, in cell order so record ids are deterministic
    std::vector<std::uint8_t> needed(
        static_cast<std::size_t>(cells_x_) * static_cast<std::size_t>(cells_y_), 0);
    for (std::int32_t tile = 0; tile < t.spec().tileCount(); ++tile) {
        const std::int32_t tx = tile % t.spec().tilesX();
        const std::int32_t ty = tile / t.spec().tilesX();
        for (const PatchEntry& e : t.tilePatches(tile)) {
            const std::int32_t cx = tx * kTileCells + e.cell % kTileCells;
            const std::int32_t cy = ty * kTileCells + e.cell / kTileCells;
            for (std::int32_t y = std::max(0, cy - kDetailHaloCells);
                 y <= std::min(cells_y_ - 1, cy + kDetailHaloCells); ++y)
                for (std::int32_t x = std::max(0, cx - kDetailHaloCells);
                     x <= std::min(cells_x_ - 1, cx + kDetailHaloCells); ++x)
                    needed[cellIndex(x, y)] = 1;
        }
    }
    // a large world has many records: no growth slack (ops add a few at a time later)
    records_.reserve(static_cast<std::size_t>(std::count(needed.begin(), needed.end(), 1)));
    for (std::int32_t y = 0; y < cells_y_; ++y)
        for (std::int32_t x = 0; x < cells_x_; ++x)
            if (needed[cellIndex(x, y)] != 0)
                summarise(t, takeRecord(x, y));
}

bool DetailBlocks::needsRecord(const Terrain& t, std::int32_t cx, std::int32_t cy) const {
    const std::int32_t real_x = t.spec().cellsX();
    const std::int32_t real_y = t.spec().cellsY();
    for (std::int32_t y = std::max(0, cy - kDetailHaloCells);
         y <= std::min(real_y - 1, cy + kDetailHaloCells); ++y)
        for (std::int32_t x = std::max(0, cx - kDetailHaloCells);
             x <= std::min(real_x - 1, cx + kDetailHaloCells); ++x)
            if (t.findPatch(x, y) != nullptr)
                return true;
    return false;
}

CellRect DetailBlocks::aroundChange(CellRect cells) const {
    // a patch appearing or going changes the needs of cells up to the halo away
    return {
        std::max(0, cells.x0 - kDetailHaloCells), std::max(0, cells.y0 - kDetailHaloCells),
        std::min(cells_x_ - 1, cells.x1 + kDetailHaloCells),
        std::min(cells_y_ - 1, cells.y1 + kDetailHaloCells)};
}

void DetailBlocks::plan(
    const Terrain& t, CellRect cells, std::vector<std::int32_t>& removing) const {
    if (cells.empty())
        return;
    const auto [x0, y0, x1, y1] = aroundChange(cells);
    for (std::int32_t y = y0; y <= y1; ++y)
        for (std::int32_t x = x0; x <= x1; ++x)
            if (const std::int32_t r = recordOf(x, y); r >= 0 && !needsRecord(t, x, y))
                removing.push_back(r);
}

void DetailBlocks::update(
    const Terrain& t,
    CellRect cells,
    std::vector<std::int32_t>& removed,
    std::vector<std::int32_t>& added) {
    if (cells.empty())
        return;
    const auto [x0, y0, x1, y1] = aroundChange(cells);
    for (std::int32_t y = y0; y <= y1; ++y) {
        for (std::int32_t x = x0; x <= x1; ++x) {
            const bool need = needsRecord(t, x, y);
            const std::int32_t r = recordOf(x, y);
            if (need && r < 0) {
                const std::int32_t made = takeRecord(x, y);
                summarise(t, made);
                added.push_back(made);
            } else if (!need && r >= 0) {
                TERRAIN_ASSERT(records_[idx(r)].block < 0); // released by the tessellator
                dropRecord(r);
                removed.push_back(r);
            } else if (r >= 0 && x >= cells.x0 && x <= cells.x1 && y >= cells.y0 && y <= cells.y1) {
                summarise(t, r);
            }
        }
    }
}

std::int32_t DetailBlocks::takeRecord(std::int32_t cx, std::int32_t cy) {
    std::int32_t r = 0;
    if (!free_records_.empty()) {
        r = free_records_.back();
        free_records_.pop_back();
    } else {
        r = recordCapacity();
        records_.emplace_back();
    }
    records_[idx(r)] = {};
    records_[idx(r)].cell = static_cast<std::uint32_t>(cellIndex(cx, cy));
    setRecordOf(cx, cy, r);
    return r;
}

void DetailBlocks::setRecordOf(std::int32_t cx, std::int32_t cy, std::int32_t r) {
    const std::size_t p = pageOf(cx, cy);
    std::vector<std::int32_t>& page = pages_[p];
    if (r >= 0) {
        if (page.empty())
            page.assign(static_cast<std::size_t>(kPageCells * kPageCells), -1);
        ++page_records_[p];
        page[pageSlot(cx, cy)] = r;
    } else if (--page_records_[p] == 0) {
        std::vector<std::int32_t>().swap(page);
    } else {
        page[pageSlot(cx, cy)] = -1;
    }
}

void DetailBlocks::dropRecord(std::int32_t r) {
    const CellXY c = recordCell(r);
    setRecordOf(c.x, c.y, -1);
    records_[idx(r)] = {};
    free_records_.push_back(r);
}

void DetailBlocks::summarise(const Terrain& t, std::int32_t r) {
    Record& rec = records_[idx(r)];
    const CellXY cell = recordCell(r);
    rec.cell &= ~kPatchBit;
    const std::int32_t last_x = t.spec().paddedWidth() - 2; // last cell of the padded grid
    const std::int32_t last_y = t.spec().paddedHeight() - 2;
    rec.finest_error = 0.0f;
    rec.cell_error = 0.0f;
    rec.lo = 0.0f;
    rec.hi = 0.0f;
    if (cell.x > last_x || cell.y > last_y)
        return; // a virtual cell: no surface of its own
    const bool real = cell.x < t.spec().cellsX() && cell.y < t.spec().cellsY();
    const DetailPatch* patch = real ? t.findPatch(cell.x, cell.y) : nullptr;
    const CellCorners c = t.corners(cell.x, cell.y);
    std::int64_t lo = std::int64_t{std::min({c.h00, c.h10, c.h01, c.h11})} * kFineUnitsPerQuantum;
    std::int64_t hi = std::int64_t{std::max({c.h00, c.h10, c.h01, c.h11})} * kFineUnitsPerQuantum;
    if (patch == nullptr) { // vertices exactly on the base triangles, which are the surface
        rec.lo = roundedDown(lo);
        rec.hi = roundedUp(hi);
        return;
    }
    rec.cell |= kPatchBit;
    // the bound already allows half a quantum of rounding; ours is 1/32
    rec.finest_error = patch->grid_error_bound * static_cast<float>(kFineUnitsPerQuantum);
    const std::int64_t dev =
        static_cast<std::int64_t>(patch->deviation_bound) * kFineUnitsPerQuantum;
    // vertices: within dev of the base, plus half a unit of rounding (1 rounded up)
    rec.lo = roundedDown(lo - dev - 1);
    rec.hi = roundedUp(hi + dev + 1);
    // Two bounds on how far a triangle on the block's (rounded) vertices, inside one of the
    // cell's base triangles, is from the patch; the smaller is kept:
    //  - it is within dev + 1 of that (linear) base triangle, and the surface within dev;
    //  - linear interpolation on a triangle of circumradius R is within ||H|| R^2 / 2 of the
    //    surface, and R^2 <= 1/2 cell^2 for a base triangle and all its descendants; the
    //    rounded vertices add half a unit. Far smaller for a crater wider than a cell.
    const std::int64_t curvature =
        (hessianBound(*patch) * kFineUnitsPerQuantum + 4 * kControlScale - 1) /
            (4 * kControlScale) +
        1;
    rec.cell_error = roundedUp(std::min(2 * dev + 1, curvature));
}

std::int32_t DetailBlocks::materialise(std::int32_t r) {
    TERRAIN_ASSERT(records_[idx(r)].block < 0);
    std::int32_t block = 0;
    if (!free_.empty()) {
        block = free_.back();
        free_.pop_back();
    } else {
        block = capacity();
        record_of_block_.push_back(-1);
    }
    record_of_block_[idx(block)] = r;
    records_[idx(r)].block = block;
    return block;
}

void DetailBlocks::release(std::int32_t block) {
    records_[idx(record_of_block_[idx(block)])].block = -1;
    record_of_block_[idx(block)] = -1;
    free_.push_back(block);
}

std::size_t DetailBlocks::memoryBytes() const {
    std::size_t table =
        pages_.capacity() * sizeof(pages_[0]) + page_records_.capacity() * sizeof(std::int32_t);
    for (const auto& page : pages_)
        table += page.capacity() * sizeof(std::int32_t);
    return table + records_.capacity() * sizeof(Record) +
           (free_records_.capacity() + record_of_block_.capacity() + free_.capacity()) *
               sizeof(std::int32_t);
}

void fillCellHeights(
    const Terrain& t,
    std::int32_t cx,
    std::int32_t cy,
    std::span<std::int64_t, kBlockVertices> out,
    std::int32_t stride) {
    const std::int32_t last_x = t.spec().paddedWidth() - 2; // last cell of the padded grid
    const std::int32_t last_y = t.spec().paddedHeight() - 2;
    if (cx > last_x || cy > last_y) {
        // a virtual cell past the grid: it carries diamond state only; the tessellator takes
        // heights on the map's last line from the real cell before it
        std::fill(out.begin(), out.end(), std::int64_t{0});
        return;
    }
    const bool real = cx < t.spec().cellsX() && cy < t.spec().cellsY();
    const DetailPatch* patch = real ? t.findPatch(cx, cy) : nullptr;
    if (patch != nullptr) {
        std::array<std::int64_t, kPatchGridVertices> numerators{};
        gridNumerators(*patch, numerators, stride);
        for (std::int32_t l = 0; l < kBlockSide; l += stride)
            for (std::int32_t k = 0; k < kBlockSide; k += stride) {
                const auto i = static_cast<std::size_t>(l * kBlockSide + k);
                out[i] = roundDiv(numerators[i] * kFineUnitsPerQuantum, kGridDenominator);
            }
        return;
    }
    const CellCorners corners = t.corners(cx, cy);
    const Diagonal d = cellDiagonal(cx, cy);
    for (std::int32_t l = 0; l < kBlockSide; l += stride)
        for (std::int32_t k = 0; k < kBlockSide; k += stride)
            out[static_cast<std::size_t>(l * kBlockSide + k)] = exactBaseHeight(corners, d, k, l);
}

} // namespace terrain::roam
