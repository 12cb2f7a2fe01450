// The replica without a network: op order, hash checks, divergence and repair.

#include <terrain/client/replica.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>
#include <terrain/task_runner.h>

#include <gtest/gtest.h>

#include <algorithm>

namespace terrain::client {
namespace {

Terrain map() {
    ProceduralMapOptions o;
    o.width = 193;
    o.height = 129;
    return std::move(*makeProceduralMap(o));
}

DeformOp crater(double x, double y, const WorldSpec& spec) {
    return *quantizeOp(OpRequest{OpKind::kCrater, x, y, 3, 1, 0.25}, spec);
}

DecodedSnapshot snapshotOf(const Terrain& t, std::uint64_t seq) {
    return std::move(*decodeSnapshot(encodeSnapshot(t, seq)));
}

TEST(Replica, AppliesInOrderIgnoresStaleAndRefusesGaps) {
    Terrain server = map();
    Replica r;
    r.loadSnapshot(snapshotOf(server, 5));
    EXPECT_TRUE(r.peekDirty().all);
    (void)r.takeDirty();
    const DeformOp a = crater(40, 40, server.spec());
    ASSERT_TRUE(server.apply(a).ok());
    auto out = r.applyOp(6, a, server.worldHash());
    ASSERT_TRUE(out.ok());
    EXPECT_EQ(*out, Replica::OpOutcome::kApplied);
    EXPECT_EQ(r.verifiedSeq(), 6u);
    EXPECT_EQ(*r.applyOp(6, a, server.worldHash()), Replica::OpOutcome::kStale);
    auto gap = r.applyOp(8, a, server.worldHash());
    ASSERT_FALSE(gap.ok());
    EXPECT_EQ(gap.error().code, ErrorCode::kOutOfRange);
    const DirtySet dirty = r.takeDirty();
    EXPECT_FALSE(dirty.all);
    // the op's own cells, not its tiles: per-op work on the client follows the footprint
    ASSERT_EQ(dirty.cells.size(), 1u);
    Terrain probe = map();
    const CellRect own = probe.apply(a)->cells;
    EXPECT_EQ(dirty.cells[0].x0, own.x0);
    EXPECT_EQ(dirty.cells[0].y0, own.y0);
    EXPECT_EQ(dirty.cells[0].x1, own.x1);
    EXPECT_EQ(dirty.cells[0].y1, own.y1);
    EXPECT_LT(dirty.cells[0].x1 - dirty.cells[0].x0, kTileCells) << "a tile, not the op's cells";
    EXPECT_TRUE(dirty.tiles.empty());
    EXPECT_TRUE(r.takeDirty().cells.empty());
}

// A replica applying on a thread pool verifies every hash of a serial server's ops.
TEST(Replica, OpsAppliedOnAThreadPoolVerifyTheSerialServersHashes) {
    Terrain server = map();
    ThreadPool pool(4);
    Replica r;
    r.setApplyRunner(&pool);
    r.loadSnapshot(snapshotOf(server, 0));
    for (std::uint64_t seq = 1; seq <= 60; ++seq) {
        const DeformOp op = crater(
            20 + static_cast<double>((seq * 37) % 80), 20 + static_cast<double>((seq * 53) % 80),
            server.spec());
        ASSERT_TRUE(server.apply(op).ok());
        auto out = r.applyOp(seq, op, server.worldHash());
        ASSERT_TRUE(out.ok()) << out.error().message;
        ASSERT_EQ(*out, Replica::OpOutcome::kApplied) << "seq " << seq;
    }
    EXPECT_EQ(r.verifiedSeq(), 60u);
    EXPECT_FALSE(r.diverged());
}

TEST(Replica, DivergenceIsDetectedAndRepairedFromTileState) {
    Terrain server = map();
    Replica r;
    r.loadSnapshot(snapshotOf(server, 0));
    // corrupt a tile the next op does not touch
    ASSERT_TRUE(r.terrainForTesting().apply(crater(150, 100, server.spec())).ok());
    const DeformOp a = crater(20, 20, server.spec());
    ASSERT_TRUE(server.apply(a).ok());
    EXPECT_EQ(*r.applyOp(1, a, server.worldHash()), Replica::OpOutcome::kDiverged);
    EXPECT_TRUE(r.diverged());
    EXPECT_EQ(r.verifiedSeq(), 0u);
    const std::vector<std::int32_t> suspects = r.suspectTiles();
    ASSERT_FALSE(suspects.empty());
    // first round: the op's tiles (which were fine) and every server tile hash
    std::vector<std::uint64_t> hashes;
    for (std::int32_t t = 0; t < server.spec().tileCount(); ++t)
        hashes.push_back(server.computeTileHash(t));
    auto records = [&](const std::vector<std::int32_t>& tiles) {
        std::vector<TileRecord> out;
        for (std::int32_t t : tiles) {
            std::vector<std::uint8_t> bytes;
            server.appendTileBytes(t, bytes);
            out.push_back(std::move(*decodeTile(bytes, server.spec())));
        }
        return out;
    };
    auto left = r.applyRepair(1, server.worldHash(), records(suspects), hashes);
    ASSERT_TRUE(left.ok());
    ASSERT_FALSE(left->empty()); // the corrupted tile shows up in the hash comparison
    EXPECT_TRUE(r.diverged());
    left = r.applyRepair(1, server.worldHash(), records(*left), hashes);
    ASSERT_TRUE(left.ok());
    EXPECT_TRUE(left->empty());
    EXPECT_FALSE(r.diverged());
    EXPECT_EQ(r.worldHash(), server.worldHash());
    EXPECT_EQ(r.terrain().computeWorldHash(), server.worldHash());
    EXPECT_EQ(r.stats().repairs, 1u);
    // tile state for another seq is refused
    EXPECT_EQ(
        r.applyRepair(7, server.worldHash(), {}, hashes).error().code, ErrorCode::kOutOfRange);
}

TEST(Replica, OpsInABatchAreCheckedByTheHashAfterItsLastOp) {
    // a batch carries one hash, after its last op: a replica that went wrong on an earlier op
    // finds out there, and suspects the tiles of every op since the last check
    Terrain server = map();
    Replica r;
    r.loadSnapshot(snapshotOf(server, 0));
    const DeformOp a = crater(20, 20, server.spec());   // tile 0
    const DeformOp b = crater(170, 100, server.spec()); // tile 5
    ASSERT_TRUE(server.apply(a).ok());
    ASSERT_TRUE(server.apply(b).ok());
    EXPECT_EQ(*r.applyOp(1, a, std::nullopt), Replica::OpOutcome::kApplied);
    EXPECT_EQ(r.verifiedSeq(), 0u) << "an unchecked op is not verified";
    EXPECT_EQ(*r.applyOp(2, b, server.worldHash()), Replica::OpOutcome::kApplied);
    EXPECT_EQ(r.verifiedSeq(), 2u);

    // the same two ops on a replica whose first op came out wrong (a corrupted tile 0)
    Replica bad;
    Terrain start = map();
    bad.loadSnapshot(snapshotOf(start, 0));
    ASSERT_TRUE(bad.terrainForTesting().apply(crater(30, 30, start.spec())).ok());
    EXPECT_EQ(*bad.applyOp(1, a, std::nullopt), Replica::OpOutcome::kApplied);
    EXPECT_EQ(*bad.applyOp(2, b, server.worldHash()), Replica::OpOutcome::kDiverged);
    const std::vector<std::int32_t> suspects = bad.suspectTiles();
    const auto has = [&](std::int32_t t) {
        return std::find(suspects.begin(), suspects.end(), t) != suspects.end();
    };
    EXPECT_TRUE(has(0)) << "the unchecked op's tile";
    EXPECT_TRUE(has(5)) << "the checked op's tile";
    EXPECT_EQ(bad.verifiedSeq(), 0u);
}

} // namespace
} // namespace terrain::client
