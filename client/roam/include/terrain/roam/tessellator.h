#pragma once

// The client's view-dependent ROAM tessellation of a Terrain (lattice.h: the 4-8 mesh).
//
// Every diamond carries a nested error bound delta (metres) on the vertical distance between the
// true surface and its two triangles, built bottom-up as in ROAM (BoundsUpdate), and a box that
// holds everything its refinement can produce. Its priority, ViewMetric::screenError(box,
// delta), is an upper bound in pixels, monotone from child to parent, so "split exactly the
// diamonds whose priority exceeds tau" is a conforming mesh whose every triangle is within tau
// pixels of the true surface on screen. kSplitOnly builds that mesh top-down every frame (Tread
// Marks / Turner); kSplitMerge keeps last frame's mesh and moves it with a budget of splits and
// merges (SplitMerge), rebuilding top-down after a jump. Where the triangle cap binds, the
// threshold rises above tau (the mesh is the best one for its count) and
// FrameStats::error_bound_pixels reports it.
//
// Detail below the base grid exists only where the view refines it: a detail cell's centre is
// eager, with a conservative bound from its records; splitting it makes the cell's block, in
// grains (block_grains.h), from a bounded pool (BlockPool) that evicts what no diamond refers to.
// A split the cap or the pool refuses leaves the mesh conforming.
//
// This class is the facade: update() is the frame's passes (stale bounds, then a rebuild or
// split/merge, then the tiles' end of frame, the pool's sweep and trim), and the lattice walk
// that joins the parts (a split with the parents it forces, a merge, the candidates each
// offers, the blocks a split needs). The parts own their state, each with its header and tests
// (ARCHITECTURE.md draws them): DiamondSpace (per-id state and bounds), LatticeIds (lattice
// points to ids, the map's measures), BlockPool (grains and eviction), BoundsUpdate (bounds
// after an op), SplitMerge (the policy), TileEmitter (the tiles' lists and vertex arrays: what a
// renderer reads). Pure: no GL, no clocks, no I/O. Single-threaded, but for the stale bounds
// pass, which a caller's TaskRunner may spread (setTaskRunner).

#include <terrain/roam/block_grains.h>
#include <terrain/roam/block_pool.h>
#include <terrain/roam/bounds_update.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/diamond_id.h>
#include <terrain/roam/diamond_space.h>
#include <terrain/roam/frame_stats.h>
#include <terrain/roam/lattice.h>
#include <terrain/roam/lattice_ids.h>
#include <terrain/roam/move_census.h>
#include <terrain/roam/packed_bounds.h>
#include <terrain/roam/split_merge.h>
#include <terrain/roam/tessellator_options.h>
#include <terrain/roam/tile_emitter.h>
#include <terrain/roam/tile_mesh.h>
#include <terrain/roam/tile_vertex_arrays.h>
#include <terrain/roam/update_phases.h>
#include <terrain/terrain.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

namespace terrain::roam {

class Tessellator {
  public:
    Tessellator(const Terrain& terrain, const TessellatorOptions& options);
    /// Its parts refer to each other (the policy to the diamond space): not copied or moved.
    Tessellator(const Tessellator&) = delete;
    Tessellator& operator=(const Tessellator&) = delete;

    /// Re-tessellates for the camera and returns what the frame did.
    FrameStats update(const Camera& camera);

    /// The terrain changed under `cells` (one rectangle per op, from the replica's DirtySet), or
    /// everything when `all` (a snapshot, possibly of another world). Rebuilds blocks and bounds
    /// along the changed paths only; affected candidates are re-examined on the next update().
    void terrainChanged(std::span<const CellRect> cells, bool all);
    /// Reads `terrain` from now on (another object: a replica's copy, a world swapped whole),
    /// as terrainChanged({}, true) does: everything is re-read, the next update() rebuilds.
    /// `terrain` must outlive the tessellator or the next rebind.
    void rebind(const Terrain& terrain) {
        terrain_ = &terrain;
        terrainChanged({}, true);
    }

