// The replica on its own through the library alone (terrain_replica.h and its C++ wrapper), as a
// program that speaks the protocol itself links it: states in every form the protocol carries
// them (raw, in a zstd frame, a genesis delta), ops checked by their hash, and every misuse
// refused by name with nothing changed. tests/api/test_replica_abi.py follows a live server's
// journal through the same functions from Python.

#include <terrain/game/replica.h>

#include <gtest/gtest.h>
#include <zstd.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace terrain::testing {
namespace {

using game::ClientError;
using game::Replica;
using game::ReplicaOp;
using game::ReplicaOutcome;

constexpr std::int64_t kQuanta = 1024; // per metre (the procedural map's)

ReplicaOp crater(double x, double y) {
    ReplicaOp op{};
    op.kind = TERRAIN_OP_CRATER;
    op.center_x = static_cast<std::int64_t>(x * kQuanta);
    op.center_y = static_cast<std::int64_t>(y * kQuanta);
    op.radius = 3 * kQuanta;
    op.height = kQuanta;
    op.strength = 19661; // 0.3
    return op;
}

std::vector<std::uint8_t> zstdFrame(const std::vector<std::uint8_t>& raw) {
    std::vector<std::uint8_t> out(ZSTD_compressBound(raw.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 1);
    EXPECT_FALSE(ZSTD_isError(n));
    out.resize(n);
    return out;
}

// A world at seq 3 whose ops were applied unchecked (no server here): a source of states.
void threeCraters(Replica& r) {
    ASSERT_TRUE(r.loadProcedural(5, 129));
    for (std::uint64_t seq = 1; seq <= 3; ++seq)
        ASSERT_TRUE(r.applyOp(seq, crater(30.0 + 20.0 * seq, 60.0), nullptr));
}

TEST(ReplicaAbi, SnapshotsAndGenesisDeltasLoadRawOrInAZstdFrame) {
    Replica source;
    threeCraters(source);
    const game::ReplicaState held = source.state();
    ASSERT_EQ(held.seq, 3u);
    ASSERT_NE(held.world_hash, held.genesis_hash);
    std::vector<std::uint8_t> snapshot, delta;
    ASSERT_TRUE(source.save(TERRAIN_STATE_SNAPSHOT, snapshot));
    ASSERT_TRUE(source.save(TERRAIN_STATE_GENESIS_DELTA, delta));
    EXPECT_LT(delta.size(), snapshot.size() / 4); // zero displacement compresses to a byte

    for (const auto* bytes : {&snapshot, &delta}) {
        for (const bool compressed : {false, true}) {
            Replica r;
            ASSERT_TRUE(r.loadProcedural(5, 129)); // the genesis a delta needs
            const auto result = r.load(compressed ? zstdFrame(*bytes) : *bytes);
            ASSERT_TRUE(result) << result.message;
            EXPECT_EQ(r.state().seq, 3u);
            EXPECT_EQ(r.state().world_hash, held.world_hash);
            EXPECT_EQ(r.state().genesis_hash, held.genesis_hash);
        }
    }
    // the same op on the same state gives the same bits, checked by the hash it gave there
    Replica a, b;
    ASSERT_TRUE(a.load(snapshot));
    ASSERT_TRUE(b.load(zstdFrame(snapshot)));
    ASSERT_TRUE(a.applyOp(4, crater(70.0, 70.0), nullptr));
    const std::uint64_t hash = a.state().world_hash;
    ReplicaOutcome outcome = ReplicaOutcome::kStale;
    ASSERT_TRUE(b.applyOp(4, crater(70.0, 70.0), &hash, &outcome));
    EXPECT_EQ(outcome, ReplicaOutcome::kApplied);
    double height = 0.0;
    ASSERT_TRUE(b.heightAt(70.0, 70.0, height));
    double beside = 0.0;
    ASSERT_TRUE(b.heightAt(70.0, 90.0, beside));
    EXPECT_TRUE(std::isfinite(height));
    EXPECT_LT(height, beside + 0.5); // the crater's floor, not above the ground beside it
}

TEST(ReplicaAbi, AHashThatDiffersNamesTheSuspectTilesAndTheServersTilesRepairThem) {
    Replica server, client;
    threeCraters(server);
    std::vector<std::uint8_t> snapshot;
    ASSERT_TRUE(server.save(TERRAIN_STATE_SNAPSHOT, snapshot));
    ASSERT_TRUE(client.load(snapshot));
    ASSERT_TRUE(server.applyOp(4, crater(100.0, 100.0), nullptr));
    const std::uint64_t hash4 = server.state().world_hash;
    ReplicaOutcome outcome = ReplicaOutcome::kApplied;
    ASSERT_TRUE(client.applyOp(4, crater(100.0, 96.0), &hash4, &outcome)); // not the server's
    EXPECT_EQ(outcome, ReplicaOutcome::kDiverged);
    EXPECT_TRUE(client.state().diverged);
    EXPECT_EQ(client.state().verified_seq, 3u);
    const std::vector<std::int32_t> suspects = client.suspectTiles();
    ASSERT_FALSE(suspects.empty());

    // the server's tile records of the suspects, as RepairState carries them (zstd), taken from
    // its snapshot: u32 length + record per tile after the 40-byte header
    std::vector<std::uint8_t> now;
    ASSERT_TRUE(server.save(TERRAIN_STATE_SNAPSHOT, now));
    std::vector<std::uint8_t> records;
    std::size_t at = 40;
    for (std::int32_t t = 0; t < server.state().tiles_x * server.state().tiles_y; ++t) {
        const std::uint32_t length = now[at] | now[at + 1] << 8 | now[at + 2] << 16 |
                                     static_cast<std::uint32_t>(now[at + 3]) << 24;
        for (const std::int32_t s : suspects)
            if (s == t)
                records.insert(records.end(), now.begin() + at, now.begin() + at + 4 + length);
        at += 4 + length;
    }
    std::vector<std::uint64_t> hashes(static_cast<std::size_t>(16));
    for (std::int32_t t = 0; t < 4; ++t)
        ASSERT_TRUE(server.tileHash(t, hashes[static_cast<std::size_t>(t)]));
    hashes.resize(4); // a 129 map has 2 x 2 tiles
    std::size_t still = 99;
    const auto repaired = client.applyRepair(4, hash4, zstdFrame(records), hashes, &still);
    ASSERT_TRUE(repaired) << repaired.message;
    EXPECT_EQ(still, 0u);
    EXPECT_FALSE(client.state().diverged);
    EXPECT_EQ(client.state().world_hash, hash4);
    EXPECT_EQ(client.state().repairs, 1u);
}

TEST(ReplicaAbi, EveryMisuseIsRefusedByNameAndChangesNothing) {
    Replica empty;
    const ReplicaOp op = crater(40.0, 40.0);
    auto r = empty.applyOp(1, op, nullptr);
    EXPECT_EQ(r.error, ClientError::kNotSynced);
    EXPECT_NE(r.message.find("NOT_SYNCED: no world held"), std::string::npos) << r.message;
    std::vector<std::uint8_t> bytes;
    EXPECT_EQ(empty.save(TERRAIN_STATE_SNAPSHOT, bytes).error, ClientError::kNotSynced);
    EXPECT_EQ(empty.loadProcedural(5, 64).error, ClientError::kBadParameter);
    EXPECT_EQ(empty.loadProcedural(5, 129, -1.0).error, ClientError::kBadParameter);
    EXPECT_EQ(empty.resetToGenesis().error, ClientError::kNotSynced);

    Replica held;
    threeCraters(held);
    const game::ReplicaState before = held.state();
    std::vector<std::uint8_t> snapshot;
    ASSERT_TRUE(held.save(TERRAIN_STATE_SNAPSHOT, snapshot));
    const auto expectRefused = [&](const game::ClientResult& result, ClientError error,
                                   const char* words) {
        EXPECT_EQ(result.error, error) << result.message;
        EXPECT_NE(result.message.find(words), std::string::npos) << result.message;
        EXPECT_EQ(held.state().seq, before.seq);
        EXPECT_EQ(held.state().world_hash, before.world_hash);
    };
    std::vector<std::uint8_t> cut(snapshot.begin(), snapshot.end() - 1);
    expectRefused(held.load(cut), ClientError::kBadData, "BAD_DATA");
    std::vector<std::uint8_t> frame = zstdFrame(snapshot);
    frame.resize(frame.size() / 2);
    expectRefused(held.load(frame), ClientError::kBadData, "zstd");
    expectRefused(held.load(std::vector<std::uint8_t>(64, 7)), ClientError::kBadData, "magic");
    std::vector<std::uint8_t> flipped = snapshot;
    flipped[flipped.size() / 2] ^= 1;
    expectRefused(held.load(flipped), ClientError::kBadData, "BAD_DATA");
    expectRefused(held.applyOp(9, op, nullptr), ClientError::kSeqGap, "missed");
    for (const int kind : {0, 5, -1}) {
        ReplicaOp bad = op;
        bad.kind = kind;
        expectRefused(held.applyOp(4, bad, nullptr), ClientError::kBadData, "kind");
    }
    ReplicaOp outside = op;
    outside.center_x = -5;
    expectRefused(held.applyOp(4, outside, nullptr), ClientError::kBadData, "BAD_DATA");
    ReplicaOp wide = op;
    wide.radius = 1 << 30;
    expectRefused(held.applyOp(4, wide, nullptr), ClientError::kBadData, "radius");
    std::uint64_t hash = 0;
    expectRefused(held.tileHash(4, hash), ClientError::kBadParameter, "tile");
    double height = 0.0;
    expectRefused(held.heightAt(NAN, 1.0, height), ClientError::kBadParameter, "on the map");
    expectRefused(held.heightAt(200.0, 1.0, height), ClientError::kBadParameter, "on the map");
    std::vector<std::uint8_t> none;
    expectRefused(held.applyRepair(2, 0, none, {}), ClientError::kBadParameter, "seq");
    expectRefused(
        held.applyRepair(3, 0, none, std::vector<std::uint64_t>(3)), ClientError::kBadData,
        "tile_hashes");
    expectRefused(
        held.save(static_cast<terrain_state_format>(7), bytes), ClientError::kBadParameter,
        "format");
    EXPECT_EQ(terrain_replica_load(nullptr, nullptr, 0), TERRAIN_BAD_PARAMETER);
    EXPECT_STREQ(terrain_status_name(TERRAIN_SEQ_GAP), "SEQ_GAP");
    EXPECT_STREQ(terrain_status_name(TERRAIN_BAD_DATA), "BAD_DATA");

    // a stale op is ignored; the genesis of the held world is the procedural map's
    ReplicaOutcome outcome = ReplicaOutcome::kApplied;
    ASSERT_TRUE(held.applyOp(2, op, nullptr, &outcome));
    EXPECT_EQ(outcome, ReplicaOutcome::kStale);
    ASSERT_TRUE(held.resetToGenesis());
    EXPECT_EQ(held.state().seq, 0u);
    EXPECT_EQ(held.state().world_hash, before.genesis_hash);
}

} // namespace
} // namespace terrain::testing
