// The bounds update alone, on a cratered world with every detail block resident in all its
// grains: an op's passes (centres and grid at once, the stale blocks within a budget) end where a
// whole-map pass over the new surface starts, the ids reported as moved are exactly those whose
// bounds changed, heights run ahead of bounds, and a single block's pass is not reused across a
// change of the surface.

#include "support/roam_parts.h"

#include <terrain/fixed_point.h>
#include <terrain/roam/bounds_update.h>
#include <terrain/task_runner.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <set>
#include <utility>
#include <vector>

namespace terrain::testing {
namespace {

TEST(RoamBoundsUpdate, AnOpsPassesEndWhereAWholeMapPassOverTheNewSurfaceStarts) {
    RoamParts w(crateredWorld());
    const OpRequest op = craterKeepingTheRecords(w);
    w.apply(op);
    ASSERT_GT(w.bounds.staleCount(), 0u) << "the op left no resident block stale";
    w.bounds.freshenHeights();
    while (w.bounds.staleCount() > 0)
        w.bounds.drainStale(3);

    Terrain after = crateredWorld();
    applyAll(after, {op});
    const RoamParts fresh(after);
    ASSERT_EQ(w.terrain.worldHash(), fresh.terrain.worldHash());
    EXPECT_EQ(w.everyHeight(), fresh.everyHeight());
    const std::vector<DiamondBounds> got = w.everyBound();
    const std::vector<DiamondBounds> want = fresh.everyBound();
    ASSERT_EQ(got.size(), want.size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < got.size(); ++i)
        differ +=
            got[i].delta != want[i].delta || got[i].zlo != want[i].zlo || got[i].zhi != want[i].zhi
                ? 1
                : 0;
    EXPECT_EQ(differ, 0u) << "of " << got.size() << " diamonds' bounds";
}

TEST(RoamBoundsUpdate, TheIdsReportedAsMovedAreExactlyThoseWhoseBoundsChanged) {
    RoamParts w(crateredWorld());
    const std::vector<DiamondId> ids = w.everyId();
    const std::size_t eager =
        w.space.gridCount() + static_cast<std::size_t>(w.blocks.recordCapacity());
    const auto changed = [&](const std::vector<DiamondBounds>& before,
                             const std::vector<DiamondBounds>& now, std::size_t from,
                             std::size_t to) {
        std::set<DiamondId> c;
        for (std::size_t i = from; i < to; ++i)
            if (before[i].delta != now[i].delta || before[i].zlo != now[i].zlo ||
                before[i].zhi != now[i].zhi)
                c.insert(ids[i]);
        return c;
    };

    // the grid's and the centres' at once
    const std::vector<DiamondBounds> before = w.everyBound();
    w.apply(craterKeepingTheRecords(w));
    const std::vector<DiamondBounds> eager_done = w.everyBound();
    const std::set<DiamondId> eager_moved = changed(before, eager_done, 0, eager);
    EXPECT_FALSE(eager_moved.empty());
    EXPECT_EQ(std::set<DiamondId>(w.bounds.moved().begin(), w.bounds.moved().end()), eager_moved);
    EXPECT_TRUE(changed(before, eager_done, eager, ids.size()).empty())
        << "the blocks' bounds moved before their turn in the stale queue";

    // the blocks', a budget at a time
    std::set<DiamondId> pooled_moved;
    while (w.bounds.staleCount() > 0) {
        w.bounds.drainStale(2);
        pooled_moved.insert(w.bounds.moved().begin(), w.bounds.moved().end());
    }
    const std::set<DiamondId> want = changed(eager_done, w.everyBound(), eager, ids.size());
    EXPECT_FALSE(want.empty());
    EXPECT_EQ(pooled_moved, want);
}

TEST(RoamBoundsUpdate, HeightsFollowTheOpBeforeTheBoundsDo) {
    RoamParts w(crateredWorld());
    const std::vector<std::int64_t> heights_before = w.everyHeight();
    const std::vector<DiamondBounds> bounds_before = w.everyBound();
    const std::size_t eager =
        w.space.gridCount() + static_cast<std::size_t>(w.blocks.recordCapacity());
    const OpRequest op = craterKeepingTheRecords(w);
    w.apply(op);
    w.bounds.freshenHeights();

    Terrain after = crateredWorld();
    applyAll(after, {op});
    const RoamParts fresh(after);
    EXPECT_NE(w.everyHeight(), heights_before);
    EXPECT_EQ(w.everyHeight(), fresh.everyHeight()) << "a stale block's heights are not the op's";
    const std::vector<DiamondBounds> now = w.everyBound();
    for (std::size_t i = eager; i < now.size(); ++i)
        ASSERT_TRUE(
            now[i].delta == bounds_before[i].delta && now[i].zlo == bounds_before[i].zlo &&
            now[i].zhi == bounds_before[i].zhi)
            << "a block's bounds moved outside the stale queue's budget";
}

TEST(RoamBoundsUpdate, ABlocksOwnPassIsNotReusedOnceTheSurfaceChanged) {
    RoamParts w(crateredWorld());
    // a block bounded alone: its own pass is kept for its next grain
    const OpRequest op = craterKeepingTheRecords(w);
    const DetailBlocks::CellXY cell{
        static_cast<std::int32_t>(op.x / w.terrain.spec().spacingMetres()),
        static_cast<std::int32_t>(op.y / w.terrain.spec().spacingMetres())};
    const std::int32_t block = w.blocks.blockOf(cell.x, cell.y);
    ASSERT_GE(block, 0);
    w.bounds.boundGrains(block, 1u);
    w.change(op);
    w.bounds.boundGrains(block, 7u);

    Terrain after = crateredWorld();
    applyAll(after, {op});
    const RoamParts fresh(after);
    for (int g = 0; g < kGrains; ++g) {
        const std::int32_t chunk = w.pool.chunkOf(block, g);
        ASSERT_EQ(chunk, fresh.pool.chunkOf(block, g));
        EXPECT_EQ(w.pool.base(g, chunk), fresh.pool.base(g, chunk)) << "grain " << g;
        for (std::int32_t slot = 0; slot < roam::kGrainDiamonds[static_cast<std::size_t>(g)];
             ++slot) {
            const DiamondId id = DiamondSpace::pooledId(g, chunk, static_cast<std::uint32_t>(slot));
            EXPECT_EQ(w.bounds.bounds(id).delta, fresh.bounds.bounds(id).delta)
                << "grain " << g << " slot " << slot;
        }
    }
}

} // namespace
} // namespace terrain::testing