    /// The cells whose surface changed since takeChangedCells() (the rectangles told, merged per
    /// call), or all of them (a new world, or more rectangles than it keeps): what a reader that
    /// keeps the surface between frames (a vertex builder's cell grids) must read again.
    std::span<const CellRect> changedCells() const { return changed_cells_; }
    bool allCellsChanged() const { return all_cells_changed_; }
    void takeChangedCells() {
        changed_cells_.clear();
        all_cells_changed_ = false;
    }

    /// Whether the mesh over `cells` is done with every change told so far: no block whose
    /// window meets them waits for its bounds, and no split there waits for a budget (a
    /// waiting merge only keeps triangles the view no longer needs). A crater has converged
    /// once its cells are settled. O(cells + the splits waiting).
    bool settled(CellRect cells) const;

    void setTau(double tau_pixels);
    /// A new triangle cap, followed over the next frames (the threshold moves; no rebuild).
    void setMaxTriangles(std::int64_t max_triangles) { options_.max_triangles = max_triangles; }
    /// Short steps (a worker's): each update() ends at `deadline` (read through it; null: the
    /// budgets alone, one whole frame per update). Stale bounds take up to half the step, oldest
    /// first; then the splits, largest error first, and the merges (which only free triangles)
    /// with what is left, or first while the mesh nears its cap. What a step leaves waits: the
    /// blocks in the stale queue, the priced splits and merges in the policy's backlog (a step
    /// prices again only kStepBacklogPull of each kind), the candidates not yet priced due. The
    /// threshold follows the cap once per view, not per step. Not owned.
    void setStepDeadline(const StepDeadline* deadline);
    static constexpr std::size_t kStepBacklogPull = 512;
    /// The threshold the mesh is refined to: tau_pixels, or higher while the cap binds.
    double threshold() const { return policy_.threshold(); }
    /// Splits the diamond centred at `p`, forcing every ancestor it needs, whatever the metric
    /// says (tools, tests); the next update() merges it again if it is not needed. Returns false
    /// if there is no such diamond or the cap refuses it.
    bool splitAt(LatticePoint p, FrameStats& stats);
    const TessellatorOptions& options() const { return options_; }
    /// Told as each pass of update() begins (timing at the edge; null: nobody). Not owned.
    void setPhaseObserver(UpdatePhaseObserver* observer) { phases_ = observer; }
    /// The stale bounds pass runs on `runner` from now on (BoundsUpdate::setTaskRunner: the same
    /// state at any thread count; null: serially). Not owned. The split/merge policy, one heap
    /// over the map whose forced splits cross tiles, stays on the caller's thread.
    void setTaskRunner(TaskRunner* runner) { bounds_.setTaskRunner(runner); }
    /// Stale bounds passes spread over the runner since construction.
    std::int64_t parallelBoundsPasses() const { return bounds_.parallelPasses(); }

