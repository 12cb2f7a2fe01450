#pragma once

// Where a tessellator's splits and merges land (benchmarks: the crater's own work against the
// rest): whether a move's diamond lies in cells an op changed within the last kRecentFrames
// updates (the footprints of recent craters, one cell of margin), and whether it undoes a move
// of the same diamond made within about as many updates (a split merged again, or the reverse).
//
// Owns: a table of the update in which each 2 x 2-cell square last changed, and the moves of
// the current and the last window of kRecentFrames updates, in two flat hash tables (a move
// undoes one found in either: made within one to two windows). Opt-in (TessellatorOptions::
// count_moves_by_place): about 1 MB per million cells and 8 MB of tables; a lookup per move.
// Pure, single-threaded.

#include <terrain/roam/diamond_id.h>
#include <terrain/roam/frame_stats.h>
#include <terrain/roam/lattice.h>
#include <terrain/terrain.h>

#include <array>
#include <cstdint>
#include <vector>

namespace terrain::roam {

class MoveCensus {
  public:
    /// A move counts as the crater's own within this many updates of its op, and as undone
    /// within one to two windows of this many.
    static constexpr std::uint64_t kRecentFrames = 60;

    /// A world of `cells_x` x `cells_y` cells (the padded lattice's); nothing changed yet.
    void reset(std::int32_t cells_x, std::int32_t cells_y);
    /// An op changed `cells` before update `frame`.
    void changed(CellRect cells, std::uint64_t frame);
    /// Diamond `id`, centred at `centre`, was split (or merged) in update `frame`.
    void
    moved(LatticePoint centre, DiamondId id, bool split, std::uint64_t frame, FrameStats& stats);

  private:
    /// A window's moves: id -> the last one's direction, open addressing (kNoDiamond: empty).
    struct Window {
        std::vector<std::uint32_t> ids;
        std::vector<std::uint8_t> splits;
        std::size_t used = 0;
        void clear();
        /// The slot holding `id`, or the empty one where it would go; ids.size() when full.
        std::size_t find(DiamondId id) const;
    };
    static constexpr std::size_t kWindowSlots = std::size_t{1} << 19;

    std::int32_t squares_x_ = 0;
    std::int32_t squares_y_ = 0;
    std::vector<std::uint64_t> changed_at_; ///< per 2 x 2-cell square: the update, 0 never
    std::array<Window, 2> windows_;         ///< the current one's index is window_ % 2
    std::uint64_t window_ = 0;              ///< frame / kRecentFrames of the current window
};

} // namespace terrain::roam
