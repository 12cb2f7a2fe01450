// The tiles' vertex arrays alone: segments keep their place, holes are reused by size, and the
// changed ranges a renderer reads.

#include <terrain/roam/tile_vertex_arrays.h>

#include <gtest/gtest.h>

#include <cstdint>

namespace terrain::testing {
namespace {

using roam::kGrainVertices;
using roam::kTileBaseVertices;
using roam::TileVertexArrays;

TEST(RoamTileVertexArrays, SegmentsFollowTheBaseGridAndKeepTheirPlace) {
    TileVertexArrays v;
    v.reset(2);
    EXPECT_EQ(v.vertexCount(1), kTileBaseVertices);
    EXPECT_TRUE(v.allChanged(1)) << "a new tile loads whole";
    const std::uint32_t version = v.version(1);
    const std::int32_t a = v.attach(1, 0, 10); // 25 vertices
    const std::int32_t b = v.attach(1, 2, 11); // 208
    const std::int32_t c = v.attach(1, 1, 12); // 56
    EXPECT_EQ(v.vertexCount(1), kTileBaseVertices + 25 + 208 + 56);
    EXPECT_EQ(v.firstVertex(1, a), static_cast<std::uint32_t>(kTileBaseVertices));
    EXPECT_EQ(v.firstVertex(1, b), static_cast<std::uint32_t>(kTileBaseVertices + 25));
    EXPECT_EQ(v.firstVertex(1, c), static_cast<std::uint32_t>(kTileBaseVertices + 25 + 208));
    EXPECT_EQ(v.version(1), version + 3);
    EXPECT_EQ(v.vertexCount(0), kTileBaseVertices) << "the other tile is untouched";

    // a grain that goes leaves a hole; the next of its size takes it, not one of another size
    v.detach(1, 2, b);
    EXPECT_EQ(v.segments(1)[static_cast<std::size_t>(b)].chunk, -1);
    EXPECT_EQ(v.vertexCount(1), kTileBaseVertices + 25 + 208 + 56) << "a hole keeps its place";
    const std::int32_t d = v.attach(1, 1, 13);
    EXPECT_NE(d, b) << "a grain-1 segment does not fit a grain-2 hole";
    const std::int32_t e = v.attach(1, 2, 14);
    EXPECT_EQ(e, b);
    EXPECT_EQ(v.segments(1)[static_cast<std::size_t>(e)].chunk, 14);
    EXPECT_EQ(v.firstVertex(1, c), static_cast<std::uint32_t>(kTileBaseVertices + 25 + 208))
        << "no segment moved";
    v.rechunk(1, e, 3);
    EXPECT_EQ(v.segments(1)[static_cast<std::size_t>(e)].chunk, 3);
    v.clearTile(1);
    EXPECT_EQ(v.vertexCount(1), kTileBaseVertices);
    EXPECT_TRUE(v.segments(1).empty());
}

TEST(RoamTileVertexArrays, ChangesAreRangesJoinedWhenTheyContinueAndEverythingPastTheLimit) {
    TileVertexArrays v;
    v.reset(1);
    v.mark(0, 0, 10);
    EXPECT_TRUE(v.changes(0).empty()) << "everything changed already: nothing to list";
    v.take(0);
    EXPECT_FALSE(v.allChanged(0));
    v.mark(0, 0, 10);
    v.mark(0, 10, 20); // continues the last
    v.mark(0, 5, 5);   // empty
    v.mark(0, 100, 120);
    ASSERT_EQ(v.changes(0).size(), 2u);
    EXPECT_EQ(v.changes(0)[0].begin, 0u);
    EXPECT_EQ(v.changes(0)[0].end, 20u);
    EXPECT_EQ(v.changes(0)[1].begin, 100u);
    const std::int32_t s = v.attach(0, 1, 0);
    ASSERT_EQ(v.changes(0).size(), 3u) << "a grain that joins marks its vertices";
    EXPECT_EQ(v.changes(0)[2].begin, v.firstVertex(0, s));
    EXPECT_EQ(
        v.changes(0)[2].end, v.firstVertex(0, s) + static_cast<std::uint32_t>(kGrainVertices[1]));
    v.detach(0, 1, s);
    EXPECT_EQ(v.changes(0).size(), 3u) << "a grain that goes marks nothing";
    v.take(0);
    EXPECT_TRUE(v.changes(0).empty());
    for (std::uint32_t i = 0; i <= TileVertexArrays::kMaxRanges; ++i)
        v.mark(0, 2 * i, 2 * i + 1);
    EXPECT_TRUE(v.allChanged(0)) << "no renderer took them: the tile loads whole";
    EXPECT_TRUE(v.changes(0).empty());
}

} // namespace
} // namespace terrain::testing
