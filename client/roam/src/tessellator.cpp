// The tessellator's frames: split/merge candidates, their deferred re-examination, the
// top-down rebuild (split-only and after a jump), and the per-frame bookkeeping.

#include "tessellator_internal.h"

#include <terrain/roam/tessellator.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::roam {

using namespace detail;

Tessellator::Tessellator(const Terrain& terrain, const TessellatorOptions& options)
    : terrain_(&terrain), options_(options),
      policy_(space_, options.tau_pixels, options.cull_sweep_degrees) {
    policy_.setMergeBand(options.merge_band);
    terrainChanged({}, true);
}

void Tessellator::adoptSpec() {
    spec_ = terrain_->spec();
    ids_.reset(LatticeGeometry::of(spec_));
    emitter_.reset(spec_);
    space_.reset(geo().grid_count, BoundsCodec(spec_.metresPerUnit()));
    pool_.clear();
    pool_.restartClock();
    policy_.forgetIds();
    if (options_.count_moves_by_place) {
        census_ = std::make_unique<MoveCensus>();
        census_->reset(geo().max_x / kLatticePerCell, geo().max_y / kLatticePerCell);
    }
}

// ---- candidates ---------------------------------------------------------------------------

struct Tessellator::PolicyMesh final : SplitMergeMesh {
    explicit PolicyMesh(Tessellator& t) : t_(t) {}

    Extent extentOf(DiamondId id) const override {
        const Bounds b = t_.bounds(id);
        return {t_.boxOf(diamondAt(t_.pointOf(id)), b), b.delta};
    }
    bool split(DiamondId id, FrameStats& stats) override {
        t_.refused_by_cap_ = false;
        return t_.activate(diamondAt(t_.pointOf(id)), id, false, stats);
    }
    void merge(DiamondId id, FrameStats& stats) override {
        const Diamond d = diamondAt(t_.pointOf(id));
        if (!t_.hasActiveChild(d))
            t_.deactivate(d, id, stats);
    }
    bool budgetSpent(FrameStats& stats) const override { return t_.budgetSpent(stats, 1.0); }
    void splitsDone() override { t_.boundBatched(); }
    bool needsRoom() const override {
        return static_cast<double>(t_.triangles_) >=
               kCapLow * static_cast<double>(t_.options_.max_triangles);
    }
    bool pricingBudgetSpent(FrameStats& stats) const override {
        return t_.budgetSpent(stats, 1.0, kStepPricingShare, 0);
    }
    bool mergeBudgetSpent(FrameStats& stats) const override {
        return t_.budgetSpent(stats, kMergeUploadShare, kStepMergeShare);
    }

  private:
    Tessellator& t_;
};

void Tessellator::collectCandidates(const Triangle& t) {
    if (t.level >= kFinestTriangleLevel)
        return;
    const LatticePoint p = splitPoint(t);
    const Diamond d = diamondAt(p);
    DiamondId id = idOf(p);
    // a split candidate in a cell whose block is not resident (a virtual cell past the grid,
    // whose diamonds hang from the real cell before it) is materialised
    if (id == kNoDiamond && parentsActive(d))
        id = resolve(p);
    if (id == kNoDiamond)
        return;
    if (active(id)) {
        if ((state(id) & kMergeCandidate) == 0 && !hasActiveChild(d))
            policy_.offer(id, kMergeCandidate);
        const auto halves = splitTriangle(t);
        collectCandidates(halves[0]);
        collectCandidates(halves[1]);
    } else if ((state(id) & kSplitCandidate) == 0 && canActivate(d, id)) {
        policy_.offer(id, kSplitCandidate);
    }
}

// ---- frames -------------------------------------------------------------------------------

void Tessellator::refineTopDown(
    const ViewMetric& m, const Triangle& t, FrameStats& stats, bool& capped) {
    if (t.level >= kFinestTriangleLevel || capped)
        return;
    const LatticePoint p = splitPoint(t);
    DiamondId id = idOf(p);
    if (id == kNoDiamond) {
        // a detail cell whose block is not resident: materialised only if it may be split
        const Diamond d = diamondAt(p);
        if (blocks_.recordOf(p.x / kLatticePerCell, p.y / kLatticePerCell) < 0 || isGridVertex(p) ||
            recordPriority(m, d) <= policy_.threshold())
            return;
        id = resolve(p);
        if (id == kNoDiamond) {
            capped = refused_by_cap_; // the pool refused
            return;
        }
    } else if (id >= kPooled) {
        markUsed(id);
    }
    if (!active(id)) {
        const Diamond d = diamondAt(p);
        ++stats.evaluations;
        if (priority(m, d, id) <= policy_.threshold())
            return;
        if (!activate(d, id, false, stats)) {
            capped = refused_by_cap_;
            return;
        }
    }
    const auto halves = splitTriangle(t);
    refineTopDown(m, halves[0], stats, capped);
    refineTopDown(m, halves[1], stats, capped);
}

