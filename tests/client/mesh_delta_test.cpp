// The hand-over of a tessellator's tiles to another thread's copy (DeltaCollector -> MeshDelta
// -> DrawnMesh), the deltas written by three threads: through a battle flight, a whip, a teleport
// and a new world, with deltas taken at random and the rest superseded, the copy equals the
// tessellator's tiles at the step of the last delta taken (lists, vertices as drawn, versions,
// visibility), and a renderer that follows the copy's change marks holds the same bytes.

#include "support/drawn_mesh_checks.h"
#include "support/golden_shots.h"
#include "support/terrain_builders.h"

#include <terrain/roam/delta_collector.h>
#include <terrain/roam/drawn_mesh.h>
#include <terrain/roam/tessellator.h>
#include <terrain/surface_query.h>
#include <terrain/task_runner.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace terrain::testing {
namespace {

using roam::Camera;
using roam::DrawnMesh;
using roam::DrawVertex;
using roam::MeshDelta;
using roam::Tessellator;

Camera camera(glm::dvec3 eye, glm::dvec3 target) {
    Camera c;
    c.eye = eye;
    c.forward = target - eye;
    c.fovy_radians = 60.0 * M_PI / 180.0;
    c.viewport_width = 640;
    c.viewport_height = 360;
    c.near_plane = 0.25;
    return c;
}

Terrain world(std::uint64_t seed, std::int32_t size) {
    Terrain t = makeHills(seed, size, size);
    CraterSeries s;
    s.seed = seed;
    s.count = 60;
    applyAll(t, randomCraters(t.spec(), s));
    return t;
}

/// A renderer's buffers, kept from the copy's change marks alone.
struct FakeRenderer {
    std::vector<std::vector<std::uint32_t>> indices;
    std::vector<std::vector<DrawVertex>> vertices;
    std::uint64_t index_bytes = 0;
    std::uint64_t vertex_bytes = 0;

    void sync(DrawnMesh& copy) {
        if (indices.size() != static_cast<std::size_t>(copy.tileCount())) {
            indices.assign(static_cast<std::size_t>(copy.tileCount()), {});
            vertices.assign(static_cast<std::size_t>(copy.tileCount()), {});
        }
        for (std::int32_t t = 0; t < copy.tileCount(); ++t) {
            auto& ib = indices[static_cast<std::size_t>(t)];
            const auto list = copy.indices(t);
            if (copy.indicesRewritten(t)) {
                ib.assign(list.begin(), list.end());
                index_bytes += list.size() * 4;
            } else {
                ib.resize(list.size());
                for (const std::uint32_t page : copy.dirtyPages(t)) {
                    const std::size_t from = std::size_t{page} * MeshDelta::kPageIndices;
                    for (std::size_t i = from; i < std::min(list.size(), from + 96); ++i)
                        ib[i] = list[i];
                    index_bytes += 96 * 4;
                }
            }
            auto& vb = vertices[static_cast<std::size_t>(t)];
            const auto held = copy.vertices(t);
            if (copy.verticesAllChanged(t)) {
                vb.assign(held.begin(), held.end());
                vertex_bytes += held.size() * 16;
            } else {
                vb.resize(held.size());
                for (const roam::VertexRange& r : copy.vertexChanges(t)) {
                    for (std::uint32_t i = r.begin; i < std::min<std::size_t>(r.end, held.size());
                         ++i)
                        vb[i] = held[i];
                    vertex_bytes += std::uint64_t{r.end - r.begin} * 16;
                }
            }
            copy.takeChanges(t);
        }
    }

