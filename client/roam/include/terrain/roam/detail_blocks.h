#pragma once

// Which cells the tessellator may refine below the base grid, and the vertices it uses there.
//
// A cell with a detail patch is refined into the patch's 17 x 17 grid (evaluateGrid). Its
// neighbours must follow part of the way, or the finer triangles along the shared edge would
// leave T-junctions: a forced split crosses into the neighbour and needs vertices inside it. So
// every cell within kDetailHaloCells (Chebyshev distance) of a patch cell is a detail cell too,
// whose vertices lie exactly on the base triangles. Cells far from any patch are never refined
// below their two base triangles, which represent them exactly.
//
// Two grains, so that memory follows the view and not the world:
//  - a record per detail cell, eager and small: whether it has a patch, and true bounds on its
//    vertices and on how far any triangle on them is from the true surface (cellError), enough
//    for the cell's coarsest diamond to carry a true bound without the cell's heights;
//  - a block id per cell the tessellator refines below its centre (a pool of slots, reused). The
//    block's heights and diamonds live in the tessellator, in up to three chunks (block_grains.h);
//    the vertex heights come from fillCellHeights(), in fine units of 1/16 quantum: base
//    triangles are exact at 1/16 of a cell in those units, and so is a patch on its straight
//    borders (linear precision of the spline), so a patch and a halo neighbour agree bit for bit
//    along their shared edge.
// Pure: no GL, no I/O.

#include <terrain/terrain.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::roam {

/// Cells of halo around each patch cell: the forced-split closure of a cell refined to its finest
/// level puts vertices in the 8 cells around it and no further (RoamLattice test), and the
/// closure of several cells is the union of theirs.
inline constexpr std::int32_t kDetailHaloCells = 1;
inline constexpr std::int32_t kBlockSide = 17;
inline constexpr std::int32_t kBlockVertices = kBlockSide * kBlockSide;
/// Height units of the tessellator's vertices per quantum.
inline constexpr std::int64_t kFineUnitsPerQuantum = 16;

class DetailBlocks {
  public:
    struct CellXY {
        std::int32_t x = -1;
        std::int32_t y = -1;
    };

    /// Records for every patch cell of `t` and its halo; no block.
    void reset(const Terrain& t);

    /// The records update() would drop for the same change (the tessellator coarsens them first
    /// and releases their blocks).
    void plan(const Terrain& t, CellRect cells, std::vector<std::int32_t>& removing) const;

    /// After an op changed the surface of `cells`: re-derives which cells are detail cells around
    /// them (patches appear and disappear) and refreshes the records in `cells` (their blocks'
    /// heights are the tessellator's to redo). Records dropped and made are appended to
    /// `removed` / `added`; a dropped record's block must have been released.
    void update(
        const Terrain& t,
        CellRect cells,
        std::vector<std::int32_t>& removed,
        std::vector<std::int32_t>& added);

    // ---- records (eager) ----

    /// Cells covered, one virtual column and row past the padded grid included (see reset());
    /// a virtual cell has no heights, only a place for diamond state.
    std::int32_t cellsX() const { return cells_x_; }
    std::int32_t cellsY() const { return cells_y_; }
    /// Record of a cell, or -1 for a cell that is never refined.
    std::int32_t recordOf(std::int32_t cx, std::int32_t cy) const {
        if (cx < 0 || cy < 0 || cx >= cells_x_ || cy >= cells_y_)
            return -1;
        const std::vector<std::int32_t>& page = pages_[pageOf(cx, cy)];
        return page.empty() ? -1 : page[pageSlot(cx, cy)];
    }
    /// Record slots (some may be free); record ids are below this.
    std::int32_t recordCapacity() const { return static_cast<std::int32_t>(records_.size()); }
    std::int32_t recordCount() const {
        return recordCapacity() - static_cast<std::int32_t>(free_records_.size());
    }
    bool recordInUse(std::int32_t r) const { return records_[idx(r)].cell != kNoCell; }
    CellXY recordCell(std::int32_t r) const { return cellAt(records_[idx(r)].cell); }
    bool hasPatch(std::int32_t r) const {
        return recordInUse(r) && (records_[idx(r)].cell & kPatchBit) != 0;
    }
    /// Bound (fine units) on the distance between the true surface of the cell and any triangle
    /// of the finest level on its vertices (0 without a patch: they lie on it).
    float finestError(std::int32_t r) const { return records_[idx(r)].finest_error; }
    /// Bound (fine units) on the distance between the true surface of the cell and any triangle
    /// inside one of its base triangles whose vertices are block vertices: both lie within the
    /// patch's deviation bound of the base triangle (the vertices plus half a unit of rounding).
    /// Rounded up to a float.
    float cellError(std::int32_t r) const { return records_[idx(r)].cell_error; }
    /// Range (fine units) of the cell's block vertices and of its true surface, rounded outward
    /// to floats (the records of a large world are many; these only need to be bounds).
    float vertexLo(std::int32_t r) const { return records_[idx(r)].lo; }
    float vertexHi(std::int32_t r) const { return records_[idx(r)].hi; }
    /// The record's block, or -1 while it has none.
    std::int32_t blockOfRecord(std::int32_t r) const { return records_[idx(r)].block; }