void Tessellator::rebuildTopDown(const ViewMetric& m, FrameStats& stats) {
    bookkeeping_ = false;
    space_.clearStates();
    policy_.clearCandidates();
    const std::int64_t roots = emitter_.rootTriangles();
    triangles_ = roots;
    refused_by_cap_ = false;
    // a cap that bound before (the threshold is above tau) most likely binds again: go
    // best-first at once rather than refine top-down until the cap stops it
    bool capped = policy_.threshold() > options_.tau_pixels;
    prefetchBlocks(m, policy_.threshold());
    policy_.setThreshold(options_.tau_pixels);
    for (std::int32_t tile = 0; tile < tileCount() && !capped; ++tile) {
        const Diamond root = emitter_.tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            refineTopDown(m, triangleOf(root, a), stats, capped);
    }
    if (capped) {
        // the cap binds: spend the triangles where the error is largest, not where we began.
        // Split/merge stops short of the cap, so that the next frames have room to follow the
        // view before the threshold must rise again.
        space_.clearStates();
        triangles_ = roots;
        refused_by_cap_ = false;
        const std::int64_t target =
            options_.mode == TessellationMode::kSplitMerge
                ? static_cast<std::int64_t>(
                      static_cast<double>(options_.max_triangles) * kCapTarget)
                : options_.max_triangles;
        policy_.setThreshold(std::max(options_.tau_pixels, refineBestFirst(m, target, stats)));
    }
    for (std::int32_t tile = 0; tile < tileCount(); ++tile)
        emitter_.emitTile(tile);
    bookkeeping_ = true;
    stats.rebuilt = true;
    if (options_.mode != TessellationMode::kSplitMerge)
        return;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = emitter_.tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            collectCandidates(triangleOf(root, a));
    }
    PolicyMesh mesh(*this);
    policy_.settle(m, stats, mesh);
}

bool Tessellator::budgetSpent(
    FrameStats& stats, double upload_share, double time_share, std::int64_t min_work) const {
    if (workSpent(stats) >= options_.work_budget)
        return true;
    // (a short step makes a few moves whatever its deadline says: progress, not only pricing)
    if (deadline_ != nullptr && workSpent(stats) >= min_work && deadline_->spent(time_share))
        return true;
    if (options_.upload_budget_bytes > 0 &&
        static_cast<double>(uploadSpent()) >=
            upload_share * static_cast<double>(options_.upload_budget_bytes)) {
        stats.upload_budget_bound = true;
        return true;
    }
    return false;
}

void Tessellator::finishFrame(const ViewMetric& m, FrameStats& stats) {
    emitter_.finishFrame(frame_, m, bounds_, stats);
    triangles_ = stats.triangles;
}

