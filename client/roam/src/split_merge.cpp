#include "tessellator_internal.h"

#include <terrain/roam/split_merge.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace terrain::roam {

using namespace detail;

namespace {

constexpr std::uint8_t kActive = DiamondSpace::kActive;
constexpr std::uint8_t kSplitCandidate = DiamondSpace::kSplitCandidate;
constexpr std::uint8_t kMergeCandidate = DiamondSpace::kMergeCandidate;
constexpr std::uint8_t kWatched = DiamondSpace::kWatched;

} // namespace

void SplitMerge::clearCandidates() {
    heap_.clear();
    watched_.clear();
    rekey_.clear();
    due_.clear();
    carried_ = 0;
    deferred_splits_.clear();
    backlog_splits_.clear();
    backlog_merges_.clear();
    left_splits_.clear();
    left_merges_.clear();
    splits_.clear();
    merges_.clear();
}

void SplitMerge::evaluate(
    const ViewMetric& m, DiamondId id, FrameStats& stats, SplitMergeMesh& mesh) {
    const std::uint8_t st = space_->state(id);
    if ((st & (kSplitCandidate | kMergeCandidate)) == 0)
        return;
    if (heap_.contains(id))
        heap_.remove(id);
    ++stats.evaluations;
    const SplitMergeMesh::Extent extent = mesh.extentOf(id);
    const Box& box = extent.box;
    const double tau = threshold_;
    if (box.lo.x > box.hi.x) {
        // wholly in the padding: never worth a triangle
        if ((st & kMergeCandidate) != 0)
            merges_.push_back({0.0, id});
        return;
    }
    const double delta = extent.delta;
    const double distance = m.distanceTo(box);
    const double any = m.screenErrorAtDistance(distance, delta);
    const double p = any > tau && !m.intersectsFrustum(box) ? 0.0 : any;
    // distance at which the priority crosses tau; priorities depend on the eye position only
    const double crossing = m.errorScale() * delta / tau;
    if ((st & kSplitCandidate) != 0) {
        if (p > tau) {
            splits_.push_back({p, id});
        } else if (any > tau) {
            space_->state(id) |= kWatched;
            watched_.push_back(id);
        } else if (m.errorScale() * delta / tau_ > m.camera().near_plane) {
            // (tested at tau, not at the threshold: the threshold may fall back to tau, and
            // then these must be in the heap)
            heap_.push(id, travel_ + std::max(0.0, distance - crossing));
        }
        return;
    }
    // (a merge waits for the band below the threshold: hysteresis)
    if (p <= tau * merge_band_)
        merges_.push_back({p, id});
    else // due when the eye has moved away far enough, or far enough to take it out of view
        heap_.push(
            id,
            travel_ + std::min(std::max(0.0, crossing / merge_band_ - distance), m.exitSlack(box)));
}

void SplitMerge::settle(const ViewMetric& m, FrameStats& stats, SplitMergeMesh& mesh) {
    for (const DiamondId id : due_)
        evaluate(m, id, stats, mesh);
    due_.clear();
    carried_ = 0;
    // only a binding cap leaves work here; it waits for the next frame
    for (const Action& a : splits_)
        heap_.push(a.id, travel_);
    for (const Action& a : merges_)
        heap_.push(a.id, travel_);
    splits_.clear();
    merges_.clear();
}

void SplitMerge::restartSweep(const Camera& camera) {
    last_forward_ = glm::normalize(camera.forward);
    last_up_ = glm::normalize(camera.up);
    sweep_credit_ = 0.0;
}

void SplitMerge::sweepCulled(const ViewMetric& m, SplitMergeMesh& mesh) {
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
                     (std::max(sweep_degrees_, 0.01) * 3.14159265358979323846 / 180.0);
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
        if ((space_->state(e.id) & kMergeCandidate) == 0 || e.key <= travel_)
            continue;
        const Box box = mesh.extentOf(e.id).box;
        if (box.lo.x > box.hi.x || !m.intersectsFrustum(box))
            due_.push_back(e.id); // taken out of the heap below, so the sweep skips no entry
    }
}

