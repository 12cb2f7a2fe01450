#include "support/terrain_builders.h"

#include <terrain/snapshot.h>

#include <gtest/gtest.h>
#include <xxhash.h>

namespace terrain {
namespace {

Terrain cratered() {
    Terrain t = testing::makeHills(51, 100, 70);
    CraterSeries s;
    s.seed = 8;
    s.count = 40;
    testing::applyAll(t, randomCraters(t.spec(), s));
    return t;
}

TEST(Snapshot, roundTripsToTheSameHashPatchesAndSamples) {
    const Terrain t = cratered();
    const auto bytes = encodeSnapshot(t, 1234);
    auto d = decodeSnapshot(bytes);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ(d->sequence, 1234u);
    EXPECT_EQ(d->terrain.worldHash(), t.worldHash());
    EXPECT_EQ(d->terrain.patchCount(), t.patchCount());
    EXPECT_EQ(d->terrain.spec(), t.spec());
    const auto a = t.paddedSamples();
    const auto b = d->terrain.paddedSamples();
    EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin(), b.end()));
    EXPECT_EQ(encodeSnapshot(d->terrain, 1234), bytes);
}

// what a server streams through its compressor: the same bytes, in pieces of any size, and a
// size known before the first (the zstd frame's pledged content size)
TEST(Snapshot, inPiecesItIsTheSameBytesAndItsSizeIsKnownBeforehand) {
    const Terrain t = cratered();
    ASSERT_GT(t.patchCount(), 0u);
    const auto whole = encodeSnapshot(t, 77);
    EXPECT_EQ(snapshotBytes(t), whole.size());
    for (std::size_t piece : {std::size_t{1}, std::size_t{5000}, std::size_t{1} << 20}) {
        std::vector<std::uint8_t> joined;
        std::size_t pieces = 0;
        encodeSnapshotTo(
            t, 77,
            [&](std::span<const std::uint8_t> p) {
                joined.insert(joined.end(), p.begin(), p.end());
                ++pieces;
            },
            piece);
        EXPECT_EQ(joined, whole) << "pieces of " << piece;
        if (piece == 1) {
            EXPECT_GT(pieces, static_cast<std::size_t>(t.spec().tileCount()));
        }
    }
}

TEST(Snapshot, everyTruncationIsRefused) {
    const Terrain t = cratered();
    const auto bytes = encodeSnapshot(t, 1);
    for (std::size_t n = 0; n < bytes.size(); n += (n < 64 ? 1 : 997)) {
        auto d = decodeSnapshot(std::span(bytes.data(), n));
        ASSERT_FALSE(d.ok()) << n;
        EXPECT_EQ(d.error().code, n < 4 ? ErrorCode::kTruncated : d.error().code);
    }
    auto d = decodeSnapshot(std::span(bytes.data(), bytes.size() - 1));
    EXPECT_EQ(d.error().code, ErrorCode::kTruncated);
}

