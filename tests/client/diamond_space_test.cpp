// The diamond space alone: which id is which, per-id state, stored bounds, and chunks that move.

#include <terrain/roam/diamond_space.h>

#include <gtest/gtest.h>

#include <cstdint>

namespace terrain::testing {
namespace {

using roam::DiamondBounds;
using roam::DiamondId;
using roam::DiamondSpace;
using roam::kGrainDiamonds;
using roam::kGrains;

DiamondSpace smallSpace() {
    DiamondSpace space;
    space.reset(100, roam::BoundsCodec(1.0 / 1024.0));
    space.resizeCentres(20);
    for (int g = 0; g < kGrains; ++g)
        space.resizeChunks(g, 4);
    return space;
}

TEST(RoamDiamondSpace, IdsNameTheGridTheCentresAndEachGrainsChunks) {
    const DiamondSpace space = smallSpace();
    EXPECT_TRUE(space.isGrid(99));
    EXPECT_FALSE(space.isCentre(99));
    EXPECT_TRUE(space.isCentre(space.centreId(0)));
    EXPECT_EQ(space.centreId(0), 100u);
    EXPECT_EQ(space.recordOfCentre(space.centreId(19)), 19);
    EXPECT_EQ(space.eagerCount(), 120u);
    for (int g = 0; g < kGrains; ++g) {
        EXPECT_EQ(space.chunkCount(g), 4u);
        EXPECT_EQ(space.pooledCounts()[static_cast<std::size_t>(g)], 4u * kGrainDiamonds[g]);
        const auto last = static_cast<std::uint32_t>(kGrainDiamonds[g] - 1);
        for (const std::int32_t chunk : {0, 3})
            for (const std::uint32_t slot : {0u, last}) {
                const DiamondId id = DiamondSpace::pooledId(g, chunk, slot);
                EXPECT_FALSE(space.isGrid(id));
                EXPECT_FALSE(space.isCentre(id));
                EXPECT_EQ(DiamondSpace::grainOfId(id), g);
                EXPECT_EQ(DiamondSpace::chunkOfId(id, g), chunk);
                EXPECT_EQ(DiamondSpace::slotOfId(id, g), slot);
            }
    }
}

TEST(RoamDiamondSpace, StatesAreOnePerIdAndClearTogether) {
    DiamondSpace space = smallSpace();
    const DiamondId ids[] = {
        0, 99, space.centreId(5), DiamondSpace::pooledId(0, 1, 2),
        DiamondSpace::pooledId(2, 3, 191)};
    for (const DiamondId id : ids)
        EXPECT_FALSE(space.active(id));
    space.state(ids[0]) = DiamondSpace::kActive;
    space.state(ids[2]) = DiamondSpace::kSplitCandidate;
    space.state(ids[4]) = DiamondSpace::kActive | DiamondSpace::kMergeCandidate;
    EXPECT_TRUE(space.active(ids[0]));
    EXPECT_FALSE(space.active(ids[1]));
    EXPECT_FALSE(space.active(ids[2]));
    EXPECT_EQ(space.state(ids[2]), DiamondSpace::kSplitCandidate);
    EXPECT_FALSE(space.active(ids[3]));
    EXPECT_TRUE(space.active(ids[4]));
    EXPECT_FALSE(space.active(roam::kNoDiamond));
    EXPECT_TRUE(space.chunkReferenced(2, 3));
    EXPECT_FALSE(space.chunkReferenced(2, 2));
    space.clearStates();
    for (const DiamondId id : ids)
        EXPECT_EQ(space.state(id), 0);
}

TEST(RoamDiamondSpace, StoredBoundsHoldTheExactOnesAndSayWhenTheyChange) {
    DiamondSpace space = smallSpace();
    const DiamondBounds exact{0.123f, -4.56f, 7.89f};
    for (const DiamondId id : {DiamondId{7}, DiamondSpace::pooledId(1, 2, 30)}) {
        EXPECT_TRUE(space.storeBounds(id, exact));
        EXPECT_FALSE(space.storeBounds(id, exact)) << "the same bounds again changed nothing";
        const DiamondBounds stored = space.storedBounds(id);
        EXPECT_GE(stored.delta, exact.delta);
        EXPECT_LE(stored.zlo, exact.zlo);
        EXPECT_GE(stored.zhi, exact.zhi);
        EXPECT_EQ(stored.delta, space.codec().outward(exact).delta);
        EXPECT_TRUE(space.storeBounds(id, {0.5f, -4.56f, 7.89f}));
    }
    // neighbours are untouched
    EXPECT_EQ(space.storedBounds(8).delta, 0.0f);
    EXPECT_EQ(space.storedBounds(DiamondSpace::pooledId(1, 2, 31)).delta, 0.0f);
}

TEST(RoamDiamondSpace, AMovedChunkTakesItsStatesAndBoundsAndLeavesNoState) {
    DiamondSpace space = smallSpace();
    const int g = 2;
    for (std::uint32_t slot = 0; slot < 192; slot += 7) {
        space.state(DiamondSpace::pooledId(g, 3, slot)) = DiamondSpace::kActive;
        space.storeBounds(
            DiamondSpace::pooledId(g, 3, slot), {0.01f * static_cast<float>(slot), -1.0f, 1.0f});
    }
    space.moveChunk(g, 3, 1);
    EXPECT_FALSE(space.chunkReferenced(g, 3));
    EXPECT_TRUE(space.chunkReferenced(g, 1));
    for (std::uint32_t slot = 0; slot < 192; ++slot) {
        const DiamondId to = DiamondSpace::pooledId(g, 1, slot);
        EXPECT_EQ(space.active(to), slot % 7 == 0) << slot;
        if (slot % 7 == 0) {
            EXPECT_EQ(
                space.storedBounds(to).delta,
                space.codec().outward({0.01f * static_cast<float>(slot), -1.0f, 1.0f}).delta);
        }
    }
    // a cut: the chunks past the end go, the rest stay
    space.fitChunks(g, 2);
    EXPECT_EQ(space.chunkCount(g), 2u);
    EXPECT_TRUE(space.active(DiamondSpace::pooledId(g, 1, 14)));
    // a grown chunk starts clear
    space.resizeChunks(g, 4);
    EXPECT_FALSE(space.chunkReferenced(g, 3));
}

} // namespace
} // namespace terrain::testing
