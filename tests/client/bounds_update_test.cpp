// The bounds update alone, on a cratered world with every detail block resident in all its
// grains: an op's passes (centres and grid at once, the stale blocks within a budget) end where a
// whole-map pass over the new surface starts, the ids reported as moved are exactly those whose
// bounds changed, heights run ahead of bounds, and a single block's pass is not reused across a
// change of the surface.

#include "support/terrain_builders.h"

#include <terrain/fixed_point.h>
#include <terrain/roam/bounds_update.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <set>
#include <utility>
#include <vector>

namespace terrain::testing {
namespace {

using roam::BlockPool;
using roam::BoundsUpdate;
using roam::DetailBlocks;
using roam::DiamondBounds;
using roam::DiamondId;
using roam::DiamondSpace;
using roam::kGrains;
using roam::kLatticePerCell;
using roam::TileVertexArrays;

Terrain crateredWorld() {
    Terrain t = makeHills(7);
    CraterSeries s;
    s.seed = 7;
    s.count = 60;
    applyAll(t, randomCraters(t.spec(), s));
    return t;
}

/// What the tessellator gives its bounds update: the records, a pool holding a block per record
/// in every grain, the diamond space sized to follow, the tiles' vertex arrays; all over
/// `terrain`, bounded by a whole-map pass.
struct BoundsWorld {
    explicit BoundsWorld(const Terrain& t) : terrain(t) {
        const WorldSpec& spec = terrain.spec();
        blocks.reset(terrain);
        space.reset(
            static_cast<std::uint32_t>(spec.paddedWidth() * spec.paddedHeight()),
            roam::BoundsCodec(spec.metresPerUnit()));
        vertices.reset(static_cast<std::size_t>(spec.tileCount()));
        for (std::int32_t r = 0; r < blocks.recordCapacity(); ++r) {
            if (!blocks.recordInUse(r))
                continue;
            const std::int32_t b = blocks.materialise(r);
            pool.resizeBlocks(static_cast<std::size_t>(blocks.capacity()));
            pool.adoptBlock(b, 1);
            for (int g = 1; g < kGrains; ++g)
                pool.takeChunk(b, g, 1);
        }
        space.resizeCentres(static_cast<std::size_t>(blocks.recordCapacity()));
        for (int g = 0; g < kGrains; ++g)
            space.resizeChunks(g, pool.chunkCount(g));
        bounds.reset(
            terrain, {spec, spec.metresPerUnit() / static_cast<double>(roam::kFineUnitsPerQuantum),
                      (spec.paddedWidth() - 1) * kLatticePerCell,
                      (spec.paddedHeight() - 1) * kLatticePerCell});
        bounds.recomputeAll();
    }

    /// Every diamond's bounds: the grid's, the centres', each grain's chunks' (in id order).
    std::vector<DiamondBounds> everyBound() const {
        std::vector<DiamondBounds> all;
        for (DiamondId id = 0; id < space.gridCount(); ++id)
            all.push_back(bounds.bounds(id));
        for (std::int32_t r = 0; r < blocks.recordCapacity(); ++r)
            all.push_back(
                blocks.recordInUse(r) ? bounds.bounds(space.centreId(r)) : DiamondBounds{});
        for (const DiamondId id : pooledIds())
            all.push_back(bounds.bounds(id));
        return all;
    }
    std::vector<DiamondId> everyId() const {
        std::vector<DiamondId> ids;
        for (DiamondId id = 0; id < space.gridCount(); ++id)
            ids.push_back(id);
        for (std::int32_t r = 0; r < blocks.recordCapacity(); ++r)
            ids.push_back(blocks.recordInUse(r) ? space.centreId(r) : roam::kNoDiamond);
        for (const DiamondId id : pooledIds())
            ids.push_back(id);
        return ids;
    }
    std::vector<DiamondId> pooledIds() const {
        std::vector<DiamondId> ids;
        for (int g = 0; g < kGrains; ++g)
            for (std::size_t c = 0; c < pool.chunkCount(g); ++c)
                for (std::int32_t slot = 0;
                     slot < roam::kGrainDiamonds[static_cast<std::size_t>(g)]; ++slot)
                    ids.push_back(DiamondSpace::pooledId(
                        g, static_cast<std::int32_t>(c), static_cast<std::uint32_t>(slot)));
        return ids;
    }
    /// Every resident grain's base and heights.
    std::vector<std::int64_t> everyHeight() const {
        std::vector<std::int64_t> all;
        for (int g = 0; g < kGrains; ++g)
            for (std::size_t c = 0; c < pool.chunkCount(g); ++c) {
                const auto chunk = static_cast<std::int32_t>(c);
                all.push_back(pool.base(g, chunk));
                for (const std::uint32_t h : pool.heights(g, chunk))
                    all.push_back(h);
            }
        return all;
    }
    /// Applies `request` to the terrain and its detail records, telling the bounds update what
    /// the tessellator tells it before the records change; the cells it changed. The op must
    /// leave the records where they were (the tessellator evicts the blocks of records that go
    /// first: not this test's subject).
    CellRect change(const OpRequest& request) {
        auto op = quantizeOp(request, terrain.spec());
        EXPECT_TRUE(op.ok());
        auto effect = terrain.apply(*op);
        EXPECT_TRUE(effect.ok());
        const CellRect r = effect->cells;
        bounds.surfaceChanged();
        std::vector<std::int32_t> removing;
        blocks.plan(terrain, r, removing);
        EXPECT_TRUE(removing.empty()) << "the op removes detail records: pick another";
        bounds.noteCentres(r);
        std::vector<std::int32_t> removed;
        std::vector<std::int32_t> added;
        blocks.update(terrain, r, removed, added);
        EXPECT_TRUE(added.empty()) << "the op adds detail records: pick another";
        return r;
    }
    /// change(), then the op's passes: the stale blocks queued, the grid and centres redone.
    void apply(const OpRequest& request) {
        const CellRect r = change(request);
        bounds.markStale(r);
        bounds.recomputeAround(r);
    }