TEST(Snapshot, rejectsEachKindOfBadInputWithTheRule) {
    const Terrain t = cratered();
    const auto good = encodeSnapshot(t, 1);
    auto mutate = [&](std::size_t at, std::uint8_t value) {
        auto b = good;
        b[at] = value;
        return decodeSnapshot(b);
    };
    EXPECT_EQ(mutate(0, 'X').error().code, ErrorCode::kBadFormat); // magic
    EXPECT_EQ(mutate(4, 3).error().code, ErrorCode::kUnsupported); // version
    // a version 1 snapshot (v1 craters) is refused by name
    const auto v1 = mutate(4, 1);
    ASSERT_FALSE(v1.ok());
    EXPECT_EQ(v1.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(v1.error().message.find("snapshot version 1 is not supported"), std::string::npos);
    EXPECT_NE(v1.error().message.find("reads version 2"), std::string::npos) << v1.error().message;
    EXPECT_EQ(mutate(8, 1).error().code, ErrorCode::kOutOfRange);     // width 1 breaks the spec
    EXPECT_EQ(mutate(19, 0x80).error().code, ErrorCode::kOutOfRange); // negative spacing
    auto extra = good;
    extra.push_back(0);
    EXPECT_EQ(decodeSnapshot(extra).error().code, ErrorCode::kBadFormat);
    // the sequence number is covered by the checksum, not by the world hash
    auto seq = mutate(4 + 4 + 20, static_cast<std::uint8_t>(good[28] ^ 1));
    ASSERT_FALSE(seq.ok());
    EXPECT_EQ(seq.error().code, ErrorCode::kHashMismatch);
    EXPECT_NE(seq.error().message.find("checksum"), std::string::npos);
    // a tile count the bytes cannot hold is refused before anything is reserved for it
    auto count = good;
    count.resize(48);
    EXPECT_EQ(decodeSnapshot(count).error().code, ErrorCode::kTruncated);
    // the stored world hash altered: caught by the checksum ...
    auto flipped = mutate(good.size() - 11, static_cast<std::uint8_t>(good[good.size() - 11] ^ 1));
    ASSERT_FALSE(flipped.ok());
    EXPECT_EQ(flipped.error().code, ErrorCode::kHashMismatch);
    // ... and, with the checksum recomputed, by the world hash of the decoded state
    auto forged = good;
    forged[good.size() - 11] ^= 1;
    const std::uint64_t sum = XXH3_64bits(forged.data(), forged.size() - 8);
    for (int b = 0; b < 8; ++b)
        forged[forged.size() - 8 + b] = static_cast<std::uint8_t>(sum >> (8 * b));
    auto wrong_world = decodeSnapshot(forged);
    ASSERT_FALSE(wrong_world.ok());
    EXPECT_EQ(wrong_world.error().code, ErrorCode::kHashMismatch);
    EXPECT_NE(wrong_world.error().message.find("world hash"), std::string::npos);
    // any single sample bit flipped is caught, by the patch invariants or by the hash
    const std::size_t first_sample = 4 + 4 + 20 + 8 + 4 + 4 + 8;
    for (std::size_t at = first_sample; at < first_sample + 65 * 65 * 4; at += 401)
        EXPECT_FALSE(mutate(at, static_cast<std::uint8_t>(good[at] ^ 0x10)).ok()) << at;
}

TEST(Snapshot, patchThatBreaksWatertightnessIsRejectedEvenWithAConsistentHash) {
    Terrain t = testing::makeFlat(65, 65);
    auto op = quantizeOp({OpKind::kCrater, 30, 30, 2.0, 0.8, 0.3}, t.spec());
    ASSERT_TRUE(t.apply(*op).ok());
    ASSERT_GT(t.patchCount(), 0u);
    // rebuild the only tile with one border control nudged, then re-encode (hash recomputed)
    std::vector<std::uint8_t> record;
    t.appendTileBytes(0, record);
    auto rec = decodeTile(record, t.spec());
    ASSERT_TRUE(rec.ok());
    // find a patch whose left neighbour has none and bend that border
    for (PatchEntry& e : rec->patches) {
        const int cx = e.cell % 64;
        const int cy = e.cell / 64;
        if (t.findPatch(cx - 1, cy) == nullptr) {
            e.patch.at(0, 2) += 6;
            break;
        }
    }
    Terrain bent = testing::makeFlat(65, 65);
    bent.replaceTile(0, rec->samples, rec->originals, rec->patches);
    auto d = decodeSnapshot(encodeSnapshot(bent, 0));
    ASSERT_FALSE(d.ok());
    EXPECT_EQ(d.error().code, ErrorCode::kInvariantBroken);
    EXPECT_NE(d.error().message.find("straight"), std::string::npos) << d.error().message;
}

TEST(Snapshot, tileRecordRejectsBadCellsAndCounts) {
    const Terrain t = testing::makeFlat(65, 65);
    std::vector<std::uint8_t> rec;
    t.appendTileBytes(0, rec);
    auto bad_tile = rec;
    bad_tile[0] = 7; // tile x = 7 on a 1 x 1 grid
    EXPECT_EQ(decodeTile(bad_tile, t.spec()).error().code, ErrorCode::kOutOfRange);
    auto huge_count = rec;
    huge_count[rec.size() - 1] = 0x7f; // patch count's top byte
    EXPECT_EQ(decodeTile(huge_count, t.spec()).error().code, ErrorCode::kOutOfRange);
    auto one_patch = rec;
    one_patch[rec.size() - 4] = 1; // claims a patch that is not there
    EXPECT_EQ(decodeTile(one_patch, t.spec()).error().code, ErrorCode::kTruncated);
}

} // namespace
} // namespace terrain
