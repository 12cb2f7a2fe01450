// The block pool alone, on a cratered world's detail records: chunks taken and freed, the clock's
// choice of a block to evict, the idle sweep, and the compaction of the finer grains' arrays.

#include "support/terrain_builders.h"

#include <terrain/roam/block_pool.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <set>
#include <utility>
#include <vector>

namespace terrain::testing {
namespace {

using roam::BlockPool;
using roam::DetailBlocks;
using roam::DiamondSpace;
using roam::kGrains;

/// A cratered world's detail records, with `n` of them given blocks, adopted by a pool, and a
/// diamond space sized to follow.
struct PoolWorld {
    explicit PoolWorld(int n) {
        Terrain t = makeHills(7);
        CraterSeries s;
        s.seed = 7;
        s.count = 60;
        applyAll(t, randomCraters(t.spec(), s));
        blocks.reset(t);
        EXPECT_GE(blocks.recordCount(), n) << "the world has too few detail cells for the test";
        space.reset(
            static_cast<std::uint32_t>(t.spec().paddedWidth() * t.spec().paddedHeight()),
            roam::BoundsCodec(t.spec().metresPerUnit()));
        for (std::int32_t r = 0; r < blocks.recordCapacity() && std::ssize(made) < n; ++r) {
            if (!blocks.recordInUse(r))
                continue;
            const std::int32_t b = blocks.materialise(r);
            pool.resizeBlocks(static_cast<std::size_t>(blocks.capacity()));
            pool.adoptBlock(b, 1);
            made.push_back(b);
        }
        follow();
    }
    /// The space follows the pool's and the records' sizes (what the tessellator does).
    void follow() {
        space.resizeCentres(static_cast<std::size_t>(blocks.recordCapacity()));
        for (int g = 0; g < kGrains; ++g)
            space.resizeChunks(g, pool.chunkCount(g));
    }
    DetailBlocks blocks;
    BlockPool pool;
    DiamondSpace space;
    std::vector<std::int32_t> made;
};

TEST(RoamBlockPool, AFinerGrainTakesTheLowestFreeChunkAndGrowsOnlyWhenNoneIsFree) {
    PoolWorld w(4);
    for (const std::int32_t b : w.made) {
        EXPECT_EQ(w.pool.chunkOf(b, 0), b) << "grain 0's chunk is the block";
        EXPECT_EQ(w.pool.chunkOf(b, 1), -1);
    }
    std::vector<std::int32_t> chunks;
    for (const std::int32_t b : w.made)
        chunks.push_back(w.pool.takeChunk(b, 1, 2));
    EXPECT_EQ(chunks, (std::vector<std::int32_t>{0, 1, 2, 3}));
    EXPECT_EQ(w.pool.chunkCount(1), 4u);
    w.pool.releaseChunk(w.made[3], 1);
    w.pool.releaseChunk(w.made[1], 1);
    EXPECT_EQ(w.pool.chunkOf(w.made[1], 1), -1);
    EXPECT_EQ(w.pool.blockOf(1, 1), -1);
    EXPECT_EQ(w.pool.takeChunk(w.made[3], 1, 3), 1) << "the lowest free chunk first";
    EXPECT_EQ(w.pool.takeChunk(w.made[1], 1, 3), 3);
    EXPECT_EQ(w.pool.chunkCount(1), 4u) << "no chunk added while one was free";
    EXPECT_EQ(w.pool.blockOf(1, 1), w.made[3]);
    EXPECT_EQ(w.pool.takeChunk(w.made[0], 2, 3), 0);
    EXPECT_EQ(w.pool.chunkCount(2), 1u);
    EXPECT_EQ(w.pool.heights(2, 0).size(), 208u);
}

TEST(RoamBlockPool, TheClockSkipsBlocksUsedThisEpochOrReferencedByADiamond) {
    PoolWorld w(4);
    const std::uint64_t epoch = 5;
    w.pool.markBlockUsed(w.made[1], epoch);
    // a candidate in block 2's coarse grain, block 3's centre split
    w.space.state(DiamondSpace::pooledId(0, w.pool.chunkOf(w.made[2], 0), 3)) =
        DiamondSpace::kSplitCandidate;
    w.space.state(w.space.centreId(w.blocks.recordOfBlock(w.made[3]))) = DiamondSpace::kActive;
    EXPECT_FALSE(w.pool.referenced(w.made[0], w.blocks, w.space));
    EXPECT_FALSE(w.pool.referenced(w.made[1], w.blocks, w.space));
    EXPECT_TRUE(w.pool.referenced(w.made[2], w.blocks, w.space));
    EXPECT_TRUE(w.pool.referenced(w.made[3], w.blocks, w.space));
    EXPECT_EQ(w.pool.evictionVictim(w.blocks, w.space, epoch), w.made[0]);
    // once the only free block is gone, nothing else may go
    w.pool.releaseChunk(w.made[0], 0);
    w.pool.releaseBlock(w.made[0]);
    w.blocks.release(w.made[0]);
    EXPECT_EQ(w.pool.evictionVictim(w.blocks, w.space, epoch), -1);
    // a finer grain's state pins the block too
    w.space.state(w.space.centreId(w.blocks.recordOfBlock(w.made[3]))) = 0;
    const std::int32_t fine = w.pool.takeChunk(w.made[3], 2, 1);
    w.follow();
    w.space.state(DiamondSpace::pooledId(2, fine, 100)) = DiamondSpace::kActive;
    EXPECT_EQ(w.pool.evictionVictim(w.blocks, w.space, epoch), -1);
    w.space.state(DiamondSpace::pooledId(2, fine, 100)) = 0;
    EXPECT_EQ(w.pool.evictionVictim(w.blocks, w.space, epoch), w.made[3]);
}

TEST(RoamBlockPool, TheSweepReleasesIdleBlocksWholeAndIdleFinerGrainsAlone) {
    PoolWorld w(3);
    // block 0: idle, unreferenced -> goes whole; block 1: in use, its grain 2 idle -> grain 2
    // goes; block 2: idle but referenced -> stays
    for (const std::int32_t b : w.made) {
        w.pool.takeChunk(b, 1, 10);
        w.pool.takeChunk(b, 2, 10);
    }
    w.follow();
    w.pool.markUsed(1, w.pool.chunkOf(w.made[1], 1), 190);
    w.space.state(DiamondSpace::pooledId(1, w.pool.chunkOf(w.made[2], 1), 0)) =
        DiamondSpace::kMergeCandidate;
    std::vector<BlockPool::Release> out;
    w.pool.sweepIdle(w.blocks, w.space, 200, 50, out);
    std::set<std::pair<std::int32_t, int>> got;
    for (const BlockPool::Release& r : out)
        got.insert({r.block, r.grain});
    EXPECT_EQ(
        got,
        (std::set<std::pair<std::int32_t, int>>{{w.made[0], 0}, {w.made[1], 2}, {w.made[2], 2}}))
        << "block 2's grain 1 holds a candidate; its grain 2 does not";
    w.pool.sweepIdle(w.blocks, w.space, 200, 0, out);
    EXPECT_TRUE(out.empty()) << "idle 0: nothing goes";
}

struct RecordingMover final : BlockPool::Mover {
    void chunkMoved(int g, std::int32_t from, std::int32_t to) override {
        moves.push_back({g, {from, to}});
    }
    void chunksCut(
        int g,
        std::size_t end,
        std::span<const std::pair<std::int32_t, std::int32_t>> moved) override {
        cuts.push_back({g, end});
        cut_moves += moved.size();
    }
    std::vector<std::pair<int, std::pair<std::int32_t, std::int32_t>>> moves;
    std::vector<std::pair<int, std::size_t>> cuts;
    std::size_t cut_moves = 0;
};

TEST(RoamBlockPool, TrimMovesTheHighestChunksIntoTheLowestFreeOnesAndCutsTheFreeEnd) {
    constexpr int kBlocks = 300;
    PoolWorld w(kBlocks);
    ASSERT_EQ(std::ssize(w.made), kBlocks);
    for (const std::int32_t b : w.made)
        w.pool.takeChunk(b, 1, 1);
    // each chunk's heights and segment say whose they are
    for (const std::int32_t b : w.made) {
        const std::int32_t c = w.pool.chunkOf(b, 1);
        for (std::uint32_t& h : w.pool.heights(1, c))
            h = static_cast<std::uint32_t>(b) * 1000u;
        w.pool.base(1, c) = -b;
        w.pool.segment(1, c) = b + 7;
    }
    // free all but every fourth of the first half: 38 live chunks left below 150, 150 live above
    std::map<std::int32_t, bool> live;
    for (int i = 0; i < kBlocks; ++i) {
        const bool keep = i >= kBlocks / 2 || i % 4 == 0;
        live[w.made[static_cast<std::size_t>(i)]] = keep;
        if (!keep)
            w.pool.releaseChunk(w.made[static_cast<std::size_t>(i)], 1);
    }
    std::size_t live_count = 0;
    for (const auto& [b, keep] : live)
        live_count += keep ? 1 : 0;
    RecordingMover mover;
    w.pool.trim(mover);
    ASSERT_FALSE(mover.moves.empty()) << "a quarter free and 256 chunks or more: trim moves";
    for (const auto& [g, m] : mover.moves) {
        EXPECT_EQ(g, 1);
        EXPECT_LT(m.second, m.first) << "down, never up";
    }
    ASSERT_EQ(mover.cuts.size(), 1u);
    EXPECT_EQ(mover.cuts[0].second, live_count) << "dense after the trim: the free end is cut";
    EXPECT_EQ(mover.cut_moves, mover.moves.size());
    EXPECT_EQ(w.pool.chunkCount(1), live_count);
    EXPECT_EQ(w.pool.movedCount(), std::ssize(mover.moves));
    // every live block still finds its own heights, base and segment through its chunk
    for (const auto& [b, keep] : live) {
        const std::int32_t c = w.pool.chunkOf(b, 1);
        if (!keep) {
            EXPECT_EQ(c, -1);
            continue;
        }
        ASSERT_GE(c, 0);
        ASSERT_LT(static_cast<std::size_t>(c), live_count);
        EXPECT_EQ(w.pool.blockOf(1, c), b);
        EXPECT_EQ(w.pool.heights(1, c)[55], static_cast<std::uint32_t>(b) * 1000u);
        EXPECT_EQ(w.pool.base(1, c), -b);
        EXPECT_EQ(w.pool.segment(1, c), b + 7);
    }
    RecordingMover again;
    w.pool.trim(again);
    EXPECT_TRUE(again.moves.empty() && again.cuts.empty()) << "a dense grain is left alone";
}

} // namespace
} // namespace terrain::testing
