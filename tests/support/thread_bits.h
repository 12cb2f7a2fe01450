#pragma once

// The same bits at every thread count: a recorded sequence of ops replayed through
// Terrain::apply with a thread pool must give the serial path's world hash after every op and
// its tile hashes at the end (GoogleTest assertions).

#include <terrain/deform_op.h>
#include <terrain/task_runner.h>
#include <terrain/terrain.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <utility>
#include <vector>

namespace terrain::testing {

/// Replays `applied` (runBattle's record) on `start` with a pool of `threads` and checks the
/// world hash after every op, then every tile hash against `expected` (the serial result).
inline void expectSameBitsWithThreads(
    Terrain start,
    const std::vector<std::pair<DeformOp, std::uint64_t>>& applied,
    const Terrain& expected,
    unsigned threads) {
    ThreadPool pool(threads);
    for (std::size_t i = 0; i < applied.size(); ++i) {
        ASSERT_TRUE(start.apply(applied[i].first, &pool).ok()) << "op " << i;
        ASSERT_EQ(start.worldHash(), applied[i].second)
            << "op " << i << " at " << threads << " threads";
    }
    for (std::int32_t tile = 0; tile < expected.spec().tileCount(); ++tile)
        ASSERT_EQ(start.tileHash(tile), expected.tileHash(tile)) << "tile " << tile;
    EXPECT_EQ(start.patchCount(), expected.patchCount());
}

} // namespace terrain::testing
