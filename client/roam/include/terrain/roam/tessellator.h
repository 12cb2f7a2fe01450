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
// Output per tile: a TileMesh of indices into the tile's vertex array, which is the 65 x 65 base
// grid followed by one 17 x 17 block per detail cell of the tile (tileVertex()).
// Pure: no GL, no clocks, no I/O. Single-threaded.

#include <terrain/roam/camera.h>
#include <terrain/roam/candidate_heap.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/lattice.h>
#include <terrain/roam/tile_mesh.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <span>
#include <vector>

namespace terrain::roam {

enum class TessellationMode : std::uint8_t { kSplitMerge, kSplitOnly };

struct TessellatorOptions {
    double tau_pixels = 1.0;
    TessellationMode mode = TessellationMode::kSplitMerge;
    /// Triangle cap (the pool): splits beyond it are refused.
    std::int64_t max_triangles = 4'000'000;
    /// Splits + merges per frame in kSplitMerge; the rest waits for the next frame.
    std::int64_t work_budget = 1'000'000;
    /// An eye jump longer than this rebuilds top-down; 0 means 8 tiles.
    double teleport_metres = 0.0;
    /// Merge candidates' culling is re-checked as the view turns, about all of them per this
    /// much turning (sampled in a low-discrepancy order, so not exactly each one), and every one
    /// on a turn of this much in one frame. Out-of-view regions merge within about this turn.
    double cull_sweep_degrees = 4.0;
};

struct FrameStats {
    std::int64_t splits = 0;
    std::int64_t forced_splits = 0; ///< of which forced by a finer split
    std::int64_t merges = 0;
    std::int64_t evaluations = 0; ///< priorities computed
    std::int64_t refused_by_cap = 0;
    std::int64_t triangles = 0;         ///< emitted, all tiles
    std::int64_t visible_triangles = 0; ///< in tiles that intersect the frustum
    std::int64_t index_bytes_written = 0;
    std::int64_t index_bytes_total = 0; ///< size of every tile's index list
    /// The screen error (pixels) every triangle of the mesh is within: tau, or the higher
    /// threshold the triangle cap forced, or more while splits the frame wanted wait (cap or
    /// work budget). Exact only when !budget_exhausted (waiting candidates were not all priced).
    double error_bound_pixels = 0.0;
    bool rebuilt = false;
    bool budget_exhausted = false;
};

/// A tile's vertex array: the (kTileCells + 1)^2 base grid first, row by row, then one
/// kBlockSide^2 block per detail cell, in the order the blocks came; a block that goes leaves a
/// hole (unreferenced vertices, standing in for the tile's first vertex) for the next one.
inline constexpr std::int32_t kTileBaseVertices = (kTileCells + 1) * (kTileCells + 1);

/// A tile vertex: lattice position (1/16 cell) and height in fine units (1/16 quantum).
struct TileVertex {
    LatticePoint position;
    std::int64_t height = 0;
};

class Tessellator {
  public:
    Tessellator(const Terrain& terrain, const TessellatorOptions& options);

    /// Re-tessellates for the camera and returns what the frame did.
    FrameStats update(const Camera& camera);

    /// The terrain changed under `cells` (one rectangle per op, from the replica's DirtySet), or
    /// everything when `all` (a snapshot, possibly of another world: the terrain object must be
    /// the same one). Rebuilds blocks and bounds along the changed paths only; affected
    /// candidates are re-examined on the next update().
    void terrainChanged(std::span<const CellRect> cells, bool all);

    void setTau(double tau_pixels);
    /// A new triangle cap, followed over the next frames (the threshold moves; no rebuild).
    void setMaxTriangles(std::int64_t max_triangles) { options_.max_triangles = max_triangles; }
    /// The threshold the mesh is refined to: tau_pixels, or higher while the cap binds.
    double threshold() const { return threshold_; }
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
    std::uint32_t tileVertexVersion(std::int32_t tile) const { return vertex_version_[idx(tile)]; }
    std::int32_t tileVertexCount(std::int32_t tile) const;
    TileVertex tileVertex(std::int32_t tile, std::uint32_t index) const;

    /// Every leaf triangle of the current mesh, emitted or not (tests: conformity).
    template <class Visit> void forEachLeaf(Visit&& visit) const;

    std::int64_t triangleCount() const { return triangles_; }
    std::int32_t blockCount() const { return blocks_.count(); }
    /// Bytes of per-diamond state, blocks and index lists.
    std::size_t memoryBytes() const;
    /// Diamonds split since construction that needed a block no cell had (must stay 0).
    std::int64_t missingBlockRefusals() const { return missing_block_refusals_; }

    /// Error bound (metres) of the diamond centred at `p`; -1 if there is none (tests).
    double deltaAt(LatticePoint p) const;
    /// Metres per lattice unit and per height fine unit.
    double metresPerLattice() const { return metres_per_lattice_; }
    double metresPerFineUnit() const { return metres_per_fine_; }

  private:
    using DiamondId = std::uint32_t;
    static constexpr DiamondId kNoDiamond = 0xffffffffu;
    static constexpr std::uint8_t kActive = 1;
    static constexpr std::uint8_t kSplitCandidate = 2;
    static constexpr std::uint8_t kMergeCandidate = 4;
    static constexpr std::uint8_t kWatched = 8;
    static std::size_t idx(std::int64_t v) { return static_cast<std::size_t>(v); }

    // the id space: grid vertices first, then 256 per block slot (half-open 16 x 16 cell lattice)
    void adoptSpec();
    bool insideMap(LatticePoint p) const {
        return p.x >= 0 && p.y >= 0 && p.x <= max_x_ && p.y <= max_y_;
    }
    DiamondId idOf(LatticePoint p) const;
    LatticePoint pointOf(DiamondId id) const;
    std::int64_t heightAt(LatticePoint p) const;
    bool active(DiamondId id) const { return id != kNoDiamond && (state_[id] & kActive) != 0; }
    void resizeDiamondState();

