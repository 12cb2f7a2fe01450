// The tessellator's lattice walk: splits with the parents they force and merges, as the
// diamonds' states and the candidates they offer (the tiles' lists follow in TileEmitter), and
// what an op changes.

#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>

namespace terrain::roam {

using namespace detail;

// ---- the mesh -----------------------------------------------------------------------------

bool Tessellator::hasActiveChild(const Diamond& d) const {
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i)
        if (active(idOf(kids[idx(i)])))
            return true;
    return false;
}

bool Tessellator::parentsActive(const Diamond& d) const {
    if (d.level == 0)
        return true;
    for (const LatticePoint a : apexes(d))
        if (insideMap(a) && !active(idOf(a)))
            return false;
    return true;
}

bool Tessellator::canActivate(const Diamond& d, DiamondId id) const {
    return id != kNoDiamond && parentsActive(d);
}

bool Tessellator::activate(const Diamond& d, DiamondId id, bool forced, FrameStats& stats) {
    if (active(id))
        return true;
    if (d.level > 0) {
        for (const LatticePoint a : apexes(d)) {
            if (!insideMap(a))
                continue;
            const DiamondId parent = resolve(a);
            if (parent == kNoDiamond) {
                // no record is a bug (must stay 0); else the pool refused (counted there)
                if (blocks_.recordOf(a.x / kLatticePerCell, a.y / kLatticePerCell) < 0)
                    ++missing_block_refusals_;
                return false;
            }
            if (!active(parent) && !activate(diamondAt(a), parent, true, stats))
                return false;
        }
    }
    // splitting a cell's centre draws the cell with its block's vertices
    if (isCentre(id)) {
        const std::int32_t record = space_.recordOfCentre(id);
        if (blocks_.blockOfRecord(record) < 0 && materialise(record) < 0)
            return false; // the pool refused
        pool_.markBlockUsed(blocks_.blockOfRecord(record), use_epoch_);
    }
    const std::int64_t gain = emitter_.splitGain(d);
    if (triangles_ + gain > options_.max_triangles) {
        ++stats.refused_by_cap;
        refused_by_cap_ = true;
        return false;
    }
    state(id) |= kActive;
    if (id >= kPooled)
        markUsed(id);
    triangles_ += gain;
    ++stats.splits;
    if (forced)
        ++stats.forced_splits;
    countMove(d, id, true, stats);
    if (!bookkeeping_)
        return true;
    emitter_.splitTriangles(d, true, forced);
    policy_.clearCandidate(id);
    if (d.level > 0)
        for (const LatticePoint a : apexes(d))
            if (insideMap(a)) {
                const DiamondId parent = idOf(a);
                if ((state(parent) & kMergeCandidate) != 0)
                    policy_.clearCandidate(parent);
            }
    policy_.offer(id, kMergeCandidate);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i) {
        const LatticePoint c = kids[idx(i)];
        if (!insideMap(c))
            continue;
        const Diamond cd = diamondAt(c);
        DiamondId child = idOf(c);
        if (child == kNoDiamond && parentsActive(cd))
            child = resolve(c); // a virtual cell's block, hanging from the real cell before it
        if (child != kNoDiamond && !active(child) && canActivate(cd, child)) {
            policy_.offer(child, kSplitCandidate);
        }
    }
    return true;
}

void Tessellator::deactivate(const Diamond& d, DiamondId id, FrameStats& stats) {
    state(id) = static_cast<std::uint8_t>(state(id) & ~kActive);
    triangles_ -= emitter_.splitGain(d);
    ++stats.merges;
    countMove(d, id, false, stats);
    if (!bookkeeping_)
        return;
    emitter_.splitTriangles(d, false, false);
    policy_.clearCandidate(id);
    policy_.offer(id, kSplitCandidate);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i) {
        const DiamondId child = idOf(kids[idx(i)]);
        if (child != kNoDiamond && (state(child) & kSplitCandidate) != 0)
            policy_.clearCandidate(child);
    }
    if (d.level == 0)
        return;
    for (const LatticePoint a : apexes(d)) {
        if (!insideMap(a))
            continue;
        const DiamondId parent = idOf(a);
        const Diamond pd = diamondAt(a);
        if (active(parent) && !hasActiveChild(pd)) {
            policy_.offer(parent, kMergeCandidate);
        }
    }
}

void Tessellator::deactivateSubtree(LatticePoint p, FrameStats& stats) {
    const DiamondId id = idOf(p);
    if (!active(id))
        return;
    const Diamond d = diamondAt(p);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i)
        if (insideMap(kids[idx(i)]))
            deactivateSubtree(kids[idx(i)], stats);
    deactivate(d, id, stats);
}

void Tessellator::attachGrain(std::int32_t block, int g) {
    const std::int32_t chunk = pool_.chunkOf(block, g);
    pool_.segment(g, chunk) = emitter_.attachGrain(block, g, chunk);
}

void Tessellator::detachGrain(std::int32_t block, int g) {
    const std::int32_t chunk = pool_.chunkOf(block, g);
    const std::int32_t segment = pool_.segment(g, chunk);
    pool_.segment(g, chunk) = -1;
    emitter_.detachGrain(block, g, segment);
}

// ---- terrain changes ----------------------------------------------------------------------

