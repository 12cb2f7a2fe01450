#pragma once

// The client's view-dependent ROAM tessellation of a Terrain (see lattice.h for the mesh).
//
// Error bounds: every diamond carries a nested bound delta (metres) on the vertical distance
// between the true surface and its two triangles, built bottom-up as in ROAM: delta = |z(centre)
// - mean of the hypotenuse ends| + max over its child diamonds; the finest triangles of a patch
// cell start from the patch's grid_error_bound, those of other cells from 0 (they lie on the base
// triangles exactly, see detail_blocks.h). A box (xy reach of the diamond's descendants, z range
// widened by delta) bounds everything its refinement can produce. A diamond's priority is
// ViewMetric::screenError(box, delta): an upper bound in pixels, monotone from child to parent, so
// "split exactly the diamonds whose priority exceeds tau" is a conforming mesh whose every triangle
// is within tau pixels of the true surface on screen.
//
// Two ways to reach that mesh:
//  - kSplitOnly rebuilds it top-down every frame (Tread Marks / Turner), as baseline and fallback.
//  - kSplitMerge keeps last frame's mesh and a candidate set: split candidates (not split, both
//    parents split) and merge candidates (split, no split children). Each candidate is re-examined
//    only when the eye has travelled far enough for its priority to cross tau (priorities depend
//    on the eye's position, not its direction; culling is re-checked by a sweep when the view
//    turns), then merges (lowest first) and splits (highest first, forcing parents) run within a
//    per-frame work budget; what is left is due next frame. A jump of the eye rebuilds top-down.
// Splits that would exceed the triangle cap are refused (the mesh stays conforming). When the cap
// binds, the budget wins over tau: a rebuild refines best-first (coarser where the priority is
// lowest) and the largest priority left unsplit becomes the threshold; split/merge then refines
// to that threshold instead of tau, raising it a step when the cap refuses a split and lowering
// it towards tau when the mesh has room (followCap). The mesh is then always the one a top-down
// build at the threshold makes, which is the best mesh for its count, with no periodic rebuild;
// FrameStats::error_bound_pixels reports the threshold reached.
//
// Detail below the base grid is modelled only where the view refines it. Every detail cell's
// coarsest diamond (its centre, whose triangles are the cell's base triangles) is eager, with a
// conservative bound from the records of the 3 x 3 cells around it (DetailBlocks::cellError), so
// the grid's priorities stay true upper bounds without any heights below the grid. Splitting a
// centre materialises the cell's block, in grains (block_grains.h): the coarse grain first (the
// 5 x 5 vertices and the 14 diamonds of levels 13-15), the next one only when a split at a
// grain's finest level makes the finer diamonds candidates. A grain's nested bounds are exact
// (BlockBounds: from the full-resolution heights of the 3 x 3 cells around, whatever else is
// resident), clamped to nested caps that keep them under the centre's conservative bound. Blocks
// live in a bounded pool: a block no diamond refers to is evicted when the pool needs its slot
// (clock order, never one used in the current frame); a split that needs a block when every slot
// is in use is refused like the triangle cap. A grain no diamond refers to goes after the idle
// time.
//
// Output per tile: a TileMesh of indices into the tile's vertex array, which is the 65 x 65 base
// grid followed by one segment per resident grain of a block of the tile (tileVertex()).
// This class is a facade: the frame's passes (update()) and the lattice walk (splits with their
// forced parents, merges, emission into the tiles' lists). Its parts own their state, each with
// its header and tests (ARCHITECTURE.md draws them): DiamondSpace (per-id state and bounds),
// BlockPool (the blocks' grains and the rules that evict them), BoundsUpdate (the bounds along
// an op's paths and what it left stale), TileVertexArrays (the renderer's vertex layout),
// SplitMerge (the policy: candidates, threshold, budget order), with CandidateHeap, TileMesh,
// DetailBlocks, StaleBlocks and BlockBounds below them.
// Pure: no GL, no clocks, no I/O. Single-threaded.

