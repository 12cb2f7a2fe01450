// The tessellator's triangle budget: when the cap binds, the budget wins over tau. A rebuild
// spends the cap best-first and starts from the error left; split/merge then refines to a
// threshold that followCap raises when the cap refuses splits and lowers towards tau when the
// mesh has room, re-examining the candidates over a few frames (spreadRekey), so the mesh is
// always the one a top-down build at the threshold makes, with no periodic rebuild.

#include "tessellator_internal.h"

#include <terrain/roam/tessellator.h>

#include <algorithm>

namespace terrain::roam {

using namespace detail;

double Tessellator::refineBestFirst(const ViewMetric& m, std::int64_t target, FrameStats& stats) {
    best_first_.clear();
    ++use_epoch_; // blocks a refused top-down pass filled the pool with may go again
    const auto by_priority = [](const auto& a, const auto& b) { return a.first < b.first; };
    // the heap holds unsplit diamonds only: a split one (forced by a finer split) is walked
    // through to its halves at once
    auto push = [&](auto&& self, const Triangle& t) -> void {
        if (t.level >= kFinestTriangleLevel)
            return;
        const LatticePoint p = splitPoint(t);
        DiamondId id = idOf(p);
        if (id == kNoDiamond) {
            // a detail cell whose block is not resident: materialised only if it may be split
            if (blocks_.recordOf(p.x / kLatticePerCell, p.y / kLatticePerCell) < 0 ||
                isGridVertex(p) || recordPriority(m, diamondAt(p)) <= options_.tau_pixels)
                return;
            id = resolve(p);
            if (id == kNoDiamond) {
                // the pool refused: its bound still counts (popping it refuses again and stops)
                best_first_.push_back({recordPriority(m, diamondAt(p)), t});
                std::push_heap(best_first_.begin(), best_first_.end(), by_priority);
                return;
            }
        } else if (id >= kPooled) {
            markUsed(id);
        }
        if (active(id)) {
            const auto halves = splitTriangle(t);
            self(self, halves[0]);
            self(self, halves[1]);
            return;
        }
        ++stats.evaluations;
        const double pr = priority(m, diamondAt(p), id);
        if (pr <= options_.tau_pixels)
            return;
        best_first_.push_back({pr, t});
        std::push_heap(best_first_.begin(), best_first_.end(), by_priority);
    };
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            push(push, triangleOf(root, a));
    }
    while (!best_first_.empty() && triangles_ < target) {
        std::pop_heap(best_first_.begin(), best_first_.end(), by_priority);
        const auto entry = best_first_.back();
        best_first_.pop_back();
        const LatticePoint p = splitPoint(entry.second);
        if (active(idOf(p))) { // forced since it was pushed
            push(push, entry.second);
            continue;
        }
        const DiamondId id = resolve(p);
        if (id == kNoDiamond || !activate(diamondAt(p), id, false, stats)) {
            if (refused_by_cap_) { // still wanted: it bounds the error
                best_first_.push_back(entry);
                std::push_heap(best_first_.begin(), best_first_.end(), by_priority);
                break;
            }
            continue;
        }
        const auto halves = splitTriangle(entry.second);
        push(push, halves[0]);
        push(push, halves[1]);
    }
    // every unsplit diamond is in the heap or below an entry (priorities only fall from parent
    // to child), so the largest entry bounds the mesh's error; a forced split since an entry
    // was pushed only splits more
    return best_first_.empty() ? options_.tau_pixels : best_first_.front().first;
}

void Tessellator::followCap(const FrameStats& stats) {
    // The cap wins over tau: raise the threshold a step whenever it (or the block pool) refused a
    // split, lower it a
    // step towards tau when the mesh has room to spare. Each change re-examines every candidate
    // against the new threshold (spread over the next kRekeyFrames frames by spreadRekey), so
    // the mesh settles on the one a top-down build at the threshold makes: the best for its
    // triangle count, with no rebuild. A step of 10 % up and 5 % down moves the count by less
    // than the gap between kCapLow and the cap.
    double next = threshold_;
    if (stats.refused_by_cap > 0 || triangles_ > options_.max_triangles) { // or a lower cap
        // each refused split wanted at least two triangles more: a view that changed a lot
        // takes a bigger step (as if the count went with the inverse of the threshold)
        const double wanted = static_cast<double>(triangles_ + 2 * stats.refused_by_cap);
        const double ratio = wanted / (kCapTarget * static_cast<double>(options_.max_triangles));
        next = threshold_ * std::clamp(ratio, kCapStepUp, kCapStepMax);
    } else if (
        threshold_ > options_.tau_pixels &&
        static_cast<double>(triangles_) < kCapLow * static_cast<double>(options_.max_triangles) &&
        frame_ > last_pool_refusal_ + kPoolQuietFrames) // nor the pool lately
        next = std::max(options_.tau_pixels, threshold_ / kCapStepDown);
    if (next == threshold_ || !rekey_.empty()) // one move at a time
        return;
    rekey_from_ = threshold_;
    threshold_ = next;
    rekey_.clear();
    for (std::size_t i = 0; i < heap_.size(); ++i)
        rekey_.push_back(heap_.at(i).id);
    rekey_quota_ = std::max(rekey_.size() / kRekeyFrames + 1, kRekeyAtOnce);
}

void Tessellator::spreadRekey() {
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

} // namespace terrain::roam
