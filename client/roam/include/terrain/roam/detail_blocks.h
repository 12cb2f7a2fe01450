#pragma once

// Which cells the tessellator may refine below the base grid, and the vertices it uses there.
//
// A cell with a detail patch is refined into the patch's 17 x 17 grid (evaluateGrid). Its
// neighbours must follow part of the way, or the finer triangles along the shared edge would
// leave T-junctions: a forced split crosses into the neighbour and needs vertices inside it. So
// every cell within kDetailHaloCells (Chebyshev distance) of a patch cell gets a block too, whose
// vertices lie exactly on the base triangles. Cells far from any patch have no block and are
// never refined below their two base triangles, which represent them exactly.
//
// A block is 17 x 17 vertex heights in fine units of 1/16 quantum: base triangles are exact at
// 1/16 of a cell in those units, and so is a patch on its straight borders (linear precision of
// the spline), so a patch and a halo neighbour agree bit for bit along their shared edge, and
// the halo's triangles lie exactly on the true surface. Block slots are reused after removal so
// that the ids of unchanged blocks, and the tessellation that refers to them, survive an op. Pure:
// no GL, no I/O.

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
    /// Blocks for every patch cell of `t` and its halo.
    void reset(const Terrain& t);

    /// After an op changed the surface of `cells`: re-derives which cells need blocks around them
    /// (patches appear and disappear) and recomputes the heights of every block in `cells`.
    /// Slots freed and taken are appended to `removed` / `added`.
    void update(
        const Terrain& t,
        CellRect cells,
        std::vector<std::int32_t>& removed,
        std::vector<std::int32_t>& added);

    /// The slots update() would free for the same change (the tessellator coarsens them first).
    void plan(const Terrain& t, CellRect cells, std::vector<std::int32_t>& removing) const;

    /// Cells covered, one virtual column and row past the padded grid included (see reset());
    /// a virtual cell's block holds no heights (zeros), only a place for diamond state.
    std::int32_t cellsX() const { return cells_x_; }
    std::int32_t cellsY() const { return cells_y_; }
    /// Block slot of a padded cell, or -1.
    std::int32_t blockOf(std::int32_t cx, std::int32_t cy) const {
        if (cx < 0 || cy < 0 || cx >= cells_x_ || cy >= cells_y_)
            return -1;
        return block_of_cell_
            [static_cast<std::size_t>(cy) * static_cast<std::size_t>(cells_x_) +
             static_cast<std::size_t>(cx)];
    }
    /// Number of slots (some may be free); slot ids are below this.
    std::int32_t capacity() const { return static_cast<std::int32_t>(cell_of_block_.size()); }
    std::int32_t count() const { return capacity() - static_cast<std::int32_t>(free_.size()); }
    bool inUse(std::int32_t block) const { return cell_of_block_[idx(block)].x >= 0; }
    /// The block's cell (x, y); (-1, -1) for a free slot.
    struct CellXY {
        std::int32_t x = -1;
        std::int32_t y = -1;
    };
    CellXY cellOf(std::int32_t block) const { return cell_of_block_[idx(block)]; }
    bool hasPatch(std::int32_t block) const { return has_patch_[idx(block)] != 0; }
    /// Height (fine units) of vertex (k, l), k along x, both 0..16.
    std::int64_t height(std::int32_t block, std::int32_t k, std::int32_t l) const {
        return heights_[idx(block) * kBlockVertices + static_cast<std::size_t>(l * kBlockSide + k)];
    }
    std::span<const std::int64_t> heights(std::int32_t block) const {
        return {heights_.data() + idx(block) * kBlockVertices, kBlockVertices};
    }
    /// Bound (fine units) on the distance between the true surface of the block's cell and any
    /// triangle of the finest level on its vertices (0 without a patch: they lie on it).
    float finestError(std::int32_t block) const { return finest_error_[idx(block)]; }

  private:
    static std::size_t idx(std::int32_t v) { return static_cast<std::size_t>(v); }
    bool needsBlock(const Terrain& t, std::int32_t cx, std::int32_t cy) const;
    CellRect aroundChange(CellRect cells) const;
    std::int32_t take(std::int32_t cx, std::int32_t cy);
    void release(std::int32_t block);
    void fill(const Terrain& t, std::int32_t block);

    std::int32_t cells_x_ = 0;
    std::int32_t cells_y_ = 0;
    std::vector<std::int32_t> block_of_cell_;
    std::vector<CellXY> cell_of_block_;
    std::vector<std::int32_t> free_;
    std::vector<std::int64_t> heights_;
    std::vector<float> finest_error_;
    std::vector<std::uint8_t> has_patch_;
};

} // namespace terrain::roam