    Terrain terrain;
    DetailBlocks blocks;
    BlockPool pool;
    DiamondSpace space;
    TileVertexArrays vertices;
    BoundsUpdate bounds{blocks, pool, space, vertices};
};

/// The detail cells of `t` (the cells with a record).
std::set<std::pair<std::int32_t, std::int32_t>> detailCells(const Terrain& t) {
    DetailBlocks b;
    b.reset(t);
    std::set<std::pair<std::int32_t, std::int32_t>> cells;
    for (std::int32_t r = 0; r < b.recordCapacity(); ++r)
        if (b.recordInUse(r))
            cells.insert({b.recordCell(r).x, b.recordCell(r).y});
    return cells;
}

/// A small crater on a detail cell near the map's middle that leaves the detail cells as they
/// were (the first such, trying the cells nearest the middle first).
OpRequest craterKeepingTheRecords(const BoundsWorld& w) {
    const WorldSpec& spec = w.terrain.spec();
    const std::set<std::pair<std::int32_t, std::int32_t>> before = detailCells(w.terrain);
    std::vector<std::pair<std::int64_t, std::pair<std::int32_t, std::int32_t>>> near;
    for (const auto& c : before) {
        const std::int64_t dx = c.first - spec.cellsX() / 2;
        const std::int64_t dy = c.second - spec.cellsY() / 2;
        near.push_back({dx * dx + dy * dy, c});
    }
    std::sort(near.begin(), near.end());
    for (std::size_t i = 0; i < near.size() && i < 200; ++i) {
        OpRequest req;
        req.kind = OpKind::kCrater;
        req.x = (near[i].second.first + 0.5) * spec.spacingMetres();
        req.y = (near[i].second.second + 0.5) * spec.spacingMetres();
        req.radius = 1.5;
        req.height = 0.4;
        req.strength = 0.5;
        Terrain trial = w.terrain;
        applyAll(trial, {req});
        if (detailCells(trial) == before)
            return req;
    }
    ADD_FAILURE() << "no crater near the middle keeps the detail cells";
    return {};
}

TEST(RoamBoundsUpdate, AnOpsPassesEndWhereAWholeMapPassOverTheNewSurfaceStarts) {
    BoundsWorld w(crateredWorld());
    const OpRequest op = craterKeepingTheRecords(w);
    w.apply(op);
    ASSERT_GT(w.bounds.staleCount(), 0u) << "the op left no resident block stale";
    w.bounds.freshenHeights();
    while (w.bounds.staleCount() > 0)
        w.bounds.drainStale(3);

    Terrain after = crateredWorld();
    applyAll(after, {op});
    const BoundsWorld fresh(after);
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
    BoundsWorld w(crateredWorld());
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
    BoundsWorld w(crateredWorld());
    const std::vector<std::int64_t> heights_before = w.everyHeight();
    const std::vector<DiamondBounds> bounds_before = w.everyBound();
    const std::size_t eager =
        w.space.gridCount() + static_cast<std::size_t>(w.blocks.recordCapacity());
    const OpRequest op = craterKeepingTheRecords(w);
    w.apply(op);
    w.bounds.freshenHeights();

    Terrain after = crateredWorld();
    applyAll(after, {op});
    const BoundsWorld fresh(after);
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
    BoundsWorld w(crateredWorld());
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
    const BoundsWorld fresh(after);
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
