// CraterLatency: frames from an op's apply to the first frame that drew it and to the first that
// drew it converged, with the largest error bound drawn meanwhile; ops of the starting state not
// counted; the history it keeps bounded by the oldest op not converged.

#include <terrain/client/crater_latency.h>

#include <gtest/gtest.h>

#include <vector>

namespace terrain::client {
namespace {

TEST(CraterLatency, CountsFramesToDrawnAndToConvergedPerOpWithTheWorstBoundMeanwhile) {
    CraterLatency l;
    l.start(10);      // a late joiner's snapshot at seq 10
    l.applied(1, 12); // ops 11, 12
    l.drawn(1, 10, 10, 1.0);
    l.applied(2, 12);
    l.drawn(2, 12, 10, 7.0); // both drawn a frame after
    l.applied(3, 13);        // op 13
    l.drawn(3, 12, 11, 3.0); // 11 converged
    l.applied(4, 13);
    l.drawn(4, 13, 11, 2.0); // 13 drawn
    l.drawn(5, 13, 13, 1.5); // 12 and 13 converged
    EXPECT_EQ(l.framesToDrawn(), (std::vector<double>{1, 1, 1}));
    EXPECT_EQ(l.framesToConverged(), (std::vector<double>{2, 4, 2}));
    // op 11 and 12 were applied in frame 1: frames 1-3 and 1-5 drew bounds up to 7; op 13
    // (frame 3 on) only 3
    EXPECT_EQ(l.boundUntilConverged(), (std::vector<double>{7.0, 7.0, 3.0}));
}

TEST(CraterLatency, AMeshPastTheAppliedSeqCountsOnlyWhatWasApplied) {
    // (a worker's world can be ahead of the frame's count when ops are applied on another
    // thread: nothing is counted before the frame saw it applied)
    CraterLatency l;
    l.start(0);
    l.drawn(1, 5, 5, 1.0);
    EXPECT_TRUE(l.framesToDrawn().empty());
    l.applied(2, 5);
    l.drawn(2, 5, 5, 1.0);
    EXPECT_EQ(l.framesToDrawn().size(), 5u);
    EXPECT_EQ(l.framesToConverged(), (std::vector<double>(5, 0.0)));
}

TEST(CraterLatency, ALongSessionKeepsItsHistoryBoundedAndItsCountsRight) {
    CraterLatency l;
    l.start(0);
    // 100,000 frames, an op a frame, each drawn 2 frames and converged 5 frames after
    for (std::int64_t f = 1; f <= 100'000; ++f) {
        l.applied(f, static_cast<std::uint64_t>(f));
        l.drawn(
            f, static_cast<std::uint64_t>(std::max<std::int64_t>(f - 2, 0)),
            static_cast<std::uint64_t>(std::max<std::int64_t>(f - 5, 0)),
            static_cast<double>(f % 7));
    }
    ASSERT_EQ(l.framesToDrawn().size(), 99'998u);
    ASSERT_EQ(l.framesToConverged().size(), 99'995u);
    for (std::size_t i = 0; i < l.framesToConverged().size(); ++i) {
        ASSERT_EQ(l.framesToDrawn()[i], 2.0);
        ASSERT_EQ(l.framesToConverged()[i], 5.0);
        // op i + 1, applied in frame i + 1, converged in frame i + 6: the bounds of those six
        // frames are six of the seven residues, a 6 among them unless they start at a 0
        ASSERT_EQ(l.boundUntilConverged()[i], (i + 1) % 7 == 0 ? 5.0 : 6.0) << i;
    }
    EXPECT_LE(l.heldEntries(), 16u) << "the history grows with the session";
}

} // namespace
} // namespace terrain::client
