// The tessellator's output, pinned: after every frame of three flights over a cratered world (a
// cruise, a whip with a teleport, and a low battle flight with craters landing ahead), each
// tile's index list, vertex array, vertex version and visibility are hashed (the layout a
// renderer uploads), and so is the set of leaf triangles, sorted (the mesh itself, whatever its
// layout), and both are compared with tests/data/golden_mesh.txt. A refactor must not change
// one index or vertex; a change of layout alone (the order of equal priorities, the vertex
// arrays) keeps the triangle sets. The first differing frame is named.
//
// Regenerate (only when the output changes on purpose, and say so in the commit):
//   TERRAIN_REGENERATE_GOLDEN_MESH=1 ./build/release/tests/roam_tests
//       --gtest_filter=GoldenMesh.Regenerate

#include "support/golden_shots.h"
#include "support/terrain_builders.h"

#include <terrain/roam/tessellator.h>
#include <terrain/surface_query.h>
#include <terrain/task_runner.h>

#include <gtest/gtest.h>
#include <xxhash.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace terrain::testing {
namespace {

namespace fs = std::filesystem;
using roam::Camera;
using roam::Tessellator;

const fs::path kGoldenFile = fs::path(TERRAIN_TEST_DATA_DIR) / "golden_mesh.txt";

struct FrameHash {
    std::string flight;
    int frame = 0;
    std::uint64_t hash = 0;
    std::int64_t triangles = 0;
    std::uint64_t set_hash = 0;
};

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

// little-endian fields, whatever the host
void put(XXH3_state_t* state, std::uint64_t v) {
    std::uint8_t bytes[8];
    for (int i = 0; i < 8; ++i)
        bytes[i] = static_cast<std::uint8_t>(v >> (8 * i));
    XXH3_64bits_update(state, bytes, sizeof bytes);
}

std::uint64_t meshHash(const Tessellator& tess) {
    XXH3_state_t* state = XXH3_createState();
    XXH3_64bits_reset(state);
    std::vector<roam::TileVertex> vertices;
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile) {
        put(state, static_cast<std::uint64_t>(tile));
        put(state, tess.tileVisible(tile) ? 1 : 0);
        put(state, tess.tileVertexVersion(tile));
        const roam::TileMesh& mesh = tess.tileMesh(tile);
        put(state, mesh.slotCount());
        for (std::uint32_t index : mesh.indices())
            put(state, index);
        vertices.resize(static_cast<std::size_t>(tess.tileVertexCount(tile)));
        tess.tileVertices(tile, vertices);
        put(state, vertices.size());
        for (const roam::TileVertex& v : vertices) {
            put(state, static_cast<std::uint64_t>(static_cast<std::int64_t>(v.position.x)));
            put(state, static_cast<std::uint64_t>(static_cast<std::int64_t>(v.position.y)));
            put(state, static_cast<std::uint64_t>(v.height));
            put(state, static_cast<std::uint64_t>(static_cast<std::int64_t>(v.block_origin.x)));
            put(state, static_cast<std::uint64_t>(static_cast<std::int64_t>(v.block_origin.y)));
        }
    }
    const std::uint64_t h = XXH3_64bits_digest(state);
    XXH3_freeState(state);
    return h;
}

// the leaf triangles that are drawn, with their tiles, sorted: the mesh whatever its layout
std::uint64_t triangleSetHash(const Tessellator& tess) {
    std::vector<std::array<std::int32_t, 7>> triangles;
    tess.forEachLeaf([&](const roam::Triangle& t, std::int32_t tile, bool emitted) {
        if (emitted)
            triangles.push_back(
                {t.apex.x, t.apex.y, t.left.x, t.left.y, t.right.x, t.right.y, tile});
    });
    std::sort(triangles.begin(), triangles.end());
    XXH3_state_t* state = XXH3_createState();
    XXH3_64bits_reset(state);
    for (const auto& t : triangles)
        for (const std::int32_t v : t)
            put(state, static_cast<std::uint64_t>(static_cast<std::int64_t>(v)));
    const std::uint64_t h = XXH3_64bits_digest(state);
    XXH3_freeState(state);
    return h;
}

FrameHash frameHash(const char* flight, int frame, const Tessellator& tess) {
    return {flight, frame, meshHash(tess), tess.triangleCount(), triangleSetHash(tess)};
}

Terrain world() {
    Terrain t = makeHills(23, 257, 257); // 4 x 4 tiles
    CraterSeries s;
    s.seed = 23;
    s.count = 60;
    applyAll(t, randomCraters(t.spec(), s));
    return t;
}

// the battle flight: two craters a frame ahead of a low camera; the stale bounds pass on
// `runner` when given (the same meshes at any thread count)
void flyBattle(
    std::vector<FrameHash>& out,
    TaskRunner* runner,
    std::int64_t* parallel_passes,
    int frames = 40) {
    Terrain t = world();
    Tessellator tess(t, {});
    tess.setTaskRunner(runner);
    std::mt19937_64 rng(7);
    for (int f = 0; f < frames; ++f) {
        const double x = 30.0 + f * 4.5;
        const double y = 70.0 + f * 2.0;
        shootAhead(t, tess, rng, x, y); // two shots a frame, 15-40 m ahead of a camera 6 m up
        const glm::dvec3 eye(x, y, surfaceHeight(t, x, y) + 6.0);
        tess.update(camera(eye, eye + glm::dvec3(0.9, 0.45, -0.25)));
        out.push_back(frameHash("battle", f, tess));
    }
    if (parallel_passes != nullptr)
        *parallel_passes = tess.parallelBoundsPasses();
}

