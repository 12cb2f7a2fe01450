// The client's op pacing (op_pacing.h): how many of the waiting ops a frame applies.

#include <terrain/client/op_pacing.h>

#include <gtest/gtest.h>

namespace terrain::client {
namespace {

TEST(OpPacing, UnpacedAppliesEverythingAtOnce) {
    OpPacer off;
    EXPECT_FALSE(off.pacing().paced());
    EXPECT_EQ(off.take(0), 0u);
    EXPECT_EQ(off.take(20), 20u);
    EXPECT_EQ(off.take(100000), 100000u);
}

TEST(OpPacing, ABurstIsSpreadOverFramesAtTheRateAsked) {
    OpPacer p({.ops_per_frame = 4, .catch_up_frames = 8});
    EXPECT_EQ(p.take(0), 0u);
    EXPECT_EQ(p.take(1), 1u); // never more than waits
    EXPECT_EQ(p.take(3), 3u);
    // 20 at once: 4, 4, 4, 4, 4 (one more arriving each frame makes it 5 frames + the tail)
    std::size_t waiting = 20;
    int frames = 0;
    while (waiting > 0) {
        const std::size_t n = p.take(waiting);
        EXPECT_EQ(n, std::min<std::size_t>(4, waiting));
        waiting -= n;
        ++frames;
    }
    EXPECT_EQ(frames, 5);
}

TEST(OpPacing, ABacklogDrainsWithinTheCatchUpFramesHoweverLarge) {
    for (const std::size_t arriving : {0u, 3u, 10u, 500u})
        for (const std::size_t backlog : {5u, 33u, 100u, 1000u, 123457u}) {
            // ops keep arriving (beyond the pacing's own rate for the larger counts): the backlog
            // present at a frame is gone within catch_up_frames frames
            OpPacer p({.ops_per_frame = 4, .catch_up_frames = 8});
            std::size_t waiting = backlog;
            std::size_t old_left = backlog; // of the first backlog, not yet applied (FIFO)
            int frames = 0;
            while (old_left > 0) {
                const std::size_t n = p.take(waiting);
                ASSERT_GE(n, std::min<std::size_t>(4, waiting));
                waiting -= n;
                old_left -= std::min(old_left, n);
                waiting += arriving;
                ++frames;
            }
            EXPECT_LE(frames, 8) << backlog << " waiting, " << arriving << " arriving a frame";
        }
}

} // namespace
} // namespace terrain::client
