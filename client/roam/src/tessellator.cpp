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
    : terrain_(&terrain), options_(options), threshold_(options.tau_pixels) {
    terrainChanged({}, true);
}

void Tessellator::adoptSpec() {
    spec_ = terrain_->spec();
    metres_per_lattice_ = spec_.spacingMetres() / kLatticePerCell;
    metres_per_fine_ = spec_.metresPerUnit() / static_cast<double>(kFineUnitsPerQuantum);
    grid_w_ = spec_.paddedWidth();
    grid_h_ = spec_.paddedHeight();
    max_x_ = (grid_w_ - 1) * kLatticePerCell;
    max_y_ = (grid_h_ - 1) * kLatticePerCell;
    real_x_ = spec_.cellsX() * kLatticePerCell;
    real_y_ = spec_.cellsY() * kLatticePerCell;
    grid_count_ = static_cast<std::uint32_t>(grid_w_) * static_cast<std::uint32_t>(grid_h_);
    const std::size_t tiles = idx(spec_.tileCount());
    tiles_.clear();
    tiles_.resize(tiles);
    tile_visible_.assign(tiles, 0);
    tile_snug_.assign(tiles, 0);
    vertices_.reset(tiles);
    space_.reset(grid_count_, BoundsCodec(spec_.metresPerUnit()));
    pool_.clear();
    pool_.restartClock();
    heap_.reset();
}

// ---- candidates ---------------------------------------------------------------------------

void Tessellator::setCandidate(DiamondId id, std::uint8_t kind) {
    state(id) = static_cast<std::uint8_t>((state(id) & kActive) | kind);
}

void Tessellator::clearCandidate(DiamondId id) {
    state(id) = static_cast<std::uint8_t>(state(id) & kActive);
    if (heap_.contains(id))
        heap_.remove(id);
}

void Tessellator::evaluate(const ViewMetric& m, DiamondId id, FrameStats& stats) {
    const std::uint8_t st = state(id);
    if ((st & (kSplitCandidate | kMergeCandidate)) == 0)
        return;
    if (heap_.contains(id))
        heap_.remove(id);
    const Diamond d = diamondAt(pointOf(id));
    ++stats.evaluations;
    const Bounds bounds_of = bounds(id);
    const Box box = boxOf(d, bounds_of);
    const double tau = threshold_;
    if (box.lo.x > box.hi.x) {
        // wholly in the padding: never worth a triangle
        if ((st & kMergeCandidate) != 0)
            merges_.push_back({0.0, id});
        return;
    }
    const double delta = bounds_of.delta;
    const double distance = m.distanceTo(box);
    const double any = m.screenErrorAtDistance(distance, delta);
    const double p = any > tau && !m.intersectsFrustum(box) ? 0.0 : any;
    // distance at which the priority crosses tau; priorities depend on the eye position only
    const double crossing = m.errorScale() * delta / tau;
    if ((st & kSplitCandidate) != 0) {
        if (p > tau) {
            splits_.push_back({p, id});
        } else if (any > tau) {
            state(id) |= kWatched;
            watched_.push_back(id);
        } else if (m.errorScale() * delta / options_.tau_pixels > m.camera().near_plane) {
            // (tested at tau, not at the threshold: the threshold may fall back to tau, and
            // then these must be in the heap)
            heap_.push(id, travel_ + std::max(0.0, distance - crossing));
        }
        return;
    }
    if (p <= tau)
        merges_.push_back({p, id});
    else // due when the eye has moved away far enough, or far enough to take it out of view
        heap_.push(id, travel_ + std::min(std::max(0.0, crossing - distance), m.exitSlack(box)));
}

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
        if ((state(id) & kMergeCandidate) == 0 && !hasActiveChild(d)) {
            setCandidate(id, kMergeCandidate);
            due_.push_back(id);
        }
        const auto halves = splitTriangle(t);
        collectCandidates(halves[0]);
        collectCandidates(halves[1]);
    } else if ((state(id) & kSplitCandidate) == 0 && canActivate(d, id)) {
        setCandidate(id, kSplitCandidate);
        due_.push_back(id);
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
            recordPriority(m, d) <= threshold_)
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
        if (priority(m, d, id) <= threshold_)
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
    heap_.clear();
    watched_.clear();
    rekey_.clear();
    due_.clear();
    splits_.clear();
    merges_.clear();
    std::int64_t roots = 0;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            roots += emitted(triangleOf(root, a)) ? 1 : 0;
    }
    triangles_ = roots;
    refused_by_cap_ = false;
    // a cap that bound before (the threshold is above tau) most likely binds again: go
    // best-first at once rather than refine top-down until the cap stops it
    bool capped = threshold_ > options_.tau_pixels;
    prefetchBlocks(m, threshold_);
    threshold_ = options_.tau_pixels;
    for (std::int32_t tile = 0; tile < tileCount() && !capped; ++tile) {
        const Diamond root = tileRoot(tile);
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
        threshold_ = std::max(options_.tau_pixels, refineBestFirst(m, target, stats));
    }
    for (std::int32_t tile = 0; tile < tileCount(); ++tile)
        emitTile(tile);
    bookkeeping_ = true;
    stats.rebuilt = true;
    if (options_.mode != TessellationMode::kSplitMerge)
        return;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            collectCandidates(triangleOf(root, a));
    }
    for (const DiamondId id : due_)
        evaluate(m, id, stats);
    due_.clear();
    // only a binding cap leaves work here; it waits for the next frame
    for (const Action& a : splits_)
        heap_.push(a.id, travel_);
    for (const Action& a : merges_)
        heap_.push(a.id, travel_);
    splits_.clear();
    merges_.clear();
}