    // the tiles, as the renderer reads them (tile_emitter.h, tile_vertex_arrays.h)
    std::int32_t tileCount() const { return emitter_.tileCount(); }
    const TileMesh& tileMesh(std::int32_t tile) const { return emitter_.mesh(tile); }
    TileMesh& tileMesh(std::int32_t tile) { return emitter_.mesh(tile); }
    bool tileVisible(std::int32_t tile) const { return emitter_.visible(tile); }
    /// Bumped whenever the tile's vertex array (heights or blocks) changes.
    std::uint32_t tileVertexVersion(std::int32_t tile) const {
        return emitter_.vertices().version(tile);
    }
    std::int32_t tileVertexCount(std::int32_t tile) const {
        return emitter_.vertices().vertexCount(tile);
    }
    TileVertex tileVertex(std::int32_t tile, std::uint32_t index) const {
        return emitter_.tileVertex(tile, index);
    }
    /// Every vertex of the tile's array at once (out.size() == tileVertexCount(tile)): what the
    /// renderer reads when it loads a tile.
    void tileVertices(std::int32_t tile, std::span<TileVertex> out) const {
        emitter_.tileVertices(tile, out);
    }
    /// The vertices [first, first + out.size()) of the tile's array.
    void tileVertices(std::int32_t tile, std::uint32_t first, std::span<TileVertex> out) const {
        emitter_.tileVertices(tile, first, out);
    }
    /// What changed in the tile's vertex array since takeVertexChanges(tile), so that a renderer
    /// rebuilds only that: everything, or these ranges (TileVertexArrays says when each is
    /// marked; a grain that goes marks nothing: no index refers to its vertices any more).
    bool tileVerticesAllChanged(std::int32_t tile) const {
        return emitter_.vertices().allChanged(tile);
    }
    std::span<const VertexRange> tileVertexChanges(std::int32_t tile) const {
        return emitter_.vertices().changes(tile);
    }
    void takeVertexChanges(std::int32_t tile) { emitter_.vertices().take(tile); }
    static constexpr std::size_t kMaxVertexRanges = TileVertexArrays::kMaxRanges;
    /// Geomorphing: the height (metres) each vertex of the tile's mesh is drawn at for `view`,
    /// so that splits and merges slide instead of pop (TileEmitter::morphedHeights: within
    /// full_pixels = tau of the surface at every instant when refined to a fraction of tau).
    void morphedHeights(
        std::int32_t tile,
        const ViewMetric& view,
        double full_pixels,
        std::span<double> out) const {
        emitter_.morphedHeights(tile, view, policy_.threshold(), full_pixels, bounds_, out);
    }
    /// Every leaf triangle of the current mesh, emitted or not (tests: conformity).
    template <class Visit> void forEachLeaf(Visit&& visit) const {
        emitter_.forEachLeaf(std::forward<Visit>(visit));
    }

    std::int64_t triangleCount() const { return triangles_; }
    /// Detail blocks resident now.
    std::int32_t blockCount() const { return blocks_.count(); }
    /// Resident blocks whose bounds wait for a frame's budget since an op (may count a few
    /// evicted since).
    std::int64_t staleBlockCount() const { return static_cast<std::int64_t>(bounds_.staleCount()); }
    /// Resident chunks of each grain (grain 0: one per block).
    std::array<std::int32_t, kGrains> grainCounts() const;
    /// Resident blocks that cannot be evicted now (some diamond refers to them); O(pool).
    std::int32_t pinnedBlockCount() const;
    /// Detail cells (eager records), resident or not.
    std::int32_t detailCellCount() const { return blocks_.recordCount(); }
    /// Materialises every detail cell's block, ignoring the pool's limit (tests: compares the
    /// lazy bounds with bounds built for everything at once).
    void materialiseAll();
    /// Bytes of per-diamond state, records, blocks and index lists.
    std::size_t memoryBytes() const { return memory().total(); }
    TessellatorMemory memory() const;
    /// Grain chunks moved down to compact their arrays since construction (trimGrains).
    std::int64_t movedChunkCount() const { return pool_.movedCount(); }
    /// Diamonds split since construction that needed a block no cell had (must stay 0).
    std::int64_t missingBlockRefusals() const { return missing_block_refusals_; }

    /// Error bound (metres) of the diamond centred at `p`; -1 if there is none (tests).
    double deltaAt(LatticePoint p) const;
    /// Metres per lattice unit and per height fine unit.
    double metresPerLattice() const { return geo().metres_per_lattice; }
    double metresPerFineUnit() const { return geo().metres_per_fine; }

  private:
    /// Ids (diamond_id.h): grid vertices, then one centre per detail record (eager, below
    /// kPooled); pooled range g holds grain g's chunks, kGrainDiamonds[g] ids a chunk.
    static constexpr DiamondId kPooled = kPooledIds;
    static constexpr std::uint8_t kActive = DiamondSpace::kActive;
    static constexpr std::uint8_t kSplitCandidate = DiamondSpace::kSplitCandidate;
    static constexpr std::uint8_t kMergeCandidate = DiamondSpace::kMergeCandidate;
    static std::size_t idx(std::int64_t v) { return static_cast<std::size_t>(v); }