// the three flights, each on a fresh world and tessellator, frame by frame
std::vector<FrameHash> fly() {
    std::vector<FrameHash> out;
    auto record = [&](const char* flight, int frame, const Tessellator& tess) {
        out.push_back(frameHash(flight, frame, tess));
    };
    {
        const Terrain t = world();
        Tessellator tess(t, {});
        for (int f = 0; f < 40; ++f) {
            const double s = 20.0 + f * 5.5;
            const glm::dvec3 eye(s, s * 0.8 + 10.0, surfaceHeight(t, s, s * 0.8 + 10.0) + 15.0);
            tess.update(camera(eye, eye + glm::dvec3(1.0, 0.8, -0.35)));
            record("cruise", f, tess);
        }
    }
    {
        const Terrain t = world();
        Tessellator tess(t, {});
        for (int f = 0; f < 30; ++f) {
            // a whip pan of 41 degrees a frame, and a teleport half way
            const double x = f < 15 ? 128.0 : 60.0;
            const double y = f < 15 ? 128.0 : 200.0;
            const glm::dvec3 eye(x, y, surfaceHeight(t, x, y) + 4.0);
            const double yaw = f * 41.0 * M_PI / 180.0;
            tess.update(camera(eye, eye + glm::dvec3(std::cos(yaw), std::sin(yaw), -0.3)));
            record("whip", f, tess);
        }
    }
    flyBattle(out, nullptr, nullptr);
    return out;
}

std::string line(const FrameHash& h) {
    char text[128];
    std::snprintf(
        text, sizeof text, "%s %d %016llx %lld %016llx", h.flight.c_str(), h.frame,
        static_cast<unsigned long long>(h.hash), static_cast<long long>(h.triangles),
        static_cast<unsigned long long>(h.set_hash));
    return text;
}

TEST(GoldenMesh, Regenerate) {
    if (!std::getenv("TERRAIN_REGENERATE_GOLDEN_MESH"))
        GTEST_SKIP()
            << "set TERRAIN_REGENERATE_GOLDEN_MESH=1 to rewrite tests/data/golden_mesh.txt";
    std::ofstream out(kGoldenFile);
    out << "# tests/client/mesh_golden_test.cpp: flight frame layout-hash triangles "
           "triangle-set-hash\n";
    for (const FrameHash& h : fly())
        out << line(h) << "\n";
    ASSERT_TRUE(out.good());
}

TEST(GoldenMesh, EveryFrameOfTheThreeFlightsHasTheRecordedMesh) {
    std::ifstream in(kGoldenFile);
    ASSERT_TRUE(in.good()) << kGoldenFile << " is missing";
    std::vector<std::string> expected;
    for (std::string text; std::getline(in, text);)
        if (!text.empty() && text[0] != '#')
            expected.push_back(text);
    const std::vector<FrameHash> got = fly();
    ASSERT_EQ(got.size(), expected.size());
    for (std::size_t i = 0; i < got.size(); ++i)
        ASSERT_EQ(line(got[i]), expected[i]) << "the first frame whose mesh differs";
    // the flights do what they are for: the mesh changes along them
    EXPECT_NE(got.front().hash, got[39].hash);
}

TEST(GoldenMesh, TheBattleHasTheRecordedMeshesWithItsBoundsOnTwoAndFourThreads) {
    std::ifstream in(kGoldenFile);
    ASSERT_TRUE(in.good()) << kGoldenFile << " is missing";
    std::vector<std::string> expected;
    for (std::string text; std::getline(in, text);)
        if (text.rfind("battle ", 0) == 0)
            expected.push_back(text);
    ASSERT_EQ(expected.size(), 40u);
#if defined(__SANITIZE_ADDRESS__)
    // five times slower: one count (groups uneven), the first 24 frames
    const std::vector<unsigned> counts{3u};
    constexpr int kFrames = 24;
#else
    const std::vector<unsigned> counts{2u, 4u};
    constexpr int kFrames = 40;
#endif
    for (const unsigned threads : counts) {
        ThreadPool pool(threads);
        std::vector<FrameHash> got;
        std::int64_t parallel = 0;
        flyBattle(got, &pool, &parallel, kFrames);
        ASSERT_EQ(got.size(), static_cast<std::size_t>(kFrames));
        for (std::size_t i = 0; i < got.size(); ++i)
            ASSERT_EQ(line(got[i]), expected[i])
                << threads << " threads: the first frame whose mesh differs";
        // the spread pass ran (passes of 32 blocks or more)
        EXPECT_GT(parallel, kFrames / 4) << threads << " threads";
    }
}

} // namespace
} // namespace terrain::testing
