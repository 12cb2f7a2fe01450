// The retained op log: which states a reconnecting client may resume from.

#include "support/terrain_builders.h"

#include <terrain/server/authority.h>
#include <terrain/server/op_log.h>

#include <gtest/gtest.h>

namespace terrain::server {
namespace {

LoggedOp entry(std::uint64_t seq) {
    LoggedOp e;
    e.seq = seq;
    e.op.radius = static_cast<std::int32_t>(seq);
    e.world_hash = 1000 + seq;
    return e;
}

TEST(OpLog, KeepsTheLastCapacityOpsAndTheStateBeforeThem) {
    OpLog log(4, 10, 999);
    std::uint64_t h = 0;
    EXPECT_EQ(log.resumableFrom(), 10u);
    ASSERT_TRUE(log.hashAt(10, h));
    EXPECT_EQ(h, 999u);
    EXPECT_FALSE(log.hashAt(11, h));
    for (std::uint64_t s = 11; s <= 14; ++s)
        log.push(entry(s));
    // four ops fit: every state from 10 on is resumable
    EXPECT_EQ(log.resumableFrom(), 10u);
    ASSERT_TRUE(log.hashAt(10, h));
    EXPECT_EQ(h, 999u);
    ASSERT_TRUE(log.hashAt(14, h));
    EXPECT_EQ(h, 1014u);
    log.push(entry(15)); // op 11 leaves: state 11 is now the oldest
    EXPECT_EQ(log.resumableFrom(), 11u);
    EXPECT_FALSE(log.hashAt(10, h));
    ASSERT_TRUE(log.hashAt(11, h));
    EXPECT_EQ(h, 1011u);
    for (std::uint64_t s = 12; s <= 15; ++s)
        EXPECT_EQ(log.at(s).op.radius, static_cast<std::int32_t>(s));
    EXPECT_FALSE(log.hashAt(16, h));
}

TEST(OpLog, CapacityOneStillResumesFromTheLastState) {
    OpLog log(1, 0, 7);
    for (std::uint64_t s = 1; s <= 50; ++s) {
        log.push(entry(s));
        std::uint64_t h = 0;
        EXPECT_EQ(log.resumableFrom(), s - 1);
        ASSERT_TRUE(log.hashAt(s, h));
        EXPECT_EQ(h, 1000 + s);
        EXPECT_EQ(log.at(s).seq, s);
    }
}

TEST(Authority, RestoresItsLogFromARecoveredHistoryOrRefusesItByName) {
    // what a restarted server does with the journal's history: the last ops and their hashes
    Terrain t = testing::makeHills(3, 129, 129);
    Authority live(t, 0, 64);
    std::vector<LoggedOp> ops;
    for (int i = 0; i < 10; ++i) {
        OpRequest r{OpKind::kCrater, 20.0 + 8.0 * i, 50.0, 3.0, 1.0, 0.5};
        auto a = live.apply(r);
        ASSERT_TRUE(a.ok()) << a.error().message;
        ops.push_back({a->seq, a->op, a->world_hash});
    }
    const std::uint64_t base_hash = ops[3].world_hash; // the state at seq 4
    const std::span<const LoggedOp> after4(ops.data() + 4, 6);

    Authority restarted(live.terrain(), 10, 4); // a log smaller than the history
    ASSERT_TRUE(restarted.restoreLog(4, base_hash, after4).ok());
    EXPECT_EQ(restarted.log().resumableFrom(), 6u); // the last 4 ops kept
    std::uint64_t h = 0;
    ASSERT_TRUE(restarted.log().hashAt(6, h));
    EXPECT_EQ(h, ops[5].world_hash);
    EXPECT_EQ(restarted.log().at(10).op, ops[9].op);

    Authority wide(live.terrain(), 10, 64);
    ASSERT_TRUE(wide.restoreLog(4, base_hash, after4).ok());
    EXPECT_EQ(wide.log().resumableFrom(), 4u);
    ASSERT_TRUE(wide.log().hashAt(4, h));
    EXPECT_EQ(h, base_hash);

    // refused, and the log left as it was
    Authority bad(live.terrain(), 10, 64);
    auto short_by_one = bad.restoreLog(5, base_hash, after4);
    ASSERT_FALSE(short_by_one.ok());
    EXPECT_EQ(short_by_one.error().code, ErrorCode::kOutOfRange);
    std::vector<LoggedOp> wrong_hash(after4.begin(), after4.end());
    wrong_hash.back().world_hash ^= 1;
    auto mismatch = bad.restoreLog(4, base_hash, wrong_hash);
    ASSERT_FALSE(mismatch.ok());
    EXPECT_EQ(mismatch.error().code, ErrorCode::kHashMismatch);
    std::vector<LoggedOp> gap(after4.begin(), after4.end());
    gap[2].seq = 99;
    EXPECT_FALSE(bad.restoreLog(4, base_hash, gap).ok());
    EXPECT_EQ(bad.log().resumableFrom(), 10u);
}

} // namespace
} // namespace terrain::server