double SplitMerge::frame(
    const ViewMetric& m, double travelled, FrameStats& stats, SplitMergeMesh& mesh, bool new_view) {
    travel_ += travelled;
    unmet_ = 0.0;
    // while a threshold move is being spread, candidates not yet re-examined still hold to the
    // threshold before it
    const double threshold = rekey_.empty() ? threshold_ : std::max(threshold_, rekey_from_);
    // (a short step that goes on with the last view has nothing new to sweep, re-key or watch)
    if (new_view) {
        spreadRekey();
        sweepCulled(m, mesh);
    }
    // offered since the last frame: out of the heap (what a short step carried over never was)
    for (std::size_t i = carried_; i < due_.size(); ++i)
        if (heap_.contains(due_[i]))
            heap_.remove(due_[i]);
    while (!heap_.empty() && heap_.top().key <= travel_) {
        const DiamondId id = heap_.top().id;
        heap_.remove(id);
        due_.push_back(id);
    }
    if (new_view) {
        watched_next_.swap(watched_);
        watched_.clear();
        for (const DiamondId id : watched_next_)
            if ((space_->state(id) & kWatched) != 0) {
                space_->state(id) = static_cast<std::uint8_t>(space_->state(id) & ~kWatched);
                due_.push_back(id);
            }
    }
    // the backlog's best are priced first (known to matter); its merges only where the mesh
    // needs their room or no split waits, since a step makes its splits first and its merges
    // with what is left
    pullBacklog(mesh.needsRoom() || backlog_splits_.empty());
    if (!pulled_.empty()) {
        pulled_.insert(pulled_.end(), due_.begin(), due_.end());
        due_.swap(pulled_);
        pulled_.clear();
    }
    deferred_splits_.clear();
    const bool stepping = backlog_pull_ != kPullAll;
    while (!due_.empty()) {
        // evaluating appends to due_ only through splits and merges, which happen below
        evaluating_.swap(due_);
        due_.clear();
        for (std::size_t k = 0; k < evaluating_.size(); ++k) {
            // short steps: pricing stops at its share of the step (the moves need the rest);
            // what is left stays due for the next
            if (stepping && k % 64 == 63 && mesh.pricingBudgetSpent(stats)) {
                due_.insert(
                    due_.end(), evaluating_.begin() + static_cast<std::ptrdiff_t>(k),
                    evaluating_.end());
                break;
            }
            evaluate(m, evaluating_[k], stats, mesh);
        }
        evaluating_.clear();
        // a budget that binds step after step goes to the largest errors first (splits), and
        // the merges, which only free triangles, take what is left, unless the mesh nears its
        // cap and needs the room; otherwise merges first, so a binding cap has room for splits
        if (backlog_pull_ != kPullAll && !mesh.needsRoom()) {
            doSplits(stats, mesh);
            mesh.splitsDone();
            doMerges(stats, mesh);
        } else {
            doMerges(stats, mesh);
            doSplits(stats, mesh);
            mesh.splitsDone();
        }
        if (mesh.budgetSpent(stats)) {
            stats.budget_exhausted = true;
            if (!stepping) {
                // offered this frame and not priced yet: due as soon as the next frame starts
                for (const DiamondId id : due_)
                    if ((space_->state(id) & (kSplitCandidate | kMergeCandidate)) != 0)
                        heap_.push(id, travel_);
                due_.clear();
            } // (short steps keep them due: the next step prices them first)
            break;
        }
        if (stepping && due_.empty()) {
            // time left in the step: the backlog's next best (merges while they may still be
            // made: pricing what the step must defer again was 5,000 merges a battle crater)
            pullBacklog(!mesh.mergeBudgetSpent(stats));
            due_.swap(pulled_);
            pulled_.clear();
        }
    }
    carried_ = due_.size();
    // what the budget left waits in the backlog, by the priority it had: the next frames price
    // again only the share they may act on, best first
    keepLeft();
    if (!backlog_splits_.empty())
        unmet_ = std::max(unmet_, backlog_splits_.front().priority);
    stats.backlog = static_cast<std::int64_t>(backlogSize() + due_.size());
    return std::max(threshold, unmet_);
}