void Tessellator::terrainChanged(std::span<const CellRect> cells, bool all) {
    bounds_.surfaceChanged();
    if (all) {
        all_cells_changed_ = true;
        changed_cells_.clear();
        // a snapshot may bring another world (size, spacing): start from its spec
        if (emitter_.tileCount() == 0 || !(terrain_->spec() == spec_))
            adoptSpec();
        emitter_.read(*terrain_);
        bounds_.reset(*terrain_, {spec_, geo().metres_per_fine, geo().max_x, geo().max_y});
        // the heap forgets its ids before their ranges shrink with the pool (clearing writes to
        // each held id's position)
        policy_.clearCandidates();
        blocks_.reset(*terrain_); // records only: no block resident
        pool_.clear();
        space_.dropChunks();
        resizeDiamondState();
        space_.clearStates();
        emitter_.clearVertexArrays();
        bounds_.recomputeAll();
        needs_rebuild_ = true;
        return;
    }
    FrameStats ignored;
    // ops of one frame often overlap (shots land where the fight is): work through the union of
    // rectangles that overlap enough, so that a block and its bounds are redone once, not per op
    merged_.clear();
    for (const CellRect& r : cells)
        if (!r.empty())
            merged_.push_back(r);
    mergeOverlapping(merged_);
    for (const CellRect& r : merged_) {
        // records about to go: coarsen everything that refines into them first
        removing_.clear();
        blocks_.plan(*terrain_, r, removing_);
        for (const std::int32_t record : removing_) {
            const DetailBlocks::CellXY c = blocks_.recordCell(record);
            // every split diamond of the cell descends from its centre
            deactivateSubtree(
                {c.x * kLatticePerCell + kCentreLocal, c.y * kLatticePerCell + kCentreLocal},
                ignored);
            const std::int32_t block = blocks_.blockOfRecord(record);
            if (block >= 0) {
                for (std::uint32_t local = 1; local < kDiamondsPerBlock; ++local)
                    deactivateSubtree(
                        {c.x * kLatticePerCell + static_cast<std::int32_t>(local % kLatticePerCell),
                         c.y * kLatticePerCell +
                             static_cast<std::int32_t>(local / kLatticePerCell)},
                        ignored);
                for (std::uint32_t local = 1; local < kDiamondsPerBlock; ++local)
                    if (const DiamondId id = ids_.pooledId(block, local); id != kNoDiamond)
                        policy_.clearCandidate(id);
                // its segments in the tile's vertex array become holes: nothing refers to them
                evict(block);
            }
            policy_.clearCandidate(centreId(record));
            state(centreId(record)) = 0;
        }
        // the centres' bounds before (they are derived, not stored): only those that move are
        // re-examined
        bounds_.noteCentres(r);
        removed_.clear();
        added_.clear();
        blocks_.update(*terrain_, r, removed_, added_);
        resizeDiamondState();
        for (const std::int32_t record : added_)
            state(centreId(record)) = 0;
        emitter_.heightsChanged(r); // heights moved in these tiles
        if (census_)
            census_->changed(r, frame_ + 1);
        bounds_.markStale(r);
        bounds_.recomputeAround(r);
        if (initialized_ && !needs_rebuild_)
            for (const DiamondId id : bounds_.moved())
                refreshCandidate(id);
    }
    // the resident blocks' heights follow the op now, with the base grid's (read from the
    // terrain): a mesh drawn before the next update() is the new surface, without cracks
    // between a block and the grid around it (their bounds wait for the frames' budget)
    bounds_.freshenHeights();
    for (const CellRect& r : merged_) {
        emitter_.markChangedSurface(r);
        if (!all_cells_changed_ && changed_cells_.size() < kMaxChangedCells)
            changed_cells_.push_back(r);
        else {
            all_cells_changed_ = true;
            changed_cells_.clear();
        }
    }
}

void Tessellator::mergeOverlapping(std::vector<CellRect>& rects) {
    const auto area = [](const CellRect& r) {
        return static_cast<std::int64_t>(r.x1 - r.x0 + 1) * (r.y1 - r.y0 + 1);
    };
    // merge two whenever their union costs no more than the two apart; passes until none do
    bool merged = true;
    while (merged) {
        merged = false;
        for (std::size_t i = 0; i < rects.size(); ++i)
            for (std::size_t j = i + 1; j < rects.size();) {
                const CellRect& a = rects[i];
                const CellRect& b = rects[j];
                const CellRect u{
                    std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1),
                    std::max(a.y1, b.y1)};
                if (area(u) <= area(a) + area(b)) {
                    rects[i] = u;
                    rects[j] = rects.back();
                    rects.pop_back();
                    merged = true;
                } else {
                    ++j;
                }
            }
    }
}

void Tessellator::refreshCandidate(DiamondId id) {
    // A bound decides a candidate's priority, not whether it is one: that is its place in the
    // mesh, which every split and merge keeps in its state bits. So a diamond that is no
    // candidate stays none (a battle crater moves the bounds of ~23,000 diamonds, 1,500 of them
    // candidates). Centres are the exception: a record the op added starts with a cleared
    // state, and its centre is offered here.
    if ((state(id) & (kSplitCandidate | kMergeCandidate)) == 0 && !space_.isCentre(id))
        return;
    const Diamond d = diamondAt(pointOf(id));
    std::uint8_t kind = 0;
    if (active(id))
        kind = hasActiveChild(d) ? 0 : kMergeCandidate;
    else if (canActivate(d, id))
        kind = kSplitCandidate;
    policy_.clearCandidate(id);
    if (kind != 0) {
        policy_.offer(id, kind);
    }
}

} // namespace terrain::roam
