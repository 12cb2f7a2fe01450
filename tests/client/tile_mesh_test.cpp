// A tile's index list alone: dense slots, counted writes, keys through growth, holes and
// shrinking.

#include <terrain/roam/tile_mesh.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <vector>

namespace terrain::testing {
namespace {

TEST(RoamTileMesh, SlotsStayDenseAndEveryWriteIsCounted) {
    roam::TileMesh mesh;
    for (std::uint32_t k = 1; k <= 100; ++k)
        mesh.add(k, {k, k + 1, k + 2});
    mesh.takeChanges();
    const std::uint64_t before = mesh.counters().index_bytes_written;
    std::mt19937_64 rng(1);
    std::set<std::uint32_t> gone;
    while (gone.size() < 40)
        gone.insert(static_cast<std::uint32_t>(1 + rng() % 100));
    for (const std::uint32_t k : gone)
        EXPECT_TRUE(mesh.remove(k));
    EXPECT_FALSE(mesh.remove(*gone.begin()));
    mesh.add(1000, {1000, 1001, 1002}); // takes the last freed slot
    mesh.fillHoles();
    ASSERT_EQ(mesh.slotCount(), 61u);
    EXPECT_EQ(mesh.triangleCount(), 61u);
    // every remaining triangle is there exactly once, with its own indices
    std::multiset<std::uint32_t> firsts;
    const auto idx = mesh.indices();
    for (std::size_t i = 0; i < idx.size(); i += 3) {
        EXPECT_EQ(idx[i + 1], idx[i] + 1);
        firsts.insert(idx[i]);
    }
    for (std::uint32_t k = 1; k <= 100; ++k) {
        EXPECT_EQ(firsts.count(k), gone.count(k) ? 0u : 1u) << k;
        EXPECT_EQ(mesh.contains(k), gone.count(k) == 0);
    }
    EXPECT_EQ(firsts.count(1000), 1u);
    // 40 frees + 1 add + at most 39 moves, 12 bytes each: never a full rewrite
    const std::uint64_t written = mesh.counters().index_bytes_written - before;
    EXPECT_LE(written, (40u + 1u + 39u) * roam::TileMesh::kIndexBytesPerTriangle);
    EXPECT_TRUE(mesh.dirty());
    EXPECT_FALSE(mesh.rewritten());
    EXPECT_GT(mesh.dirtyUploadBytes(), 0u);
    EXPECT_LE(mesh.dirtyUploadBytes(), 61u * roam::TileMesh::kIndexBytesPerTriangle);
    mesh.takeChanges();
    EXPECT_FALSE(mesh.dirty());
    EXPECT_EQ(mesh.dirtyUploadBytes(), 0u);
}

TEST(RoamTileMesh, KeysFindTheirTrianglesThroughGrowthHolesAndShrinking) {
    // the key table (any size, linear probing with wrap-around, backward-shift deletion) against
    // a map, through growth, mass removals, fillHoles and shrink; memory stays near 12 bytes a
    // triangle
    roam::TileMesh mesh;
    std::map<std::uint32_t, std::uint32_t> expected; // key -> first index
    std::mt19937_64 rng(7);
    const auto check = [&] {
        ASSERT_EQ(mesh.triangleCount(), expected.size());
        for (const auto& [key, first] : expected)
            ASSERT_TRUE(mesh.contains(key)) << key;
        const auto idx = mesh.indices();
        std::map<std::uint32_t, int> seen;
        for (std::size_t i = 0; i < idx.size(); i += 3)
            if (idx[i + 1] != 0)
                ++seen[idx[i]];
        for (const auto& [key, first] : expected)
            ASSERT_EQ(seen[first], 1) << key;
        // a vertex is referenced exactly while a live triangle uses it
        std::map<std::uint32_t, int> uses;
        for (const auto& [key, first] : expected)
            for (std::uint32_t k = 0; k < 3; ++k)
                ++uses[first + k];
        for (std::uint32_t v = 0; v < 200010; v += 7)
            ASSERT_EQ(mesh.referenced(v), uses.count(v) != 0) << v;
        // the drawn list names the same vertices through their slots, each slot one vertex's
        const auto drawn = mesh.drawnIndices();
        ASSERT_EQ(drawn.size(), idx.size());
        for (std::size_t i = 0; i < idx.size(); i += 3) {
            if (idx[i + 1] == 0)
                continue;
            for (std::size_t k = 0; k < 3; ++k)
                ASSERT_EQ(mesh.vertexOfSlot(drawn[i + k]), idx[i + k]) << i;
        }
        // after fillHoles, at most half the slots (or 256) are free
        ASSERT_LE(mesh.drawnVertexCount(), std::max(2 * uses.size(), uses.size() + 256));
    };
    for (int round = 0; round < 4; ++round) {
        for (int i = 0; i < 30000; ++i) {
            const auto key = static_cast<std::uint32_t>(rng() % 200000);
            if (expected.count(key) != 0) {
                EXPECT_TRUE(mesh.remove(key));
                expected.erase(key);
            } else {
                mesh.add(key, {key + 1, key + 2, key + 3});
                expected[key] = key + 1;
            }
        }
        mesh.fillHoles();
        check();
        // most go: the table must still find the rest across the holes left in probe runs
        for (auto it = expected.begin(); it != expected.end();)
            if (rng() % 10 != 0) {
                EXPECT_TRUE(mesh.remove(it->first));
                EXPECT_FALSE(mesh.contains(it->first));
                it = expected.erase(it);
            } else {
                ++it;
            }
        mesh.fillHoles();
        check();
        mesh.shrink();
        check();
    }
    for (int i = 0; i < 60000; ++i) {
        const auto key = static_cast<std::uint32_t>(1000000 + i);
        mesh.add(key, {key + 1, key + 2, key + 3});
        expected[key] = key + 1;
    }
    mesh.fillHoles();
    check();
    // 12 bytes of indices, 12 of drawn indices, 4 of key and at most 16 of table entry per
    // triangle, a quarter of growth on the lists; a byte of reference count per vertex index up
    // to the largest (here a million: real tiles' arrays hold about half as many vertices as
    // triangles); and the slots: per used vertex (three a triangle here) at most 8 bytes doubled
    // by growth, a 4-byte page number per 64 vertex indices, list of slots taken
    EXPECT_LE(
        mesh.memoryBytes(), expected.size() * 48 + 4096 + (1060003 + 1) * 5 / 4 + 64 +
                                expected.size() * 3 * 8 * 2 + (1060003 / 64 + 1) * 4 * 2 +
                                (expected.size() * 3 / 4 + 256) * 4 * 2);
}

} // namespace
} // namespace terrain::testing