void Tessellator::updateSplitMerge(const ViewMetric& m, FrameStats& stats) {
    // merge candidates kept split because they were in view: their keys cover the eye moving
    // them out of the frustum (exitSlack) but not the view turning. So their culling is
    // re-checked as the view turns: as many per frame as the heap holds times the turn over
    // cull_sweep_degrees, sampled in a low-discrepancy order (about each one per that much
    // turning, not exactly), or every one on a turn that large within a frame. This only
    // delays merges of regions out of view; no needed split depends on it.
    const glm::dvec3 forward = glm::normalize(m.camera().forward);
    const glm::dvec3 up = glm::normalize(m.camera().up);
    const double turned = std::acos(std::clamp(glm::dot(forward, last_forward_), -1.0, 1.0)) +
                          std::acos(std::clamp(glm::dot(up, last_up_), -1.0, 1.0));
    last_forward_ = forward;
    last_up_ = up;
    sweep_credit_ += static_cast<double>(heap_.size()) * turned /
                     (std::max(options_.cull_sweep_degrees, 0.01) * 3.14159265358979323846 / 180.0);
    const auto sweep =
        static_cast<std::size_t>(std::min(sweep_credit_, static_cast<double>(heap_.size())));
    sweep_credit_ = std::min(sweep_credit_ - static_cast<double>(sweep), 1.0);
    for (std::size_t k = 0; k < sweep; ++k) {
        // low-discrepancy order (golden-ratio steps) rather than heap order: entries near the
        // heap's front are the ones near the frustum's sides, and checking them in one block
        // would merge everything that left the view in one burst
        sweep_phase_ += 0.6180339887498949;
        sweep_phase_ -= std::floor(sweep_phase_);
        const CandidateHeap::Entry e =
            sweep == heap_.size() // a whole turn's worth: every entry once
                ? heap_.at(k)
                : heap_.at(
                      static_cast<std::size_t>(sweep_phase_ * static_cast<double>(heap_.size())));
        if ((state(e.id) & kMergeCandidate) == 0 || e.key <= travel_)
            continue;
        const Box box = boxOf(diamondAt(pointOf(e.id)), bounds(e.id));
        if (box.lo.x > box.hi.x || !m.intersectsFrustum(box))
            due_.push_back(e.id); // taken out of the heap below, so the sweep skips no entry
    }
    for (const DiamondId id : due_)
        if (heap_.contains(id))
            heap_.remove(id);
    while (!heap_.empty() && heap_.top().key <= travel_) {
        const DiamondId id = heap_.top().id;
        heap_.remove(id);
        due_.push_back(id);
    }
    watched_next_.swap(watched_);
    watched_.clear();
    for (const DiamondId id : watched_next_)
        if ((state(id) & kWatched) != 0) {
            state(id) = static_cast<std::uint8_t>(state(id) & ~kWatched);
            due_.push_back(id);
        }
    const auto by_priority_up = [](const Action& a, const Action& b) {
        return a.priority < b.priority;
    };
    const auto by_priority_down = [](const Action& a, const Action& b) {
        return a.priority > b.priority;
    };
    deferred_.clear();
    while (!due_.empty()) {
        // evaluating appends to due_ only through splits and merges, which happen below
        evaluating_.swap(due_);
        due_.clear();
        for (const DiamondId id : evaluating_)
            evaluate(m, id, stats);
        evaluating_.clear();
        std::sort(merges_.begin(), merges_.end(), by_priority_up);
        for (const Action& a : merges_) {
            if ((state(a.id) & kMergeCandidate) == 0 || !active(a.id))
                continue;
            if (budgetSpent(stats)) {
                deferred_.push_back(a.id);
                continue;
            }
            const Diamond d = diamondAt(pointOf(a.id));
            if (!hasActiveChild(d))
                deactivate(d, a.id, stats);
        }
        merges_.clear();
        std::sort(splits_.begin(), splits_.end(), by_priority_down);
        for (const Action& a : splits_) {
            if ((state(a.id) & kSplitCandidate) == 0 || active(a.id))
                continue;
            if (budgetSpent(stats)) {
                deferred_.push_back(a.id);
                unmet_ = std::max(unmet_, a.priority);
                continue;
            }
            refused_by_cap_ = false;
            if (!activate(diamondAt(pointOf(a.id)), a.id, false, stats)) {
                deferred_.push_back(a.id);
                unmet_ = std::max(unmet_, a.priority);
            }
        }
        splits_.clear();
        if (budgetSpent(stats)) {
            stats.budget_exhausted = true;
            deferred_.insert(deferred_.end(), due_.begin(), due_.end());
            due_.clear();
        }
    }
    // left for the next frame: due again as soon as it starts
    for (const DiamondId id : deferred_)
        if ((state(id) & (kSplitCandidate | kMergeCandidate)) != 0)
            heap_.push(id, travel_);
}