#include <terrain/roam/block_grains.h>
#include <terrain/roam/block_pool.h>
#include <terrain/roam/bounds_update.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/diamond_id.h>
#include <terrain/roam/diamond_space.h>
#include <terrain/roam/frame_stats.h>
#include <terrain/roam/lattice.h>
#include <terrain/roam/packed_bounds.h>
#include <terrain/roam/split_merge.h>
#include <terrain/roam/tessellator_options.h>
#include <terrain/roam/tile_mesh.h>
#include <terrain/roam/tile_vertex_arrays.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <span>
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

    void setTau(double tau_pixels);
    /// A new triangle cap, followed over the next frames (the threshold moves; no rebuild).
    void setMaxTriangles(std::int64_t max_triangles) { options_.max_triangles = max_triangles; }
    /// The threshold the mesh is refined to: tau_pixels, or higher while the cap binds.
    double threshold() const { return policy_.threshold(); }
    /// Splits the diamond centred at `p`, forcing every ancestor it needs, whatever the metric
    /// says (tools, tests); the next update() merges it again if it is not needed. Returns false
    /// if there is no such diamond or the cap refuses it.
    bool splitAt(LatticePoint p, FrameStats& stats);
    const TessellatorOptions& options() const { return options_; }

    std::int32_t tileCount() const { return static_cast<std::int32_t>(tiles_.size()); }
    const TileMesh& tileMesh(std::int32_t tile) const { return tiles_[idx(tile)]; }
    TileMesh& tileMesh(std::int32_t tile) { return tiles_[idx(tile)]; }
    bool tileVisible(std::int32_t tile) const { return tile_visible_[idx(tile)] != 0; }
    /// Bumped whenever the tile's vertex array (heights or blocks) changes.
    std::uint32_t tileVertexVersion(std::int32_t tile) const { return vertices_.version(tile); }
    std::int32_t tileVertexCount(std::int32_t tile) const { return vertices_.vertexCount(tile); }
    TileVertex tileVertex(std::int32_t tile, std::uint32_t index) const;
    /// Every vertex of the tile's array at once (out.size() == tileVertexCount(tile)): what the
    /// renderer reads when it loads a tile.
    void tileVertices(std::int32_t tile, std::span<TileVertex> out) const;
    /// The vertices [first, first + out.size()) of the tile's array.
    void tileVertices(std::int32_t tile, std::uint32_t first, std::span<TileVertex> out) const;
    /// What changed in the tile's vertex array since takeVertexChanges(tile), so that a renderer
    /// rebuilds only that: everything (a reset, or more ranges than kMaxVertexRanges), or these
    /// ranges, in the order marked (they may overlap). A vertex is marked when its grain joins
    /// the array (or takes a hole), when its height moves, and when the surface within a cell
    /// of it changes (its normal: an op's cells widened by one). A grain that goes marks
    /// nothing: no index refers to its vertices any more.
    bool tileVerticesAllChanged(std::int32_t tile) const { return vertices_.allChanged(tile); }
    std::span<const VertexRange> tileVertexChanges(std::int32_t tile) const {
        return vertices_.changes(tile);
    }
    void takeVertexChanges(std::int32_t tile) { vertices_.take(tile); }
    static constexpr std::size_t kMaxVertexRanges = TileVertexArrays::kMaxRanges;

    /// Geomorphing: the height (metres) each vertex of the tile's mesh is drawn at for `view`,
    /// so that splits and merges slide instead of pop; vertices the mesh does not use are left
    /// as they are in `out` (size tileVertexCount(tile)). A split diamond's centre v, with
    /// hypotenuse ends a and b, is drawn at
    ///     drawn(v) = (drawn(a) + drawn(b)) / 2 + s * (z(v) - (z(a) + z(b)) / 2),
    ///     s = clamp((P - threshold()) / (full_pixels - threshold()), 0, 1),
    /// P its priority ignoring the frustum (so a turn of the view moves nothing). A diamond is
    /// split when P passes threshold(), where s = 0: the split adds a vertex on the drawn edge
    /// and changes nothing drawn; a merge below it likewise. Every vertex reaches its height
    /// once P >= full_pixels. Refine to threshold() = fraction * tau and pass full_pixels = tau:
    /// the drawn surface is within tau at every instant, because drawn - z at a point p is a
    /// sum over the split diamonds D above p (each nested in the last) of (1 - s_D) times D's
    /// own centre offset, and D's delta holds its offset plus its children's delta. Where the
    /// coarsest D with s_D < 1 exists, the error at p is within its delta, i.e. under its
    /// P < full_pixels; where none does, within the leaf's delta, under threshold(). The same
    /// arithmetic on the same vertices in every tile: no cracks. Costs a walk of the tile's
    /// split diamonds, one priority each: O(mesh) per frame, not O(change) as split/merge.
    void morphedHeights(
        std::int32_t tile, const ViewMetric& view, double full_pixels, std::span<double> out) const;

    /// Every leaf triangle of the current mesh, emitted or not (tests: conformity).
    template <class Visit> void forEachLeaf(Visit&& visit) const;

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
    double metresPerLattice() const { return metres_per_lattice_; }
    double metresPerFineUnit() const { return metres_per_fine_; }

  private:
    /// Ids (diamond_id.h): grid vertices, then one centre per detail record (eager, below
    /// kPooled); pooled range g holds grain g's chunks, kGrainDiamonds[g] ids a chunk.
    static constexpr DiamondId kPooled = kPooledIds;
    static constexpr std::uint8_t kActive = DiamondSpace::kActive;
    static constexpr std::uint8_t kSplitCandidate = DiamondSpace::kSplitCandidate;
    static constexpr std::uint8_t kMergeCandidate = DiamondSpace::kMergeCandidate;
    static constexpr std::uint8_t kWatched = DiamondSpace::kWatched;
    static std::size_t idx(std::int64_t v) { return static_cast<std::size_t>(v); }

    using Bounds = DiamondBounds;
    void adoptSpec();
    /// The vertices whose height or normal an op over `cells` may have changed: the base grid
    /// and the blocks within a cell of them.
    void markChangedSurface(CellRect cells);
    bool insideMap(LatticePoint p) const {
        return p.x >= 0 && p.y >= 0 && p.x <= max_x_ && p.y <= max_y_;
    }
    /// kNoDiamond for a point of a detail cell whose block is not resident.
    DiamondId idOf(LatticePoint p) const;
    /// idOf, materialising the cell's block if it has a record and none (kNoDiamond if the pool
    /// refuses); marks the block used this frame.
    DiamondId resolve(LatticePoint p);
    LatticePoint pointOf(DiamondId id) const;
    static int grainOfId(DiamondId id) { return DiamondSpace::grainOfId(id); }
    /// The block a pooled id belongs to.
    std::int32_t blockOfId(DiamondId id) const {
        const int g = grainOfId(id);
        return pool_.blockOf(g, DiamondSpace::chunkOfId(id, g));
    }
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
        const int g = grainOfId(id);
        pool_.markUsed(g, DiamondSpace::chunkOfId(id, g), use_epoch_);
    }
    bool active(DiamondId id) const { return space_.active(id); }
    bool isCentre(DiamondId id) const { return space_.isCentre(id); }
    DiamondId centreId(std::int32_t record) const { return space_.centreId(record); }
    /// The id of diamond `local` (l * 16 + k) of `block`, or kNoDiamond if its grain is not
    /// resident.
    DiamondId pooledId(std::int32_t block, std::uint32_t local) const;
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
    Box boxOf(const Diamond& d, const Bounds& b) const;
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
    std::int32_t tileOf(const Triangle& t) const;
    bool emitted(const Triangle& t) const;
    std::uint32_t tileKey(const Triangle& t, std::int32_t tile) const;
    TileMesh::Indices indicesOf(const Triangle& t, std::int32_t tile) const;
    /// Index in the tile's vertex array of `v`, a vertex of triangle `t` of the tile.
    std::uint32_t vertexIndex(LatticePoint v, const Triangle& t, std::int32_t tile) const;
    struct MeshVertex {
        std::uint32_t index = 0;
        std::int64_t height = 0; ///< fine units
    };
    /// vertexIndex, and the vertex's height.
    MeshVertex vertexAt(LatticePoint v, const Triangle& t, std::int32_t tile) const;
    /// morphedHeights' walk below triangle t (vertex indices apex, left, right).
    struct MorphWalk;
    /// Drawn and true heights (metres) of a triangle's apex, left and right.
    using Corners = std::array<double, 3>;
    void
    morphBelow(MorphWalk& walk, const Triangle& t, const Corners& drawn, const Corners& z) const;
    void splitTriangles(const Diamond& d, bool split, bool forced);
    std::int64_t splitGain(const Diamond& d) const;
    Diamond tileRoot(std::int32_t tile) const;
    void emitTile(std::int32_t tile);
    void emitTriangle(const Triangle& t, std::int32_t tile, TileMesh& mesh);
    std::int32_t tileOfCell(DetailBlocks::CellXY c) const; ///< -1 for virtual cells
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
    std::int64_t uploadTotal() const {
        return upload_pages_ * TileMesh::kSlotsPerPage * TileMesh::kIndexBytesPerTriangle +
               upload_vertices_ * TessellatorOptions::kUploadBytesPerVertex;
    }
    /// Either budget spent: what is left waits for the next frame.
    bool budgetSpent(FrameStats& stats) const;
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
    double metres_per_lattice_ = 0.0;
    double metres_per_fine_ = 0.0;
    std::int32_t grid_w_ = 0;
    std::int32_t grid_h_ = 0;
    std::int32_t max_x_ = 0; ///< lattice extent of the padded map
    std::int32_t max_y_ = 0;
    std::int32_t real_x_ = 0; ///< lattice extent of the real map
    std::int32_t real_y_ = 0;
    std::uint32_t grid_count_ = 0;
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
    std::int64_t upload_pages_ = 0;          ///< index pages first written by split/merge, all told
    std::int64_t upload_vertices_ = 0;       ///< grain vertices added to tiles' arrays, all told
    std::int64_t upload_at_frame_start_ = 0; ///< their bytes when the frame began

    // per tile
    std::vector<TileMesh> tiles_;
    std::vector<std::uint8_t> tile_visible_;
    std::vector<std::uint64_t> tile_snug_; ///< per tile: the frame its mesh last had no slack
    TileVertexArrays vertices_;

    BoundsUpdate bounds_{blocks_, pool_, space_, vertices_};

    // split/merge
    SplitMerge policy_; ///< the candidates, the threshold (after space_: it holds a reference)
    std::vector<CellRect> merged_;
    std::vector<std::int32_t> removing_;
    std::vector<std::int32_t> removed_;
    std::vector<std::int32_t> added_;
    std::uint64_t written_before_ = 0;
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
    /// morphedHeights: per vertex of the tile, the call that last wrote it
    mutable std::vector<std::uint32_t> morph_stamp_;
    mutable std::uint32_t morph_call_ = 0;
};

template <class Visit> void Tessellator::forEachLeaf(Visit&& visit) const {
    std::vector<Triangle> stack;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const std::int32_t tx = tile % spec_.tilesX();
        const std::int32_t ty = tile / spec_.tilesX();
        const Diamond root = diamondAt(
            {tx * kLatticePerTile + kLatticePerTile / 2,
             ty * kLatticePerTile + kLatticePerTile / 2});
        for (const LatticePoint a : apexes(root))
            stack.push_back(triangleOf(root, a));
        while (!stack.empty()) {
            const Triangle t = stack.back();
            stack.pop_back();
            if (t.level < kFinestTriangleLevel && active(idOf(splitPoint(t)))) {
                const auto halves = splitTriangle(t);
                stack.push_back(halves[0]);
                stack.push_back(halves[1]);
            } else {
                visit(t, tile, emitted(t));
            }
        }
    }
}

} // namespace terrain::roam