void SplitMerge::doMerges(FrameStats& stats, SplitMergeMesh& mesh) {
    std::sort(merges_.begin(), merges_.end(), lowerPriority);
    for (const Action& a : merges_) {
        if ((space_->state(a.id) & kMergeCandidate) == 0 || !space_->active(a.id))
            continue;
        if (mesh.mergeBudgetSpent(stats)) {
            defer(a, kMergeCandidate);
            continue;
        }
        mesh.merge(a.id, stats);
    }
    merges_.clear();
}

void SplitMerge::doSplits(FrameStats& stats, SplitMergeMesh& mesh) {
    std::sort(splits_.begin(), splits_.end(), higherPriority);
    for (const Action& a : splits_) {
        if ((space_->state(a.id) & kSplitCandidate) == 0 || space_->active(a.id))
            continue;
        if (mesh.budgetSpent(stats) || !mesh.split(a.id, stats)) {
            defer(a, kSplitCandidate);
            unmet_ = std::max(unmet_, a.priority);
        }
    }
    splits_.clear();
}

void SplitMerge::defer(const Action& a, std::uint8_t kind) {
    if (kind == kSplitCandidate)
        deferred_splits_.push_back(a.id);
    if (backlog_pull_ == kPullAll) {
        // due again as soon as the next frame starts, and priced again then with everything due
        heap_.push(a.id, travel_);
        return;
    }
    // (into the backlog when the frame ends: not priced again in the frame that left it)
    (kind == kSplitCandidate ? left_splits_ : left_merges_).push_back(a);
}

void SplitMerge::keepLeft() {
    for (const Action& a : left_splits_) {
        backlog_splits_.push_back(a);
        std::push_heap(backlog_splits_.begin(), backlog_splits_.end(), lowerPriority);
    }
    for (const Action& a : left_merges_) {
        backlog_merges_.push_back(a);
        std::push_heap(backlog_merges_.begin(), backlog_merges_.end(), higherPriority);
    }
    left_splits_.clear();
    left_merges_.clear();
}

void SplitMerge::setBacklogPull(std::size_t per_frame) {
    backlog_pull_ = per_frame;
    if (per_frame != kPullAll)
        return;
    // back to one whole frame per update: what waited is due at once
    for (const std::vector<Action>* backlog : {&backlog_splits_, &backlog_merges_})
        for (const Action& a : *backlog)
            if ((space_->state(a.id) & (kSplitCandidate | kMergeCandidate)) != 0 &&
                !heap_.contains(a.id))
                heap_.push(a.id, travel_);
    backlog_splits_.clear();
    backlog_merges_.clear();
}

void SplitMerge::pullBacklog(bool merges) {
    // the best of what the budgets left, priced again this frame (still candidates of the same
    // kind, and not re-offered since: those are due or in the heap already)
    // (only up to what the frame can price: candidates the last frame left unpriced come first)
    const std::size_t room = backlog_pull_ > due_.size() ? backlog_pull_ - due_.size() : 0;
    pulled_.clear();
    const auto pull = [&](std::vector<Action>& backlog, auto before, std::uint8_t kind) {
        for (std::size_t k = 0; k < room && !backlog.empty(); ++k) {
            std::pop_heap(backlog.begin(), backlog.end(), before);
            const DiamondId id = backlog.back().id;
            backlog.pop_back();
            if ((space_->state(id) & kind) != 0 && !heap_.contains(id))
                pulled_.push_back(id);
        }
    };
    pull(backlog_splits_, lowerPriority, kSplitCandidate);
    if (merges)
        pull(backlog_merges_, higherPriority, kMergeCandidate);
}

