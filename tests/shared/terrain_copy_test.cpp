// Copies of a world: patch lists shared copy-on-write, and syncFrom(), which brings a kept copy
// up to date with the changed tiles only (the server's snapshot copies).
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

} // namespace
} // namespace terrain
