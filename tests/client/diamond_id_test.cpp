// The diamond-id layout alone: ranges, slots and their round trips.

#include <terrain/roam/diamond_id.h>

#include <gtest/gtest.h>

namespace terrain::roam {
namespace {

TEST(DiamondId, PooledIdsRoundTripThroughTheirRangeAndSlot) {
    for (int range = 0; range < kPooledRanges; ++range) {
        const std::size_t last =
            (range + 1 < kPooledRanges ? kRangeBase[static_cast<std::size_t>(range) + 1]
                                       : kNoDiamond - kPooledIds) -
            kRangeBase[static_cast<std::size_t>(range)] - 1;
        for (const std::size_t slot : {std::size_t{0}, std::size_t{1}, std::size_t{4096}, last}) {
            const DiamondId id = pooledIdAt(range, slot);
            EXPECT_TRUE(isPooled(id)) << range << " " << slot;
            EXPECT_EQ(rangeOf(id), range) << slot;
            EXPECT_EQ(pooledSlot(id, range), slot);
        }
    }
    // the eager ids and the sentinel are not pooled
    EXPECT_FALSE(isPooled(0));
    EXPECT_FALSE(isPooled(kPooledIds - 1));
    EXPECT_FALSE(isPooled(kNoDiamond));
    EXPECT_EQ(pooledIdAt(0, 0), kPooledIds);
}

} // namespace
} // namespace terrain::roam