void SplitMerge::followCap(
    const FrameStats& stats, std::int64_t triangles, std::int64_t max_triangles, bool pool_quiet) {
    // The cap wins over tau: raise the threshold a step whenever it (or the block pool) refused a
    // split, lower it a step towards tau when the mesh has room to spare. Each change
    // re-examines the candidates whose keys it made late against the new threshold (spread over
    // the next kRekeyFrames frames by spreadRekey), so the mesh settles on the one a top-down build
    // at the threshold makes: the best for its triangle count, with no rebuild. A step of 10 % up
    // and 5 % down moves the count by less than the gap between kCapLow and the cap.
    double next = threshold_;
    if (stats.refused_by_cap > 0 || triangles > max_triangles) { // or a lower cap
        // each refused split wanted at least two triangles more: a view that changed a lot
        // takes a bigger step (as if the count went with the inverse of the threshold). In
        // short steps the refusals count the backlog tried again step after step, not what the
        // view wants: the smallest step
        const std::int64_t refused = backlog_pull_ == kPullAll ? stats.refused_by_cap : 0;
        const double wanted = static_cast<double>(triangles + 2 * refused);
        const double ratio = wanted / (kCapTarget * static_cast<double>(max_triangles));
        next = threshold_ * std::clamp(ratio, kCapStepUp, kCapStepMax);
    } else if (
        threshold_ > tau_ &&
        static_cast<double>(triangles) < kCapLow * static_cast<double>(max_triangles) &&
        pool_quiet) // nor the pool lately
        next = std::max(tau_, threshold_ / kCapStepDown);
    if (next == threshold_ || !rekey_.empty()) // one move at a time
        return;
    // A key says when a candidate's priority may first cross the threshold. A higher threshold
    // leaves a split candidate's key early (it is priced a little sooner than it must be: still
    // right) and a merge candidate's late; a lower one the other way round. So only the kind
    // whose keys went late is re-examined: about half the heap, not all of it.
    const std::uint8_t late = next > threshold_ ? kMergeCandidate : kSplitCandidate;
    rekey_from_ = threshold_;
    threshold_ = next;
    rekey_.clear();
    for (std::size_t i = 0; i < heap_.size(); ++i)
        if ((space_->state(heap_.at(i).id) & late) != 0)
            rekey_.push_back(heap_.at(i).id);
    rekey_quota_ = std::max(rekey_.size() / kRekeyFrames + 1, kRekeyAtOnce);
}

void SplitMerge::spreadRekey() {
    // the candidates keyed against the old threshold, re-examined over kRekeyFrames frames
    // rather than all in one (a few hundred thousand at a binding cap: tens of milliseconds);
    // a small heap goes at once
    for (std::size_t k = 0; k < rekey_quota_ && !rekey_.empty(); ++k) {
        const DiamondId id = rekey_.back();
        rekey_.pop_back();
        if (!heap_.contains(id))
            continue; // re-examined since, so keyed against the new threshold
        heap_.remove(id);
        due_.push_back(id);
    }
}

void SplitMerge::chunkMoved(int g, std::int32_t from, std::int32_t to) {
    const auto diamonds = static_cast<std::uint32_t>(kGrainDiamonds[static_cast<std::size_t>(g)]);
    for (std::uint32_t slot = 0; slot < diamonds; ++slot) {
        const DiamondId old_id = DiamondSpace::pooledId(g, from, slot);
        const DiamondId new_id = DiamondSpace::pooledId(g, to, slot);
        if (space_->state(new_id) != 0 && heap_.contains(old_id))
            heap_.rename(old_id, new_id);
    }
}

void SplitMerge::chunksCut(
    int g, std::size_t end, std::span<const std::pair<std::int32_t, std::int32_t>> moved) {
    // renamed if the chunk moved; dropped if it was free (a released grain's watched ids lost
    // their state)
    // whether the id goes (renamed in place when it stays)
    const auto drop = [&](DiamondId& id) {
        if (id < kPooledIds || DiamondSpace::grainOfId(id) != g)
            return false;
        const std::int32_t chunk = DiamondSpace::chunkOfId(id, g);
        if (static_cast<std::size_t>(chunk) < end)
            return false;
        for (const auto& [from, to] : moved)
            if (from == chunk) {
                id = DiamondSpace::pooledId(g, to, DiamondSpace::slotOfId(id, g));
                return false;
            }
        return true;
    };
    const auto rename = [&](std::vector<DiamondId>& ids) { std::erase_if(ids, drop); };
    rename(watched_);
    rename(rekey_);
    rename(deferred_splits_);
    rename(due_); // (short steps carry candidates not yet priced over to the next)
    carried_ = 0;
    const auto rename_actions = [&](std::vector<Action>& actions, auto before) {
        std::erase_if(actions, [&](Action& a) { return drop(a.id); });
        std::make_heap(actions.begin(), actions.end(), before);
    };
    rename_actions(backlog_splits_, lowerPriority);
    rename_actions(backlog_merges_, higherPriority);
}

} // namespace terrain::roam