    using Bounds = DiamondBounds;
    void adoptSpec();
    const LatticeGeometry& geo() const { return ids_.geometry(); }
    bool insideMap(LatticePoint p) const { return geo().insideMap(p); }
    /// kNoDiamond for a point of a detail cell whose block is not resident.
    DiamondId idOf(LatticePoint p) const { return ids_.idOf(p); }
    /// idOf, materialising the cell's block if it has a record and none (kNoDiamond if the pool
    /// refuses); marks the block used this frame.
    DiamondId resolve(LatticePoint p);
    LatticePoint pointOf(DiamondId id) const { return ids_.pointOf(id); }
    static DiamondId grainId(int g, std::int32_t chunk, std::uint32_t slot) {
        return DiamondSpace::pooledId(g, chunk, slot);
    }
    std::uint8_t& state(DiamondId id) { return space_.state(id); }
    std::uint8_t state(DiamondId id) const { return space_.state(id); }
    /// Stored for the grid's and the blocks' diamonds (read here directly: pricing reads it per
    /// candidate); derived for a centre (bounds_).
    Bounds bounds(DiamondId id) const {
        return space_.isCentre(id) ? bounds_.bounds(id) : space_.storedBounds(id);
    }
    /// Marks the pooled id's chunk and block used in this epoch (never evicted in it).
    void markUsed(DiamondId id) {
        const int g = DiamondSpace::grainOfId(id);
        pool_.markUsed(g, DiamondSpace::chunkOfId(id, g), use_epoch_);
    }
    bool active(DiamondId id) const { return space_.active(id); }
    bool isCentre(DiamondId id) const { return space_.isCentre(id); }
    DiamondId centreId(std::int32_t record) const { return space_.centreId(record); }
    /// Sizes the diamond space and the heap's ids after the records or the pool's chunks grew.
    void resizeDiamondState();

    // the block pool (tessellator_pool.cpp)
    /// Gives `record` a resident block with its coarse grain (evicting one if the pool is full);
    /// -1 if every slot is in use.
    std::int32_t materialise(std::int32_t record);
    /// Gives `block` its grain `g` (1 or 2) with its bounds and heights.
    void materialiseGrain(std::int32_t block, int g);
    /// Before a top-down build at `threshold`: makes the blocks and grains it will need, known
    /// from the records and then from the grains just made, in BlockBounds passes (not one block
    /// at a time as the build meets them), while the pool has room.
    void prefetchBlocks(const ViewMetric& m, double threshold);
    /// During prefetchBlocks' bounds pass: makes the finer grains the build will need.
    struct PrefetchGrains;
    /// Split/merge frames make the blocks and grains their splits need with their bounds left
    /// for one pass at the end of each round of splits (boundBatched): nothing prices the new
    /// diamonds before it (the children a split offers are priced in the next round).
    bool batching_ = false;
    std::vector<std::pair<std::int32_t, unsigned>> batched_; ///< block, grains made
    void batch(std::int32_t block, unsigned grains);
    void boundBatched();
    bool evictOne();
    /// Releases blocks (or their finer grains) idle for options_.detail_block_idle_frames, a
    /// few slots per frame.
    void sweepIdleBlocks();
    /// Gives back the memory of free grain 1 and 2 chunks once they are a quarter of their
    /// arrays, compacting over a few frames: a battle's peak is not kept for the session.
    void trimGrains();
    /// What follows the pool's moves: the diamonds' state, the heap, the lists, the segments.
    struct PoolMover;
    void evict(std::int32_t block);
    void releaseGrain(std::int32_t block, int g);
    /// The triangle cap or the pool refused a split this frame.
    void refuse(bool pool);