FrameStats Tessellator::update(const Camera& camera) {
    const ViewMetric m(camera);
    FrameStats stats;
    ++frame_;
    ++use_epoch_;
    const std::int64_t pool_refusals = pool_refusals_;
    const std::int64_t materialised = materialised_;
    const std::int64_t evicted = evicted_;
    made_at_frame_start_ = materialised_ + grains_materialised_;
    upload_at_frame_start_ = uploadTotal();
    const double teleport = options_.teleport_metres > 0.0
                                ? options_.teleport_metres
                                : 8.0 * kLatticePerTile * geo().metres_per_lattice;
    const bool jumped = glm::length(camera.eye - last_eye_) > teleport;
    const bool lens_changed =
        m.errorScale() != last_error_scale_ || camera.near_plane != last_near_;
    const bool rebuilding = options_.mode == TessellationMode::kSplitOnly || needs_rebuild_ ||
                            !initialized_ || jumped || lens_changed;
    // bounds that ops made stale: within the budget, or all before a rebuild
    const std::int64_t budget = rebuilding || options_.stale_block_budget <= 0
                                    ? std::numeric_limits<std::int64_t>::max()
                                    : options_.stale_block_budget;
    enter(UpdatePhase::kStaleBounds);
    if (deadline_ != nullptr && !rebuilding) {
        // a short step: oldest first, in passes of a few blocks, until its share of the step
        constexpr std::int64_t kPass = 48;
        while (staleBlockCount() > 0 && !deadline_->spent(kStepBoundsShare)) {
            const std::int64_t bounded = drainStale(kPass);
            stats.stale_blocks_bounded += bounded;
            if (bounded == 0)
                break;
        }
    } else {
        stats.stale_blocks_bounded = drainStale(budget);
    }
    if (rebuilding) {
        enter(UpdatePhase::kRebuild);
        rebuildTopDown(m, stats);
        needs_rebuild_ = false;
        initialized_ = true;
        policy_.restartSweep(camera);
    } else {
        enter(UpdatePhase::kSplitMerge);
        PolicyMesh mesh(*this);
        const bool new_view = deadline_ == nullptr || !sameView(camera, last_camera_);
        batching_ = true;
        stats.error_bound_pixels =
            policy_.frame(m, glm::length(camera.eye - last_eye_), stats, mesh, new_view);
        boundBatched();
        batching_ = false;
        stats.refused_by_cap += pool_refusals_ - pool_refusals; // the pool binds like the cap
        // a step that goes on with the last view (a worker's short steps) leaves the threshold
        // alone: each move re-prices every candidate, once a view is enough
        if (new_view)
            policy_.followCap(
                stats, triangles_, options_.max_triangles,
                frame_ > last_pool_refusal_ + kPoolQuietFrames);
    }
    if (stats.rebuilt)
        stats.error_bound_pixels = policy_.threshold();
    last_eye_ = camera.eye;
    last_camera_ = camera;
    last_error_scale_ = m.errorScale();
    last_near_ = camera.near_plane;
    enter(UpdatePhase::kFinishFrame);
    finishFrame(m, stats);
    enter(UpdatePhase::kPoolUpkeep);
    sweepIdleBlocks();
    trimGrains();
    stats.refused_by_pool = pool_refusals_ - pool_refusals;
    bounds_.freshenHeights();
    stats.stale_blocks = staleBlockCount();
    if (stats.stale_blocks > 0)
        stats.budget_exhausted = true; // their bounds are the old surface's
    stats.upload_bytes = uploadSpent();
    stats.blocks_materialised = materialised_ - materialised;
    stats.blocks_evicted = evicted_ - evicted;
    enter(UpdatePhase::kDone);
    return stats;
}

std::int64_t Tessellator::drainStale(std::int64_t budget) {
    const std::int64_t bounded = bounds_.drainStale(budget);
    if (bounded > 0 && initialized_ && !needs_rebuild_)
        for (const DiamondId id : bounds_.moved())
            refreshCandidate(id);
    return bounded;
}

bool Tessellator::splitAt(LatticePoint p, FrameStats& stats) {
    const Diamond d = diamondAt(p);
    if (!d.valid() || !initialized_)
        return false;
    const DiamondId id = resolve(p);
    if (id == kNoDiamond)
        return false;
    return activate(d, id, false, stats);
}

void Tessellator::setStepDeadline(const StepDeadline* deadline) {
    deadline_ = deadline;
    policy_.setBacklogPull(deadline != nullptr ? kStepBacklogPull : SplitMerge::kPullAll);
}

bool Tessellator::settled(CellRect cells) const {
    // a block's bounds read its 3 x 3 window: the blocks one cell around
    for (std::int32_t cy = cells.y0 - 1; cy <= cells.y1 + 1; ++cy)
        for (std::int32_t cx = cells.x0 - 1; cx <= cells.x1 + 1; ++cx)
            if (const std::int32_t block = blocks_.blockOf(cx, cy);
                block >= 0 && bounds_.blockStale(block))
                return false;
    bool waiting = false;
    policy_.forEachWaitingSplit([&](DiamondId id) {
        if (waiting || (state(id) & kSplitCandidate) == 0 || active(id))
            return;
        const LatticePoint p = pointOf(id);
        const std::int32_t cx = p.x / kLatticePerCell;
        const std::int32_t cy = p.y / kLatticePerCell;
        waiting =
            cx >= cells.x0 - 1 && cx <= cells.x1 + 1 && cy >= cells.y0 - 1 && cy <= cells.y1 + 1;
    });
    return !waiting;
}

void Tessellator::setTau(double tau_pixels) {
    options_.tau_pixels = tau_pixels;
    policy_.setTau(tau_pixels);
    needs_rebuild_ = true;
}

TessellatorMemory Tessellator::memory() const {
    TessellatorMemory m;
    const DiamondSpace::Memory space = space_.memory();
    const BlockPool::Memory pool = pool_.memory();
    m.grid = space.grid;
    m.records = blocks_.memoryBytes() + pool.blocks;
    for (std::size_t g = 0; g < kGrains; ++g)
        m.grains[g] = space.chunks[g] + pool.grains[g];
    m.heap = policy_.memoryBytes();
    m.meshes = emitter_.memoryBytes();
    m.scratch = bounds_.memoryBytes() + emitter_.scratchBytes();
    return m;
}

} // namespace terrain::roam