bool Tessellator::budgetSpent(FrameStats& stats) const {
    if (workSpent(stats) >= options_.work_budget)
        return true;
    if (options_.upload_budget_bytes > 0 && uploadSpent() >= options_.upload_budget_bytes) {
        stats.upload_budget_bound = true;
        return true;
    }
    return false;
}

void Tessellator::finishFrame(const ViewMetric& m, FrameStats& stats) {
    std::uint64_t written = 0;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        TileMesh& mesh = tiles_[idx(tile)];
        mesh.fillHoles();
        written += mesh.counters().index_bytes_written;
        const Diamond root = tileRoot(tile);
        const DiamondId id = idOf(root.centre);
        const std::int32_t tx = tile % spec_.tilesX();
        const std::int32_t ty = tile / spec_.tilesX();
        Box box;
        box.lo = {
            tx * kLatticePerTile * metres_per_lattice_, ty * kLatticePerTile * metres_per_lattice_,
            bounds(id).zlo};
        box.hi = {
            std::min((tx + 1) * kLatticePerTile, real_x_) * metres_per_lattice_,
            std::min((ty + 1) * kLatticePerTile, real_y_) * metres_per_lattice_, bounds(id).zhi};
        const bool visible = m.intersectsFrustum(box);
        tile_visible_[idx(tile)] = visible ? 1 : 0;
        // memory follows the mesh: a tile whose list has stayed well below its peak for a while
        // gives the capacity back (a few tiles a frame); one that returns to its peak, as in an
        // orbit, keeps it
        if (!mesh.hasSlack())
            tile_snug_[idx(tile)] = frame_;
        else if (
            frame_ > tile_snug_[idx(tile)] + kTileSlackFrames &&
            (frame_ + static_cast<std::uint64_t>(tile)) % kTileShrinkEvery == 0)
            mesh.shrink();
        stats.triangles += mesh.triangleCount();
        if (visible)
            stats.visible_triangles += mesh.triangleCount();
        stats.index_bytes_total +=
            static_cast<std::int64_t>(mesh.slotCount()) * TileMesh::kIndexBytesPerTriangle;
    }
    stats.index_bytes_written = static_cast<std::int64_t>(written - written_before_);
    written_before_ = written;
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
                                : 8.0 * kLatticePerTile * metres_per_lattice_;
    const bool jumped = glm::length(camera.eye - last_eye_) > teleport;
    const bool lens_changed =
        m.errorScale() != last_error_scale_ || camera.near_plane != last_near_;
    const bool rebuilding = options_.mode == TessellationMode::kSplitOnly || needs_rebuild_ ||
                            !initialized_ || jumped || lens_changed;
    // bounds that ops made stale: within the budget, or all before a rebuild
    const std::int64_t budget = rebuilding || options_.stale_block_budget <= 0
                                    ? std::numeric_limits<std::int64_t>::max()
                                    : options_.stale_block_budget;
    stats.stale_blocks_bounded = drainStale(budget);
    if (rebuilding) {
        rebuildTopDown(m, stats);
        needs_rebuild_ = false;
        initialized_ = true;
        last_forward_ = glm::normalize(camera.forward);
        last_up_ = glm::normalize(camera.up);
        sweep_credit_ = 0.0;
    } else {
        travel_ += glm::length(camera.eye - last_eye_);
        unmet_ = 0.0;
        // while a threshold move is being spread, candidates not yet re-examined still hold to
        // the threshold before it
        const double threshold = rekey_.empty() ? threshold_ : std::max(threshold_, rekey_from_);
        spreadRekey();
        updateSplitMerge(m, stats);
        stats.error_bound_pixels = std::max(threshold, unmet_);
        stats.refused_by_cap += pool_refusals_ - pool_refusals; // the pool binds like the cap
        followCap(stats);
    }
    if (stats.rebuilt)
        stats.error_bound_pixels = threshold_;
    last_eye_ = camera.eye;
    last_error_scale_ = m.errorScale();
    last_near_ = camera.near_plane;
    finishFrame(m, stats);
    sweepIdleBlocks();
    trimGrains();
    stats.refused_by_pool = pool_refusals_ - pool_refusals;
    freshenHeights();
    stats.stale_blocks = staleBlockCount();
    if (stats.stale_blocks > 0)
        stats.budget_exhausted = true; // their bounds are the old surface's
    stats.upload_bytes = uploadSpent();
    stats.blocks_materialised = materialised_ - materialised;
    stats.blocks_evicted = evicted_ - evicted;
    return stats;
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

void Tessellator::setTau(double tau_pixels) {
    options_.tau_pixels = tau_pixels;
    threshold_ = tau_pixels;
    needs_rebuild_ = true;
}

TessellatorMemory Tessellator::memory() const {
    TessellatorMemory m;
    const DiamondSpace::Memory space = space_.memory();
    const BlockPool::Memory pool = pool_.memory();
    m.grid = space.grid + centre_cache_.capacity() * sizeof(Bounds);
    m.records = blocks_.memoryBytes() + pool.blocks;
    for (std::size_t g = 0; g < kGrains; ++g)
        m.grains[g] = space.chunks[g] + pool.grains[g];
    m.heap = heap_.memoryBytes();
    for (const TileMesh& t : tiles_)
        m.meshes += t.memoryBytes();
    m.meshes += vertices_.memoryBytes();
    m.scratch = block_bounds_.memoryBytes() + morph_stamp_.capacity() * sizeof(std::uint32_t);
    return m;
}

} // namespace terrain::roam
