#pragma once

// The resident detail blocks an op left stale, oldest first. An op changes the surface of some
// cells; every block whose 3 x 3 window meets them has stale bounds (its diamonds' nested
// bounds read that window), and the blocks of the changed cells have stale heights too.
// Heights must be new before anything draws the block (or the mesh cracks against the grid);
// bounds may wait for the frames' budget (meanwhile the error bound is not exact there).
//
// Owns: the queue and a flag byte per block slot. Reads: DetailBlocks (which block a cell has).
// Does not touch: the blocks' heights or bounds (the tessellator redoes them for the blocks this
// hands out), the pool, the heap. Pure, single-threaded.

#include <terrain/roam/detail_blocks.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrain::roam {

class StaleBlocks {
  public:
    void clear();
    /// After an op changed the surface of `cells`: queues the blocks whose 3 x 3 window meets
    /// them, with stale heights for those of the changed cells and, past the real map's
    /// `real_cells_x` x `real_cells_y` cells, the padding cells (never drawn, but their blocks
    /// hold the real samples of the map's last line).
    void mark(
        CellRect cells,
        const DetailBlocks& blocks,
        std::int32_t real_cells_x,
        std::int32_t real_cells_y);
    /// The block went (evicted): its place in the queue is skipped.
    void forget(std::int32_t block) {
        if (static_cast<std::size_t>(block) < flags_.size())
            flags_[static_cast<std::size_t>(block)] = 0;
    }
    /// The queued blocks whose heights are stale, oldest first, into `out` (cleared first);
    /// their heights count as new from here (their bounds stay queued).
    void takeHeights(std::vector<std::int32_t>& out);
    /// Up to `budget` queued blocks, oldest first, into `out` (cleared first), and out of the
    /// queue: the caller redoes their bounds and heights. Forgotten ones are skipped.
    void take(std::int64_t budget, std::vector<std::int32_t>& out);
    /// Blocks queued (a few may have been forgotten since).
    std::size_t size() const { return queue_.size(); }
    bool stale(std::int32_t block) const {
        return static_cast<std::size_t>(block) < flags_.size() &&
               flags_[static_cast<std::size_t>(block)] != 0;
    }

  private:
    static constexpr std::uint8_t kBounds = 1;
    static constexpr std::uint8_t kHeights = 2;
    std::vector<std::int32_t> queue_;
    std::vector<std::uint8_t> flags_; ///< per block slot: kBounds | kHeights while queued
};

} // namespace terrain::roam
