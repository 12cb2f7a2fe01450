#pragma once

// The diamonds' nested error bounds (tessellator.h explains them) as the surface changes, and
// the resident blocks' heights that go with them: which blocks an op left stale, the passes
// that recompute bounds along the op's paths, and the ids whose bounds moved (the candidates
// the policy must look at again).
//
// Owns: the BlockBounds kernel and its passes' scratch (cells, blocks, a cell's heights), the
// last single-block pass (kept for the block's next grain until the terrain changes), the
// stale-block queue (StaleBlocks), the centres' bounds before an op, every centre's bounds
// while a whole-map pass runs, and the ids whose bounds moved in the last pass (moved()).
// Reads: the terrain, the detail records (DetailBlocks), which grains each block has
// (BlockPool's chunks).
// Writes: the stored bounds of the grid's and the blocks' diamonds (DiamondSpace), the blocks'
// heights (BlockPool), and the version and changed ranges of a tile's vertex array whose
// heights moved (TileVertexArrays).
// May not touch: the diamonds' states, the candidates (the tessellator re-offers moved()),
// the tiles' index lists, which blocks are resident (the pool's rules decide that).
// Pure, single-threaded.

#include <terrain/roam/block_bounds.h>
#include <terrain/roam/block_pool.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/diamond_id.h>
#include <terrain/roam/diamond_space.h>
#include <terrain/roam/lattice.h>
#include <terrain/roam/stale_blocks.h>
#include <terrain/roam/tile_vertex_arrays.h>
#include <terrain/task_runner.h>
#include <terrain/terrain.h>
#include <terrain/world_spec.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace terrain::roam {

class BoundsUpdate {
  public:
    /// The parts it reads and writes; they outlive it (the tessellator owns them all).
    BoundsUpdate(
        const DetailBlocks& blocks,
        BlockPool& pool,
        DiamondSpace& space,
        TileVertexArrays& vertices);
    BoundsUpdate(const BoundsUpdate&) = delete;
    BoundsUpdate& operator=(const BoundsUpdate&) = delete;

    /// The map's measures, as the tessellator derives them from its spec.
    struct Geometry {
        WorldSpec spec;
        double metres_per_fine = 0.0;
        std::int32_t max_x = 0; ///< lattice extent of the padded map
        std::int32_t max_y = 0;
    };
    /// Reads `terrain` (and its spec's measures) from now on; what was cached is forgotten and
    /// no block is stale.
    void reset(const Terrain& terrain, const Geometry& geometry);

    /// A diamond's bounds: stored for the grid's and the blocks' diamonds; a centre's come from
    /// the records of its 3 x 3 cells (cached while a whole-map pass runs).
    DiamondBounds bounds(DiamondId id) const {
        if (space_.isCentre(id)) {
            const std::int32_t record = space_.recordOfCentre(id);
            return centre_cache_.empty() ? centreBounds(record)
                                         : centre_cache_[static_cast<std::size_t>(record)];
        }
        return space_.storedBounds(id);
    }
    /// A centre's bounds: the largest cellError of its 3 x 3 cells, and their vertex range
    /// widened by it. Packed and unpacked like every stored bound (BoundsCodec::outward), so
    /// that the centre's children, stored packed, stay within it. Derived, not stored: records
    /// are many.
    DiamondBounds centreBounds(std::int32_t record) const;
    /// The same for any cell's 3 x 3 window (a diamond whose block is not resident); zlo > zhi
    /// if no cell of the window has a surface.
    DiamondBounds windowBounds(std::int32_t cx, std::int32_t cy) const;

    // ---- an op -----------------------------------------------------------------------------
    /// The terrain changed (before anything else is told): the kept single-block pass is stale.
    void surfaceChanged() { bounded_cell_ = {}; }
    /// Before the records of `cells` change: the bounds of the centres they can move (two cells
    /// around), so that recompute() reports only those that moved.
    void noteCentres(CellRect cells);
    /// After the records changed: the resident blocks whose bounds (and, in `cells`, heights)
    /// are stale now.
    void markStale(CellRect cells);
    /// The grid's and the noted centres' bounds after the surface of `cells` changed, finest
    /// level first; moved() lists the ids whose bounds changed. The resident blocks wait in the
    /// stale queue (drainStale()).
    void recomputeAround(CellRect cells);
    /// Everything after the world was replaced: every resident block, every centre, the grid.
    void recomputeAll();
    /// Bounds and heights of up to `budget` stale blocks, oldest first (moved() lists the ids
    /// whose bounds changed); returns how many.
    std::int64_t drainStale(std::int64_t budget);
    /// Heights of the blocks still stale (their bounds wait): before anything draws them.
    void freshenHeights();
    /// The block went: its place in the stale queue is skipped.
    void forget(std::int32_t block) { stale_.forget(block); }
    /// Blocks waiting for their bounds (a few may have been forgotten since).
    std::size_t staleCount() const { return stale_.size(); }
    /// Whether `block` waits for its bounds.
    bool blockStale(std::int32_t block) const { return stale_.stale(block); }
    /// The ids whose bounds the last recomputeAround() or drainStale() moved.
    std::span<const DiamondId> moved() const { return moved_; }