    // priorities (bounds_ keeps the bounds)
    Box boxOf(const Diamond& d, const Bounds& b) const { return geo().boxOf(d, b); }
    double priority(const ViewMetric& m, const Diamond& d, DiamondId id) const;
    double priority(const ViewMetric& m, const Diamond& d, const Bounds& b) const;
    /// An upper bound on priority() for a diamond whose block is not resident, from its cells'
    /// records (no heights needed).
    double recordPriority(const ViewMetric& m, const Diamond& d) const;

    // mesh
    bool canActivate(const Diamond& d, DiamondId id) const;
    bool parentsActive(const Diamond& d) const;
    bool activate(const Diamond& d, DiamondId id, bool forced, FrameStats& stats);
    void deactivate(const Diamond& d, DiamondId id, FrameStats& stats);
    void deactivateSubtree(LatticePoint p, FrameStats& stats);
    bool hasActiveChild(const Diamond& d) const;
    /// Gives grain `g` of `block` a segment of its tile's vertex array (none for virtual cells).
    void attachGrain(std::int32_t block, int g);
    void detachGrain(std::int32_t block, int g);

    // frames
    void rebuildTopDown(const ViewMetric& m, FrameStats& stats);
    /// Splits best-first until `target` triangles; returns a bound on the error left.
    double refineBestFirst(const ViewMetric& m, std::int64_t target, FrameStats& stats);
    void refineTopDown(const ViewMetric& m, const Triangle& t, FrameStats& stats, bool& capped);
    void collectCandidates(const Triangle& t);
    /// What the split/merge policy reads of the mesh and does to it.
    struct PolicyMesh;
    /// This frame's split/merge work so far, in the units of TessellatorOptions::work_budget.
    std::int64_t workSpent(const FrameStats& stats) const {
        return stats.splits + stats.merges +
               TessellatorOptions::kMaterialiseWork *
                   (materialised_ + grains_materialised_ - made_at_frame_start_);
    }
    /// This frame's upload so far, in bytes (TessellatorOptions::upload_budget_bytes).
    std::int64_t uploadSpent() const { return uploadTotal() - upload_at_frame_start_; }
    std::int64_t uploadTotal() const { return emitter_.uploadBytes(); }
    /// Either budget spent: what is left waits for the next frame.
    /// `work_share` of the work budget, or `upload_share` of the upload budget, is spent.
    /// `time_share` of a short step, once `min_work` is done.
    bool budgetSpent(
        FrameStats& stats,
        double upload_share,
        double time_share = 1.0,
        std::int64_t min_work = kStepMinWork) const;
    /// In short steps, merges made before the splits (at a cap) may spend this share of a step,
    /// and stale bounds as much: neither takes the whole step from the splits the view needs.
    static constexpr double kStepMergeShare = 0.5;
    static constexpr double kStepBoundsShare = 0.5;
    /// Pricing stops at this share of a short step, so that the moves have the rest; and a
    /// step makes at least kStepMinWork of work, however short it is.
    static constexpr double kStepPricingShare = 0.5;
    static constexpr std::int64_t kStepMinWork = 16;
    const StepDeadline* deadline_ = nullptr; ///< short steps (setStepDeadline)
    Camera last_camera_{};
    static bool sameView(const Camera& a, const Camera& b) {
        return a.eye == b.eye && a.forward == b.forward && a.up == b.up &&
               a.fovy_radians == b.fovy_radians && a.viewport_width == b.viewport_width &&
               a.viewport_height == b.viewport_height && a.near_plane == b.near_plane;
    }
    /// Merges may spend three quarters of the upload budget: the splits the view needs get the
    /// rest even while a risen threshold has thousands of merges due. Measured in the battle at
    /// the triangle cap (client_battle_bench --async --lockstep, error bound p50 / p99 px):
    /// merges spending it all, hover 1.61 / 199, cross 1.37 / 108 (60-250 px for 10 frames at
    /// a time); half, 1.61 / 1.77 and 1.87 / 14.4 (deferred merges re-examined, twice the
    /// evaluations); three quarters, 1.61 / 1.77 and 1.39 / 3.83.
    static constexpr double kMergeUploadShare = 0.75;
    /// Re-offers a diamond whose bounds moved as the candidate its place in the mesh makes it.
    void refreshCandidate(DiamondId id);
    /// Replaces rectangles that overlap enough by their union (in place; order not kept).
    static void mergeOverlapping(std::vector<CellRect>& rects);
    void finishFrame(const ViewMetric& m, FrameStats& stats);
    /// Re-bounds up to `budget` stale blocks and re-offers the candidates whose bounds moved.
    std::int64_t drainStale(std::int64_t budget);