    std::string difference(const DrawnMesh& copy) const {
        for (std::int32_t t = 0; t < copy.tileCount(); ++t) {
            const auto list = copy.indices(t);
            const auto& ib = indices[static_cast<std::size_t>(t)];
            if (ib.size() != list.size() || !std::equal(ib.begin(), ib.end(), list.begin()))
                return "tile " + std::to_string(t) + ": renderer's index list";
            const auto held = copy.vertices(t);
            const auto& vb = vertices[static_cast<std::size_t>(t)];
            if (vb.size() != held.size())
                return "tile " + std::to_string(t) + ": renderer's vertex count";
            for (std::size_t i = 0; i < held.size(); ++i)
                if (!sameBits(vb[i], held[i]))
                    return "tile " + std::to_string(t) + ": renderer's vertex " + std::to_string(i);
        }
        return "";
    }
};

TEST(MeshDelta, ACopyFedAnySubsequenceOfDeltasEqualsTheTessellatorAtTheLastOnesStep) {
    Terrain t = world(23, 257);
    Terrain other = world(5, 321); // 5 x 5 tiles: a new world mid-flight
    Tessellator tess(t, {});
    roam::DeltaCollector collector;
    // the contents written by three threads, in uneven groups of tiles (the serial path is the
    // next test's, and the worker's at one thread)
    ThreadPool pool(3);
    collector.setTaskRunner(&pool);
    MeshDelta delta;
    DrawnMesh copy;
    FakeRenderer renderer;
    std::mt19937_64 rng(11);
    std::bernoulli_distribution taken(0.4);
    std::bernoulli_distribution synced(0.5);
    Terrain* now = &t;
    int applied = 0;
    int superseded = 0;
#if defined(__SANITIZE_ADDRESS__)
    constexpr int kLast = 64; // five times slower: ten frames of the new world, not twenty-five
    constexpr int kNormalsEvery = 6;
#else
    constexpr int kLast = 79;
    constexpr int kNormalsEvery = 3;
#endif
    for (int f = 0; f <= kLast; ++f) {
        double x = 30.0 + (f % 40) * 4.0;
        double y = 70.0 + (f % 40) * 2.0;
        double yaw = std::atan2(0.45, 0.9);
        if (f >= 25 && f < 37)
            yaw += (f - 25) * 41.0 * M_PI / 180.0; // a whip
        if (f >= 37 && f < 40) {
            x = 200.0; // a teleport
            y = 40.0;
        }
        if (f == 55) {
            now = &other; // another world, bigger
            tess.rebind(other);
        }
        if (f < 25 || f >= 40)
            shootAhead(*now, tess, rng, x, y);
        const glm::dvec3 eye(x, y, surfaceHeight(*now, x, y) + 6.0);
        tess.update(camera(eye, eye + glm::dvec3(std::cos(yaw), std::sin(yaw), -0.25)));
        collector.collect(tess, *now, delta);
        EXPECT_EQ(delta.step, static_cast<std::uint64_t>(f + 1));
        // the frame thread took this one, or the next supersedes it
        if (!taken(rng) && f != 55 && f != kLast) {
            ++superseded;
            continue;
        }
        ASSERT_TRUE(copy.apply(delta));
        collector.delivered();
        ++applied;
        // normals (the costly part) at every third copy (sixth under a sanitizer) and the last
        ASSERT_EQ(difference(copy, tess, *now, applied % kNormalsEvery == 0 || f == kLast), "")
            << "after step " << f + 1;
        if (synced(rng) || f == kLast) {
            renderer.sync(copy);
            ASSERT_EQ(renderer.difference(copy), "") << "after step " << f + 1;
        }
    }
    EXPECT_GT(applied, 15);
    EXPECT_GT(superseded, 15);
    // an old delta is refused
    MeshDelta old;
    old.step = 3;
    old.tile_count = copy.tileCount();
    old.visible.assign(static_cast<std::size_t>(copy.tileCount()), 0);
    EXPECT_FALSE(copy.apply(old));
    EXPECT_EQ(difference(copy, tess, *now), "");
}

TEST(MeshDelta, WithASmallPoolBlocksComeAndGoAndTheCopyKeepsUp) {
    // a pool of 48 blocks over a flight: blocks evicted and grains gone every frame (vertex
    // versions that move with nothing to copy), every delta taken
    Terrain t = world(23, 257);
    roam::TessellatorOptions o;
    o.max_detail_blocks = 48;
    Tessellator tess(t, o);
    roam::DeltaCollector collector;
    MeshDelta delta;
    DrawnMesh copy;
    std::int64_t evicted = 0;
    for (int f = 0; f < 30; ++f) {
        const double x = 40.0 + f * 6.0;
        const double y = 60.0 + f * 4.0;
        const glm::dvec3 eye(x, y, surfaceHeight(t, x, y) + 5.0);
        evicted += tess.update(camera(eye, eye + glm::dvec3(0.8, 0.6, -0.3))).blocks_evicted;
        collector.delivered();
        collector.collect(tess, t, delta);
        ASSERT_TRUE(copy.apply(delta));
        ASSERT_EQ(difference(copy, tess, t, f % 5 == 0), "") << "after step " << f + 1;
    }
    EXPECT_GT(evicted, 50);
}

TEST(MeshDelta, TheCopysArraysHoldTheVerticesATriangleUsesAndLittleElse) {
    // most of a tessellator's array is drawn by no triangle (the base grid a coarse tile skips,
    // the grains' points a block's triangles do not reach): the copy holds a vertex at a slot
    // from when a triangle uses it, and gives the slot to another once none does. The copy is
    // taken every step, then only every ninth (more uses change between two deltas than a tile
    // lists: every vertex is looked at); then the camera leaves (most slots free up: the tile
    // is laid out afresh)
    Terrain t = world(23, 257);
    Tessellator tess(t, {});
    roam::DeltaCollector collector;
    MeshDelta delta;
    DrawnMesh copy;
    std::size_t held_max = 0;
    std::size_t array_max = 0;
    std::size_t held_last = 0;
    for (int f = 0; f < 60; ++f) {
        const double x = f < 45 ? 40.0 + f * 4.0 : 220.0;
        const double y = f < 45 ? 60.0 + f * 3.0 : 220.0;
        const glm::dvec3 eye(x, y, surfaceHeight(t, x, y) + (f < 45 ? 5.0 : 120.0));
        tess.update(camera(eye, eye + glm::dvec3(0.8, 0.6, -0.3)));
        if (f >= 20 && f < 45 && f % 9 != 0)
            continue;
        collector.delivered();
        collector.collect(tess, t, delta);
        ASSERT_TRUE(copy.apply(delta));
        ASSERT_EQ(difference(copy, tess, t, f % 3 == 0), "") << "after step " << f + 1;
        std::size_t held = 0;
        std::size_t array = 0;
        for (std::int32_t k = 0; k < copy.tileCount(); ++k) {
            const std::set<std::uint32_t> named(copy.indices(k).begin(), copy.indices(k).end());
            const std::size_t slots = copy.vertices(k).size();
            // a free slot for every two held, or 256 (then the tile is laid out afresh)
            ASSERT_LE(slots, std::max(2 * named.size(), named.size() + 256))
                << "tile " << k << " after step " << f + 1;
            held += slots;
            array += static_cast<std::size_t>(tess.tileVertexCount(k));
        }
        EXPECT_EQ(held, roam::DeltaCollector::slotCount(tess));
        EXPECT_EQ(array, roam::DeltaCollector::tessellatorVertexCount(tess));
        EXPECT_LT(held * 3, array) << "after step " << f + 1;
        held_max = std::max(held_max, held);
        array_max = std::max(array_max, array);
        held_last = held;
    }
    EXPECT_LT(held_last * 10, held_max) << "the copy shrinks with the detail drawn";
    EXPECT_GT(array_max, static_cast<std::size_t>(tess.tileCount() * roam::kTileBaseVertices))
        << "detail blocks came into the arrays";
}

TEST(MeshDelta, AMalformedDeltaIsRefusedWhole) {
    const Terrain t = world(23, 257);
    Tessellator tess(t, {});
    roam::DeltaCollector collector;
    MeshDelta delta;
    DrawnMesh copy;
    const glm::dvec3 eye(100.0, 100.0, surfaceHeight(t, 100.0, 100.0) + 8.0);
    tess.update(camera(eye, eye + glm::dvec3(1.0, 0.3, -0.3)));
    collector.collect(tess, t, delta);
    ASSERT_FALSE(delta.tiles.empty());
    ASSERT_FALSE(delta.pages.empty());
    ASSERT_FALSE(delta.runs.empty());
    const auto refused = [&](auto&& breakIt) {
        MeshDelta bad = delta;
        breakIt(bad);
        DrawnMesh fresh;
        return !fresh.apply(bad) && fresh.tileCount() == 0;
    };
    EXPECT_TRUE(refused([](MeshDelta& d) { d.tiles[0].tile = d.tile_count; }));
    EXPECT_TRUE(refused([](MeshDelta& d) { d.pages[0] = 1u << 20; }));
    EXPECT_TRUE(refused([](MeshDelta& d) { d.runs[0].end = d.tiles[0].vertex_count + 1; }));
    EXPECT_TRUE(refused([](MeshDelta& d) { d.runs.back().at = d.vertices.size(); }));
    EXPECT_TRUE(refused([](MeshDelta& d) { d.visible.pop_back(); }));
    EXPECT_TRUE(refused([](MeshDelta& d) { d.page_indices.pop_back(); }));
    EXPECT_TRUE(refused([](MeshDelta& d) { d.tiles[0].page_count += 1u << 20; }));
    EXPECT_TRUE(copy.apply(delta)) << "the delta as written";
}

TEST(MeshDelta, ASettledViewHandsOverNothingButVisibility) {
    const Terrain t = world(23, 257);
    Tessellator tess(t, {});
    roam::DeltaCollector collector;
    MeshDelta delta;
    DrawnMesh copy;
    const glm::dvec3 eye(100.0, 100.0, surfaceHeight(t, 100.0, 100.0) + 8.0);
    const Camera still = camera(eye, eye + glm::dvec3(1.0, 0.3, -0.3));
    for (int f = 0; f < 60; ++f) {
        tess.update(still);
        collector.delivered();
        collector.collect(tess, t, delta);
        copy.apply(delta);
    }
    // settled: nothing to copy but the visibility bytes
    EXPECT_TRUE(delta.tiles.empty());
    EXPECT_EQ(delta.payloadBytes(), 0u);
    EXPECT_EQ(delta.visible.size(), static_cast<std::size_t>(tess.tileCount()));
    // one crater: only the tiles it touched, a small part of the mesh
    Terrain changed = t;
    tess.rebind(changed);
    tess.update(still);
    collector.delivered();
    collector.collect(tess, changed, delta);
    copy.apply(delta);
    OpRequest r;
    r.x = 120.0;
    r.y = 106.0;
    r.radius = 3.0;
    r.height = 1.2;
    r.strength = 0.4;
    auto effect = changed.apply(*quantizeOp(r, changed.spec()));
    ASSERT_TRUE(static_cast<bool>(effect));
    tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
    tess.update(still);
    collector.delivered();
    collector.collect(tess, changed, delta);
    ASSERT_FALSE(delta.tiles.empty());
    EXPECT_LT(delta.tiles.size(), static_cast<std::size_t>(tess.tileCount()));
    std::uint64_t whole = 0;
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile)
        whole += copy.vertices(tile).size() * sizeof(DrawVertex) +
                 copy.indices(tile).size() * sizeof(std::uint32_t);
    EXPECT_LT(delta.payloadBytes() * 4, whole);
    ASSERT_TRUE(copy.apply(delta));
    EXPECT_EQ(difference(copy, tess, changed), "");
}

} // namespace
} // namespace terrain::testing