    // ---- blocks as they are made -----------------------------------------------------------
    /// Bounds and heights of `block`'s grains in `grain_mask` (bit g), from a pass over its cell
    /// alone, reused for the block's next grain while the terrain has not changed.
    void boundGrains(std::int32_t block, unsigned grain_mask);
    /// Called after each block of a boundBlocks() pass, while the pass's results are readable.
    class PassListener {
      public:
        virtual void bounded(std::size_t i, std::int32_t block) = 0;

      protected:
        ~PassListener() = default;
    };
    /// Bounds and heights of the grains `requests` name (a block and a mask of its grains, each
    /// block once), in passes over squares of cells as boundBlocks makes them: blocks and grains
    /// a frame's splits made, bounded together rather than one block's pass at a time (a block
    /// alone pays for the neighbours its bounds read: about four times the work).
    void boundGrainsOf(std::span<const std::pair<std::int32_t, unsigned>> requests);
    /// Bounds and heights of every resident grain of `blocks`, in BlockBounds passes over
    /// squares of cells (a pass's scratch spans its cells' box, so scattered blocks stay cheap).
    void boundBlocks(std::span<const std::int32_t> blocks, PassListener* listener = nullptr);
    /// During PassListener::bounded(): the pass's bounds of diamond `local` (l * 16 + k) of its
    /// i-th block, and storing them into a grain made since.
    const DiamondBounds& passBounds(std::size_t i, std::uint32_t local) const {
        return kernel_.bounds(i, local);
    }
    void storeGrains(std::size_t i, std::int32_t block, unsigned grain_mask);

    /// Bytes of the kernel's scratch and the centres' cache.
    std::size_t memoryBytes() const;

    /// drainStale's passes run on `runner` from now on (not owned; null: serially): squares of
    /// cells in groups, one kernel per group; each block's bounds and heights are its square's
    /// pass either way, the ids moved and the tiles' vertex marks are listed in the serial
    /// order, so the state after is the same at any thread count.
    void setTaskRunner(TaskRunner* runner) { runner_ = runner; }
    /// drainStale passes spread over the runner so far.
    std::int64_t parallelPasses() const { return parallel_passes_; }

  private:
    /// What storing a pass writes besides each block's own state, per thread of a pass.
    struct VertexMark {
        std::int32_t tile = 0;
        std::uint32_t begin = 0;
        std::uint32_t end = 0; ///< == begin: the version bumped, nothing marked
    };
    struct PassScratch {
        BlockBounds kernel;
        std::array<std::int64_t, kBlockVertices> heights{};
        std::vector<DetailBlocks::CellXY> cells;
        std::vector<DiamondId> moved;
        std::vector<VertexMark> marks; ///< for the owner's thread to make, in order
    };
    /// Stores `kernel`'s i-th block (its heights through `heights`): the ids whose bounds moved
    /// into `moved` (if given), the tiles' vertex marks made at once or listed in `marks`.
    void storePassFrom(
        const BlockBounds& kernel,
        std::array<std::int64_t, kBlockVertices>& heights,
        std::size_t i,
        std::int32_t block,
        unsigned grain_mask,
        std::vector<DiamondId>* moved,
        std::vector<VertexMark>* marks);
    /// `blocks` into pass_blocks_, sorted by square of cells (then id), and square_ends_.
    void sortIntoSquares(std::span<const std::int32_t> blocks);
    /// boundGrainsOf's masks by block (0: every resident grain, as boundBlocks).
    std::vector<unsigned> grain_masks_;
    std::vector<std::int32_t> requested_; ///< boundGrainsOf's blocks
    /// The end (a square index, at most `last`) of a kernel pass starting at square `first`:
    /// the squares after it while their bounding box stays within kPassSquares a side. A pass
    /// over neighbouring squares computes the ring of cells between them once, not once per
    /// square; its blocks are stored in the squares' order all the same.
    std::size_t passEnd(std::size_t first, std::size_t last) const;
    /// The grains of `block` resident in the pool, a bit each.
    unsigned residentGrains(std::int32_t block) const;
    /// The blocks of squares [first, end) in one kernel pass, stored in order.
    void boundSquares(
        std::size_t first,
        std::size_t end,
        bool collect,
        BlockGeometry geometry,
        PassListener* listener);
    /// Stores `heights` into `block`'s resident grains in the mask; the tiles' vertex marks are
    /// made at once, or listed in `marks`.
    void storeHeightsFrom(
        const std::array<std::int64_t, kBlockVertices>& heights,
        std::int32_t block,
        unsigned grain_mask,
        std::vector<VertexMark>* marks);
    void boundBlocksParallel(std::span<const std::int32_t> blocks);

