// The tessellator's triangle budget at a rebuild: when the cap binds, the budget wins over tau,
// and the rebuild spends the cap best-first and starts from the error left. Split/merge then
// refines to a threshold that SplitMerge::followCap moves (split_merge.h), so the mesh is always
// the one a top-down build at the threshold makes, with no periodic rebuild.

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
        const Diamond root = emitter_.tileRoot(tile);
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

} // namespace terrain::roam