namespace terrain::testing {
namespace {

// The stale pass spread over threads (squares of cells in groups, a kernel each) leaves the state
// the serial pass leaves: every height and bound, the ids reported moved in the same order, and
// the tiles' vertex versions and change marks (what a renderer uploads).
TEST(RoamBoundsUpdate, ASpreadPassLeavesWhatTheSerialPassLeaves) {
    RoamParts serial(crateredWorld());
    RoamParts spread(crateredWorld());
    ThreadPool pool(3);
    spread.bounds.setTaskRunner(&pool);
    const OpRequest op = craterKeepingTheRecords(serial);
    serial.apply(op);
    spread.apply(op);
    ASSERT_GE(spread.bounds.staleCount(), 64u) << "too few stale blocks to spread";
    for (std::int32_t t = 0; t < serial.emitter.tileCount(); ++t) {
        serial.emitter.vertices().take(t);
        spread.emitter.vertices().take(t);
    }
    while (serial.bounds.staleCount() > 0 || spread.bounds.staleCount() > 0) {
        serial.bounds.drainStale(200);
        spread.bounds.drainStale(200);
        ASSERT_TRUE(std::equal(
            serial.bounds.moved().begin(), serial.bounds.moved().end(),
            spread.bounds.moved().begin(), spread.bounds.moved().end()));
    }
    EXPECT_GT(spread.bounds.parallelPasses(), 0);
    EXPECT_EQ(serial.bounds.parallelPasses(), 0);
    EXPECT_EQ(spread.everyHeight(), serial.everyHeight());
    const std::vector<DiamondBounds> a = serial.everyBound();
    const std::vector<DiamondBounds> b = spread.everyBound();
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i)
        ASSERT_TRUE(a[i].delta == b[i].delta && a[i].zlo == b[i].zlo && a[i].zhi == b[i].zhi)
            << "diamond " << i;
    std::size_t marked = 0;
    for (std::int32_t t = 0; t < serial.emitter.tileCount(); ++t) {
        const roam::TileVertexArrays& va = serial.emitter.vertices();
        const roam::TileVertexArrays& vb = spread.emitter.vertices();
        EXPECT_EQ(va.version(t), vb.version(t)) << "tile " << t;
        EXPECT_EQ(va.allChanged(t), vb.allChanged(t)) << "tile " << t;
        const auto ra = va.changes(t);
        const auto rb = vb.changes(t);
        ASSERT_EQ(ra.size(), rb.size()) << "tile " << t;
        for (std::size_t k = 0; k < ra.size(); ++k)
            ASSERT_TRUE(ra[k].begin == rb[k].begin && ra[k].end == rb[k].end) << "tile " << t;
        marked += ra.size();
    }
    EXPECT_GT(marked, 0u) << "the passes marked no vertex: nothing was compared";
}

} // namespace
} // namespace terrain::testing