    /// The largest cellCap and the vertex range (fine units) of the 3 x 3 cells around a cell,
    /// those of the padded grid: everything a diamond of that cell can refine into.
    struct WindowBound {
        float cap = 0.0f;
        double lo = std::numeric_limits<double>::infinity();
        double hi = -std::numeric_limits<double>::infinity();
    };
    WindowBound windowBound(std::int32_t cx, std::int32_t cy) const;
    /// Conservative bound (metres) of a detail cell (0 for a cell without a record).
    float cellCap(std::int32_t cx, std::int32_t cy) const;
    bool insideMap(LatticePoint p) const {
        return p.x >= 0 && p.y >= 0 && p.x <= max_x_ && p.y <= max_y_;
    }
    std::int64_t heightAt(LatticePoint p) const; ///< a grid vertex's, fine units
    /// The id of a grid vertex or a cell's centre (kNoDiamond for a cell without a record).
    DiamondId eagerId(LatticePoint p) const;
    /// A grid diamond's bounds from its vertices and children; whether they changed.
    bool computeGridBounds(const Diamond& d, DiamondId id);
    double childBounds(LatticePoint c, double& zlo, double& zhi) const;
    /// The grid's diamonds whose subtree reaches the lattice box [x0, x1] x [y0, y1], finest
    /// level first (with `collect`, those whose bounds moved to moved_).
    void
    recomputeGrid(std::int32_t x0, std::int32_t y0, std::int32_t x1, std::int32_t y1, bool collect);
    /// storeGrains, listing the ids whose bounds moved in moved_ if `collect`.
    void storePass(std::size_t i, std::int32_t block, unsigned grain_mask, bool collect);
    /// Stores heights_ (a cell's 17 x 17) into `block`'s resident grains in the mask.
    void storeHeights(std::int32_t block, unsigned grain_mask);
    void boundBlocks(std::span<const std::int32_t> blocks, bool collect, PassListener* listener);
    std::int32_t tileOfCell(DetailBlocks::CellXY c) const;

    const DetailBlocks& blocks_;
    BlockPool& pool_;
    DiamondSpace& space_;
    TileVertexArrays& vertices_;
    const Terrain* terrain_ = nullptr;
    WorldSpec spec_;
    double metres_per_fine_ = 0.0;
    std::int32_t grid_w_ = 0;
    std::int32_t grid_h_ = 0;
    std::int32_t max_x_ = 0;
    std::int32_t max_y_ = 0;

    BlockBounds kernel_;
    DetailBlocks::CellXY bounded_cell_{}; ///< the cell kernel_ last computed alone, if any
    StaleBlocks stale_;
    std::vector<DiamondId> moved_;
    std::vector<DiamondBounds> centre_cache_;  ///< every centre's, during recomputeAll()
    std::vector<DiamondBounds> centre_before_; ///< noteCentres' (delta -1: no record)
    CellRect centre_rect_{};
    std::vector<std::int32_t> pass_;        ///< drainStale's and recomputeAll's blocks
    std::vector<std::int32_t> heights_due_; ///< freshenHeights'
    std::vector<DetailBlocks::CellXY> pass_cells_;
    std::vector<std::int32_t> pass_blocks_;
    std::array<std::int64_t, kBlockVertices> heights_{};
    TaskRunner* runner_ = nullptr;
    std::int64_t parallel_passes_ = 0;
    std::vector<PassScratch> scratch_;                   ///< per group of a parallel pass
    std::vector<std::size_t> square_ends_;               ///< pass_blocks_' squares, each's end
    std::vector<std::array<std::int32_t, 2>> square_at_; ///< each square's (x, y), in squares
    std::vector<std::size_t> group_ends_;                ///< in squares
};

} // namespace terrain::roam