    // ---- blocks (ids of the cells refined below their centre) ----

    /// Gives record `r` a block id and returns it.
    std::int32_t materialise(std::int32_t r);
    /// Frees the block id (its record stays).
    void release(std::int32_t block);
    /// Block of a cell, or -1.
    std::int32_t blockOf(std::int32_t cx, std::int32_t cy) const {
        const std::int32_t r = recordOf(cx, cy);
        return r < 0 ? -1 : records_[idx(r)].block;
    }
    /// Block slots (some may be free); block ids are below this.
    std::int32_t capacity() const { return static_cast<std::int32_t>(record_of_block_.size()); }
    std::int32_t count() const { return capacity() - static_cast<std::int32_t>(free_.size()); }
    bool inUse(std::int32_t block) const { return record_of_block_[idx(block)] >= 0; }
    std::int32_t recordOfBlock(std::int32_t block) const { return record_of_block_[idx(block)]; }
    /// The block's cell (x, y); (-1, -1) for a free slot.
    CellXY cellOf(std::int32_t block) const {
        const std::int32_t r = record_of_block_[idx(block)];
        return r < 0 ? CellXY{} : cellAt(records_[idx(r)].cell);
    }
    std::size_t memoryBytes() const;

  private:
    struct Record { // 24 bytes: one per detail cell of the world
        /// cy * cellsX() + cx, with kPatchBit set if the cell has a patch; kNoCell when free.
        std::uint32_t cell = kNoCell;
        std::int32_t block = -1;
        float finest_error = 0.0f;
        float cell_error = 0.0f;
        float lo = 0.0f;
        float hi = 0.0f;
    };
    static constexpr std::uint32_t kNoCell = 0xffffffffu;
    static constexpr std::uint32_t kPatchBit = 0x80000000u; // maps hold fewer than 2^31 cells
    CellXY cellAt(std::uint32_t packed) const {
        const std::uint32_t i = packed & ~kPatchBit;
        const auto w = static_cast<std::uint32_t>(cells_x_);
        return {static_cast<std::int32_t>(i % w), static_cast<std::int32_t>(i / w)};
    }

    static std::size_t idx(std::int32_t v) { return static_cast<std::size_t>(v); }
    std::size_t cellIndex(std::int32_t cx, std::int32_t cy) const {
        return static_cast<std::size_t>(cy) * static_cast<std::size_t>(cells_x_) +
               static_cast<std::size_t>(cx);
    }
    /// The cell table in pages of kPageCells x kPageCells cells, a page only where some cell
    /// has a record (a 4097 x 4097 map has 16.8 M cells, a battle's records cluster).
    static constexpr std::int32_t kPageShift = 6;
    static constexpr std::int32_t kPageCells = 1 << kPageShift;
    std::size_t pageOf(std::int32_t cx, std::int32_t cy) const {
        return static_cast<std::size_t>(cy >> kPageShift) * static_cast<std::size_t>(pages_x_) +
               static_cast<std::size_t>(cx >> kPageShift);
    }
    static std::size_t pageSlot(std::int32_t cx, std::int32_t cy) {
        return static_cast<std::size_t>(
            ((cy & (kPageCells - 1)) << kPageShift) | (cx & (kPageCells - 1)));
    }
    void setRecordOf(std::int32_t cx, std::int32_t cy, std::int32_t r);
    bool needsRecord(const Terrain& t, std::int32_t cx, std::int32_t cy) const;
    CellRect aroundChange(CellRect cells) const;
    std::int32_t takeRecord(std::int32_t cx, std::int32_t cy);
    void dropRecord(std::int32_t r);
    void summarise(const Terrain& t, std::int32_t r);

    std::int32_t cells_x_ = 0;
    std::int32_t cells_y_ = 0;
    std::int32_t pages_x_ = 0;
    std::vector<std::vector<std::int32_t>> pages_; ///< empty: no record in the page
    std::vector<std::int32_t> page_records_;       ///< per page: its records (0 frees it)
    std::vector<Record> records_;
    std::vector<std::int32_t> free_records_;
    std::vector<std::int32_t> record_of_block_;
    std::vector<std::int32_t> free_;
};

/// The heights (fine units) of cell (cx, cy)'s 17 x 17 vertices, (k, l) at l * 17 + k: its
/// patch's grid (spline numerators rounded to 1/16 quantum) if it is a real cell with a patch,
/// else its base triangles, exact; zeros for a virtual cell past the padded grid. With a
/// `stride` of 2 or 4, only the vertices whose k and l are multiples of it (a block's coarser
/// grains; the others are left as they were), the same values at a fraction of the work.
void fillCellHeights(
    const Terrain& t,
    std::int32_t cx,
    std::int32_t cy,
    std::span<std::int64_t, kBlockVertices> out,
    std::int32_t stride = 1);

} // namespace terrain::roam
