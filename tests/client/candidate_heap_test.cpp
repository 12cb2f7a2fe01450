// The candidate heap alone: key order through pushes, re-keys and removals, over every id range.

#include <terrain/roam/candidate_heap.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <vector>

namespace terrain::testing {
namespace {

TEST(RoamCandidateHeap, PopsInKeyOrderThroughPushesReKeysAndRemovals) {
    roam::CandidateHeap heap;
    heap.resizeIds(250, {100, 100, 100});      // every id range: eager and the pooled ones
    std::map<std::uint32_t, double> reference; // id -> key
    std::mt19937_64 rng(12);
    std::uniform_int_distribution<std::uint32_t> any_id(0, 549);
    std::uniform_real_distribution<double> any_key(0.0, 100.0);
    for (int step = 0; step < 20000; ++step) {
        const std::uint32_t n = any_id(rng);
        const std::uint32_t id = n < 250 ? n
                                         : roam::CandidateHeap::kPooledIds +
                                               roam::CandidateHeap::kRangeBase[(n - 250) / 100] +
                                               (n - 250) % 100;
        if (step % 3 == 2 && heap.contains(id)) {
            heap.remove(id);
            reference.erase(id);
        } else {
            const double key = any_key(rng) + (step % 7 == 0 ? 1e5 : 0.0); // far along too
            heap.push(id, key);                                            // a held id is re-keyed
            const double stored = roam::CandidateHeap::storedKey(key);
            ASSERT_LE(stored, key); // never due later than asked
            ASSERT_LE(key - stored, 2.5e-7 * std::max(1.0, key)) << key; // one float step
            reference[id] = stored;
        }
        ASSERT_EQ(heap.size(), reference.size());
        if (!reference.empty()) {
            double lowest = 1e12;
            for (const auto& [held, key] : reference)
                lowest = std::min(lowest, key);
            ASSERT_EQ(heap.top().key, lowest);
        }
    }
    for (const auto& [id, key] : reference)
        EXPECT_TRUE(heap.contains(id));
    double last = -1.0;
    while (!heap.empty()) {
        const auto top = heap.top();
        EXPECT_GE(top.key, last);
        EXPECT_EQ(reference.at(top.id), top.key);
        last = top.key;
        heap.remove(top.id);
        EXPECT_FALSE(heap.contains(top.id));
    }
}

} // namespace
} // namespace terrain::testing
