// Copies of a world: patch lists shared copy-on-write, and syncFrom(), which brings a kept copy
// up to date with the changed tiles only (the server's snapshot copies), or takeSync() and
// applySync(), the same in two halves (a client's copies on other threads).
#include "support/terrain_builders.h"

#include <terrain/snapshot.h>

#include <gtest/gtest.h>

namespace terrain {
namespace {

// 150 x 140 vertices: 3 x 3 tiles, the last row and column of tiles partly padding
Terrain hills() {
    return testing::makeHills(61);
}

void crater(Terrain& t, double x, double y, double r = 4.0) {
    auto op = quantizeOp({OpKind::kCrater, x, y, r, 1.5, 0.3}, t.spec());
    ASSERT_TRUE(op.ok()) << op.error().message;
    ASSERT_TRUE(t.apply(*op).ok());
}

// equal in every byte a snapshot holds: samples, original ground, patches, hashes
void expectEqualCopies(const Terrain& a, const Terrain& b) {
    EXPECT_EQ(a.worldHash(), b.worldHash());
    EXPECT_EQ(b.worldHash(), b.computeWorldHash());
    EXPECT_EQ(a.patchCount(), b.patchCount());
    EXPECT_EQ(a.genesisHash(), b.genesisHash());
    EXPECT_EQ(encodeSnapshot(a, 5), encodeSnapshot(b, 5));
    const auto sa = a.paddedSamples();
    const auto sb = b.paddedSamples();
    EXPECT_TRUE(std::equal(sa.begin(), sa.end(), sb.begin(), sb.end()));
}

TEST(TerrainCopy, aCopyAndItsSourceChangeApart) {
    Terrain t = hills();
    crater(t, 40, 40);
    const Terrain before = t;
    Terrain copy = t;
    ASSERT_GT(copy.patchCount(), 0u);
    crater(t, 41, 42, 6.0); // rewrites patches the copy shares
    expectEqualCopies(copy, before);
    crater(copy, 100, 90);
    EXPECT_NE(t.worldHash(), copy.worldHash());
    EXPECT_EQ(t.worldHash(), t.computeWorldHash());
    EXPECT_EQ(copy.worldHash(), copy.computeWorldHash());
}

TEST(TerrainCopy, syncFromCopiesOnlyTheChangedTilesAndEndsEqual) {
    Terrain t = hills();
    Terrain kept = t;
    EXPECT_EQ(kept.syncFrom(t), 0u);
    crater(t, 20, 20); // inside tile 0 only
    EXPECT_EQ(kept.syncFrom(t), 1u);
    expectEqualCopies(t, kept);
    EXPECT_EQ(kept.syncFrom(t), 0u);
    // on the corner of four tiles, then on the map's far edge (the padded last tiles)
    crater(t, 64, 64, 5.0);
    crater(t, 148, 138, 5.0);
    const std::size_t copied = kept.syncFrom(t);
    EXPECT_GE(copied, 4u);
    EXPECT_LE(copied, 6u);
    expectEqualCopies(t, kept);
}

TEST(TerrainCopy, syncFromUndoesTheCopysOwnChanges) {
    Terrain t = hills();
    crater(t, 30, 100);
    Terrain kept = t;
    crater(kept, 120, 30); // a change the source never had
    crater(t, 30, 101);
    EXPECT_EQ(kept.syncFrom(t), 2u);
    expectEqualCopies(t, kept);
}

TEST(TerrainCopy, syncFromFollowsARepairAndAnUnrelatedWorld) {
    Terrain t = hills();
    crater(t, 90, 70);
    Terrain kept = t;
    // a repair: tile 4 replaced from another world's bytes (the shared edges rehash too)
    Terrain other = hills();
    crater(other, 80, 80, 7.0);
    std::vector<std::uint8_t> record;
    other.appendTileBytes(4, record);
    auto rec = decodeTile(record, other.spec());
    ASSERT_TRUE(rec.ok()) << rec.error().message;
    t.replaceTile(4, rec->samples, rec->originals, rec->patches);
    kept.syncFrom(t);
    expectEqualCopies(t, kept);
    // a world that shares nothing with the copy (another genesis, same size): every tile
    Terrain unrelated = testing::makeHills(62);
    crater(unrelated, 10, 10);
    EXPECT_EQ(kept.syncFrom(unrelated), static_cast<std::size_t>(t.spec().tileCount()));
    expectEqualCopies(unrelated, kept);
    // another size: a whole copy
    Terrain small = testing::makeHills(63, 70, 70);
    kept.syncFrom(small);
    expectEqualCopies(small, kept);
}

TEST(TerrainCopy, aDecodedWorldIsNeverTakenForItsSource) {
    Terrain t = hills();
    crater(t, 50, 50);
    auto decoded = decodeSnapshot(encodeSnapshot(t, 1));
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    Terrain kept = t;
    // same bytes, but decoding made tiles of its own: all copied, the result still equal
    EXPECT_EQ(kept.syncFrom(decoded->terrain), static_cast<std::size_t>(t.spec().tileCount()));
    expectEqualCopies(t, kept);
}

TEST(TerrainCopy, aSyncTakenOnOneSideAndAppliedOnTheOtherCopiesOnlyTheChangedTiles) {
    Terrain t = hills();
    std::vector<std::uint64_t> versions; // what the copy holds: nothing yet
    Terrain::TileSync first = t.takeSync(versions);
    ASSERT_TRUE(first.whole()) << "a copy with nothing takes the whole world";
    Terrain copy = first.wholeTerrain();
    EXPECT_EQ(t.takeSync(versions).tileCount(), 0u) << "nothing changed since";
    crater(t, 20, 20); // inside tile 0 only
    Terrain::TileSync one = t.takeSync(versions);
    EXPECT_FALSE(one.whole());
    EXPECT_EQ(one.tileCount(), 1u);
    EXPECT_GT(one.bytes(), 0u);
    // the source goes on before the copy applies the sync: it still brings the state taken
    const Terrain taken = t;
    crater(t, 64, 64, 5.0);   // the corner of four tiles
    crater(t, 148, 138, 5.0); // the map's far edge (the padded last tiles)
    copy.applySync(one);
    expectEqualCopies(taken, copy);
    Terrain::TileSync more = t.takeSync(versions);
    EXPECT_GE(more.tileCount(), 4u);
    EXPECT_LE(more.tileCount(), 6u);
    copy.applySync(more);
    expectEqualCopies(t, copy);
    // two syncs applied in the order taken
    crater(t, 30, 100);
    Terrain::TileSync a = t.takeSync(versions);
    crater(t, 31, 101);
    crater(t, 120, 30);
    Terrain::TileSync b = t.takeSync(versions);
    copy.applySync(a);
    copy.applySync(b, Terrain::PatchLists::kOwnCopies); // the same bits either way
    expectEqualCopies(t, copy);
    crater(t, 121, 31, 6.0); // rewrites the lists the copy took copies of
    EXPECT_EQ(copy.computeWorldHash(), copy.worldHash());
    // another world of the same size shares no tile: taken whole, as is one of another size
    Terrain unrelated = testing::makeHills(62);
    Terrain::TileSync all = unrelated.takeSync(versions);
    EXPECT_TRUE(all.whole());
    copy.applySync(all);
    expectEqualCopies(unrelated, copy);
    Terrain small = testing::makeHills(63, 70, 70);
    Terrain::TileSync smaller = small.takeSync(versions);
    EXPECT_TRUE(smaller.whole());
    copy.applySync(smaller);
    expectEqualCopies(small, copy);
}

} // namespace
} // namespace terrain
