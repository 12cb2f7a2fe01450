// The retained op log: which states a reconnecting client may resume from.

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

} // namespace
} // namespace terrain::server