    // bounds
    /// Both return whether the diamond's bounds changed.
    bool computeBounds(const Diamond& d, DiamondId id);
    /// computeBounds for a diamond strictly inside `block`'s cell, from the block directly.
    bool computeBlockBounds(const Diamond& d, DiamondId id, std::int32_t block);
    bool storeBounds(DiamondId id, float delta, float zlo, float zhi);
    bool finishBounds(
        DiamondId id, std::int64_t own_lo, std::int64_t own_hi, double delta, double lo, double hi);
    /// Bounds of every diamond whose subtree reaches the lattice rectangle, finest level first;
    /// with `collect`, the ids of those whose bounds changed go to recomputed_ (candidates to
    /// refresh).
    void recomputeBounds(
        std::int32_t lx0, std::int32_t ly0, std::int32_t lx1, std::int32_t ly1, bool collect);
    Box boxOf(const Diamond& d, DiamondId id) const;
    double priority(const ViewMetric& m, const Diamond& d, DiamondId id) const;
    double priorityAnyDirection(const ViewMetric& m, const Diamond& d, DiamondId id) const;
    double childBounds(LatticePoint c, double& zlo, double& zhi) const;

    // mesh
    bool canActivate(const Diamond& d, DiamondId id) const;
    bool activate(const Diamond& d, DiamondId id, bool forced, FrameStats& stats);
    void deactivate(const Diamond& d, DiamondId id, FrameStats& stats);
    void deactivateSubtree(LatticePoint p, FrameStats& stats);
    bool hasActiveChild(const Diamond& d) const;
    std::int32_t tileOf(const Triangle& t) const;
    bool emitted(const Triangle& t) const;
    TileMesh::Indices indicesOf(const Triangle& t, std::int32_t tile) const;
    void splitTriangles(const Diamond& d, bool split, bool forced);
    std::int64_t splitGain(const Diamond& d) const;
    Diamond tileRoot(std::int32_t tile) const;
    void emitTile(std::int32_t tile);
    void emitTriangle(const Triangle& t, std::int32_t tile, TileMesh& mesh);
    void rebuildTileBlocks(std::int32_t tile);
    std::int32_t tileOfCell(DetailBlocks::CellXY c) const; ///< -1 for virtual cells
    void attachBlock(std::int32_t block);
    void detachBlock(std::int32_t block);

    // frames
    void rebuildTopDown(const ViewMetric& m, FrameStats& stats);
    /// Splits best-first until `target` triangles; returns a bound on the error left.
    double refineBestFirst(const ViewMetric& m, std::int64_t target, FrameStats& stats);
    void followCap(const FrameStats& stats);
    void spreadRekey();
    void refineTopDown(const ViewMetric& m, const Triangle& t, FrameStats& stats, bool& capped);
    void collectCandidates(const Triangle& t);
    void updateSplitMerge(const ViewMetric& m, FrameStats& stats);
    void evaluate(const ViewMetric& m, DiamondId id, FrameStats& stats);
    void setCandidate(DiamondId id, std::uint8_t kind);
    void clearCandidate(DiamondId id);
    void refreshCandidate(DiamondId id);
    /// Replaces rectangles that overlap enough by their union (in place; order not kept).
    static void mergeOverlapping(std::vector<CellRect>& rects);
    void finishFrame(const ViewMetric& m, FrameStats& stats);

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

    // per diamond
    std::vector<float> delta_; ///< metres, rounded up
    std::vector<float> zlo_;   ///< metres, rounded down
    std::vector<float> zhi_;   ///< metres, rounded up
    std::vector<std::uint8_t> state_;

    // per tile
    std::vector<TileMesh> tiles_;
    std::vector<std::uint8_t> tile_visible_;
    std::vector<std::uint32_t> vertex_version_;
    /// Block slots in each tile's vertex array (-1: a hole left by a block that went); a slot
    /// keeps its place while its block lives, so index lists never move.
    std::vector<std::vector<std::int32_t>> tile_blocks_;
    std::vector<std::vector<std::int32_t>> tile_holes_; ///< free places in tile_blocks_
    std::vector<std::int32_t> block_local_;             ///< block slot -> index in its tile

    // split/merge state
    CandidateHeap heap_;             ///< candidates by the eye travel at which to re-examine them
    std::vector<DiamondId> watched_; ///< split candidates that want a split but are culled
    std::vector<DiamondId> watched_next_;
    struct Action {
        double priority = 0.0;
        DiamondId id = 0;
    };
    std::vector<Action> splits_;
    std::vector<Action> merges_;
    std::vector<DiamondId> due_;
    std::vector<DiamondId> evaluating_;
    std::vector<DiamondId> deferred_;
    std::vector<DiamondId> recomputed_;
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
    double threshold_ = 0.0; ///< tau, or higher while the cap binds (followCap)
    double unmet_ = 0.0;     ///< largest priority of a split the frame wanted and did not make
    std::vector<DiamondId> rekey_; ///< candidates still keyed against rekey_from_
    double rekey_from_ = 0.0;
    std::size_t rekey_quota_ = 0; ///< of rekey_, per frame
    double travel_ = 0.0;
    glm::dvec3 last_eye_{0.0};
    glm::dvec3 last_forward_{0.0};
    glm::dvec3 last_up_{0.0};
    double sweep_credit_ = 0.0;
    double sweep_phase_ = 0.0;
    std::int64_t triangles_ = 0;
    std::int64_t missing_block_refusals_ = 0;
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