    const Terrain* terrain_;
    TessellatorOptions options_;
    WorldSpec spec_;
    DetailBlocks blocks_;

    // per diamond: eager ids, and pooled ones (by grain)
    DiamondSpace space_;

    // the block pool
    BlockPool pool_;
    std::vector<BlockPool::Release> releases_; ///< the idle sweep's
    std::vector<std::int32_t> made_;           ///< prefetchBlocks' and materialiseAll's blocks
    bool defer_bounds_ = false; ///< materialiseAll, prefetch: bounds in passes at the end
    std::vector<std::pair<double, std::int32_t>> prefetch_; ///< priority, record
    std::uint64_t frame_ = 0;
    /// Blocks used in the current epoch are never evicted (ids of them may be held on the
    /// stack); a frame starts one, and so does a best-first pass (nothing is held then).
    std::uint64_t use_epoch_ = 0;
    std::uint64_t last_pool_refusal_ = 0;               ///< frame
    std::uint64_t pool_full_epoch_ = ~std::uint64_t{0}; ///< epoch no slot could be freed in
    std::int64_t pool_refusals_ = 0;                    ///< since construction
    std::int64_t materialised_ = 0;
    std::int64_t grains_materialised_ = 0; ///< finer grains (1 and 2) made
    std::int64_t evicted_ = 0;
    /// materialised_ + grains_materialised_ when the frame began (its work budget counts them)
    std::int64_t made_at_frame_start_ = 0;
    std::int64_t upload_at_frame_start_ = 0; ///< their bytes when the frame began

    LatticeIds ids_{blocks_, pool_, space_}; ///< and the map's measures
    TileEmitter emitter_{blocks_, pool_, ids_};

    BoundsUpdate bounds_{blocks_, pool_, space_, emitter_.vertices()};

    // split/merge
    SplitMerge policy_; ///< the candidates, the threshold (after space_: it holds a reference)
    std::vector<CellRect> merged_;
    std::vector<std::int32_t> removing_;
    std::vector<std::int32_t> removed_;
    std::vector<std::int32_t> added_;
    double last_error_scale_ = 0.0;
    double last_near_ = 0.0;
    std::vector<std::pair<double, Triangle>> best_first_;
    bool bookkeeping_ = false; ///< slots and candidates follow each split (off while rebuilding)
    bool refused_by_cap_ = false;
    bool initialized_ = false;
    bool needs_rebuild_ = true;
    glm::dvec3 last_eye_{0.0};
    std::int64_t triangles_ = 0;
    std::int64_t missing_block_refusals_ = 0;
    UpdatePhaseObserver* phases_ = nullptr;
    std::unique_ptr<MoveCensus> census_;  ///< with options_.count_moves_by_place
    std::vector<CellRect> changed_cells_; ///< since takeChangedCells()
    bool all_cells_changed_ = true;
    static constexpr std::size_t kMaxChangedCells = 256; ///< rectangles kept, then "all"
    void countMove(const Diamond& d, DiamondId id, bool split, FrameStats& stats) {
        if (census_)
            census_->moved(d.centre, id, split, frame_, stats);
    }
    void enter(UpdatePhase phase) {
        if (phases_ != nullptr)
            phases_->enter(phase);
    }
};

} // namespace terrain::roam
