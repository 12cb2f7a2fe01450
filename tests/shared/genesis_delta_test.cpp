#include "support/terrain_builders.h"

#include <terrain/battle.h>
#include <terrain/genesis_delta.h>
#include <terrain/snapshot.h>

#include <gtest/gtest.h>
#include <xxhash.h>

#include <random>

namespace terrain {
namespace {

/// Hills with craters, raises, flattens and smooths spread over part of the map, and every tile
/// of the far half left as created (so the delta holds some tiles and not others).
Terrain deformed(std::uint64_t seed) {
    Terrain t = testing::makeHills(seed, 300, 200);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> x(5.0, 140.0);
    std::uniform_real_distribution<double> y(5.0, 190.0);
    for (int n = 0; n < 120; ++n) {
        OpRequest r;
        r.kind = static_cast<OpKind>(1 + n % 4);
        r.x = x(rng);
        r.y = y(rng);
        r.radius = 2.0 + (n % 7);
        r.height = r.kind == OpKind::kCrater    ? 1.5
                   : r.kind == OpKind::kRaise   ? 0.8
                   : r.kind == OpKind::kFlatten ? 9.0
                                                : 0.0;
        r.strength = (r.kind == OpKind::kRaise) ? 1.0 : (r.kind == OpKind::kCrater ? 0.4 : 0.7);
        auto op = quantizeOp(r, t.spec());
        EXPECT_TRUE(op.ok()) << op.error().message;
        EXPECT_TRUE(t.apply(*op).ok());
    }
    return t;
}

void expectSameWorld(const Terrain& a, const Terrain& b) {
    ASSERT_EQ(a.spec(), b.spec());
    EXPECT_EQ(a.worldHash(), b.worldHash());
    EXPECT_EQ(a.patchCount(), b.patchCount());
    for (std::int32_t tile = 0; tile < a.spec().tileCount(); ++tile)
        EXPECT_EQ(a.tileHash(tile), b.tileHash(tile)) << tile;
    // the decoded hashes are recomputed, not copied: the state itself is equal
    EXPECT_EQ(b.computeWorldHash(), a.worldHash());
}

TEST(GenesisDelta, rebuildsTheWorldOnAFreshlyMadeGenesis) {
    const Terrain server = deformed(3);
    const Terrain genesis = testing::makeHills(3, 300, 200);
    ASSERT_EQ(server.genesisHash(), genesis.worldHash());
    ASSERT_EQ(genesis.genesisHash(), genesis.worldHash());

    const auto bytes = encodeGenesisDelta(server, 77, server.genesisHash());
    auto d = decodeGenesisDelta(bytes, genesis);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ(d->sequence, 77u);
    expectSameWorld(server, d->terrain);
    // only the tiles that differ travel: the far half of the map is genesis
    std::int32_t differing = 0;
    for (std::int32_t tile = 0; tile < server.spec().tileCount(); ++tile)
        differing += server.differsFromGenesis(tile) ? 1 : 0;
    EXPECT_GT(differing, 0);
    EXPECT_LT(differing, server.spec().tileCount());
    EXPECT_LT(bytes.size(), encodeSnapshot(server, 77).size() / 4);
}

TEST(GenesisDelta, aReplicaInAnyStateOfTheWorldIsItsOwnGenesis) {
    // a client holding an older or diverged state of the world has the genesis in its original
    // ground: the delta replaces its samples and patches
    Terrain older = testing::makeHills(5, 300, 200);
    CraterSeries s;
    s.seed = 1;
    s.count = 30;
    testing::applyAll(older, randomCraters(older.spec(), s));
    const Terrain server = deformed(5);
    auto d = decodeGenesisDelta(encodeGenesisDelta(server, 9, server.genesisHash()), older);
    ASSERT_TRUE(d.ok()) << d.error().message;
    expectSameWorld(server, d->terrain);
    // and a world back at its genesis is an empty delta
    const Terrain untouched = testing::makeHills(5, 300, 200);
    const auto empty = encodeGenesisDelta(untouched, 0, untouched.genesisHash());
    EXPECT_EQ(empty.size(), 48u + 16u); // the header, no tile, the hashes
    auto g = decodeGenesisDelta(empty, older);
    ASSERT_TRUE(g.ok()) << g.error().message;
    expectSameWorld(untouched, g->terrain);
}

TEST(GenesisDelta, aBattleZoneRoundTripsAndCostsLittle) {
    // the battle's dense craters on slopes, overlapping patches across tile borders
    ProceduralMapOptions map;
    map.width = 257;
    map.height = 257;
    auto made = makeProceduralMap(map);
    ASSERT_TRUE(made.ok());
    Terrain t = std::move(*made);
    BattleOptions o;
    o.zone_x = 128.0; // on a tile corner: patches on both sides of two tile borders
    o.zone_y = 128.0;
    o.zone_radius = 20.0;
    BattleGenerator battle(o);
    for (int n = 0; n < 400; ++n) {
        const BattleShot shot = battle.next(t);
        if (!shot.crater)
            continue;
        auto op = quantizeOp(*shot.crater, t.spec());
        ASSERT_TRUE(op.ok());
        ASSERT_TRUE(t.apply(*op).ok());
    }
    ASSERT_GT(t.patchCount(), 500u);
    auto genesis = makeProceduralMap(map);
    ASSERT_TRUE(genesis.ok());
    const auto bytes = encodeGenesisDelta(t, 400, t.genesisHash());
    auto d = decodeGenesisDelta(bytes, *genesis);
    ASSERT_TRUE(d.ok()) << d.error().message;
    expectSameWorld(t, d->terrain);
    // a patch's 25 controls are 100 bytes in the snapshot; coded, they must be far fewer
    EXPECT_LT(static_cast<double>(bytes.size()) / static_cast<double>(t.patchCount()), 50.0);
}

TEST(GenesisDelta, refusesAnotherGenesisAndAnotherWorldByName) {
    const Terrain server = deformed(3);
    const auto bytes = encodeGenesisDelta(server, 1, server.genesisHash());
    auto other = decodeGenesisDelta(bytes, testing::makeHills(4, 300, 200));
    ASSERT_FALSE(other.ok());
    EXPECT_EQ(other.error().code, ErrorCode::kHashMismatch);
    EXPECT_NE(other.error().message.find("genesis held here differs"), std::string::npos);
    auto smaller = decodeGenesisDelta(bytes, testing::makeHills(3, 299, 200));
    ASSERT_FALSE(smaller.ok());
    EXPECT_EQ(smaller.error().code, ErrorCode::kSizeMismatch);
}

TEST(GenesisDelta, everyTruncationAndEveryAlteredByteIsRefused) {
    const Terrain server = deformed(6);
    const Terrain genesis = testing::makeHills(6, 300, 200);
    const auto good = encodeGenesisDelta(server, 1, server.genesisHash());
    for (std::size_t n = 0; n < good.size(); n += (n < 80 ? 1 : 131)) {
        auto d = decodeGenesisDelta(std::span(good.data(), n), genesis);
        ASSERT_FALSE(d.ok()) << n;
    }
    auto extra = good;
    extra.push_back(0);
    EXPECT_EQ(decodeGenesisDelta(extra, genesis).error().code, ErrorCode::kBadFormat);
    auto magic = good;
    magic[0] = 'X';
    EXPECT_EQ(decodeGenesisDelta(magic, genesis).error().code, ErrorCode::kBadFormat);
    auto version = good;
    version[4] = 9;
    EXPECT_EQ(decodeGenesisDelta(version, genesis).error().code, ErrorCode::kUnsupported);
    // an altered byte with a checksum made to match (a hostile sender) must still be refused:
    // by the parser's rules, the invariants or the world hash; never accepted, never a crash
    std::mt19937_64 rng(11);
    const std::size_t body_end = good.size() - 16;
    for (int trial = 0; trial < 400; ++trial) {
        auto b = good;
        const std::size_t at = 36 + rng() % (body_end - 36);
        b[at] = static_cast<std::uint8_t>(b[at] ^ (1u << (rng() % 8)));
        const std::uint64_t sum = XXH3_64bits(b.data(), b.size() - 8);
        for (int k = 0; k < 8; ++k)
            b[b.size() - 8 + static_cast<std::size_t>(k)] =
                static_cast<std::uint8_t>(sum >> (8 * k));
        auto d = decodeGenesisDelta(b, genesis);
        EXPECT_FALSE(d.ok()) << "byte " << at << " altered and accepted";
    }
}

/// A delta for a one-tile world built by hand: `entry` is the tile entry's bytes after the gap.
std::vector<std::uint8_t> handMade(const Terrain& genesis, const std::vector<std::uint8_t>& entry) {
    std::vector<std::uint8_t> b = {'T', 'R', 'G', 'D', 1, 0, 0, 0};
    auto put = [&](std::uint64_t v, int bytes) {
        for (int k = 0; k < bytes; ++k)
            b.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
    };
    const WorldSpec& s = genesis.spec();
    for (std::int32_t v : {s.width, s.height, s.spacing, s.units_per_metre, s.patch_tolerance})
        put(static_cast<std::uint32_t>(v), 4);
    put(5, 8);                     // seq
    put(genesis.genesisHash(), 8); // genesis
    put(1, 4);                     // one entry
    b.insert(b.end(), entry.begin(), entry.end());
    put(genesis.worldHash(), 8);
    put(XXH3_64bits(b.data(), b.size()), 8);
    return b;
}

TEST(GenesisDelta, oneEncodingPerWorld) {
    const Terrain genesis = testing::makeFlat(65, 65);
    // a record of zero displacements and no patch: the tile equals its genesis
    std::vector<std::uint8_t> record(kTileVertices * kTileVertices, 0);
    record.push_back(0); // patch count
    auto entry = [&](std::vector<std::uint8_t> gap) {
        std::vector<std::uint8_t> e = std::move(gap);
        // the record length, 4226, as LEB128
        e.push_back(static_cast<std::uint8_t>(0x80 | (record.size() & 0x7f)));
        e.push_back(static_cast<std::uint8_t>(record.size() >> 7));
        e.insert(e.end(), record.begin(), record.end());
        return e;
    };
    auto plain = decodeGenesisDelta(handMade(genesis, entry({0})), genesis);
    ASSERT_FALSE(plain.ok());
    EXPECT_EQ(plain.error().code, ErrorCode::kBadFormat);
    EXPECT_NE(plain.error().message.find("equals its genesis"), std::string::npos)
        << plain.error().message;
    // the same tile number written in two bytes (0x80 0x00) is not its shortest form
    auto overlong = decodeGenesisDelta(handMade(genesis, entry({0x80, 0x00})), genesis);
    ASSERT_FALSE(overlong.ok());
    EXPECT_EQ(overlong.error().code, ErrorCode::kTruncated);
    EXPECT_NE(overlong.error().message.find("shortest form"), std::string::npos);
    // with one displaced vertex, the entry is the world's encoding (hash aside)
    record[0] = 2; // zig(1)
    auto displaced = decodeGenesisDelta(handMade(genesis, entry({0})), genesis);
    ASSERT_FALSE(displaced.ok());
    EXPECT_EQ(displaced.error().code, ErrorCode::kHashMismatch); // not the genesis' world hash
    EXPECT_NE(displaced.error().message.find("world hash"), std::string::npos);
}

} // namespace
} // namespace terrain
