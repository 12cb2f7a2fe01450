// The world hash after a fixed op script is golden: checked into tests/data, and the same in
// release, debug and sanitizer builds and on every platform.

#include "support/terrain_builders.h"

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace terrain {
namespace {

std::string readText(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

struct Golden {
    std::uint64_t map_hash = 0;
    std::uint64_t final_hash = 0;
    std::size_t patches = 0;
};

Golden readGolden() {
    Golden g;
    std::istringstream in(readText(TERRAIN_TEST_DATA_DIR "/golden_world_hash.txt"));
    std::string key;
    while (in >> key) {
        if (key[0] == '#') {
            in.ignore(1 << 20, '\n');
            continue;
        }
        if (key == "map")
            in >> std::hex >> g.map_hash >> std::dec;
        else if (key == "final")
            in >> std::hex >> g.final_hash >> std::dec;
        else if (key == "patches")
            in >> g.patches;
        else
            in.ignore(1 << 20, '\n');
    }
    return g;
}

Terrain goldenMap() {
    ProceduralMapOptions o;
    o.seed = 42;
    o.width = 200;
    o.height = 170;
    auto t = makeProceduralMap(o);
    EXPECT_TRUE(t.ok());
    return std::move(*t);
}

std::vector<OpRequest> goldenScript() {
    auto ops = parseOpScript(readText(TERRAIN_TEST_DATA_DIR "/golden_ops.txt"));
    EXPECT_TRUE(ops.ok()) << (ops.ok() ? "" : ops.error().message);
    return ops.ok() ? *ops : std::vector<OpRequest>{};
}

TEST(Determinism, fixedScriptGivesTheGoldenWorldHash) {
    const Golden golden = readGolden();
    ASSERT_NE(golden.final_hash, 0u) << "tests/data/golden_world_hash.txt is missing or empty";
    Terrain t = goldenMap();
    EXPECT_EQ(t.worldHash(), golden.map_hash);
    const auto ops = goldenScript();
    ASSERT_GT(ops.size(), 100u);
    testing::applyAll(t, ops);
    EXPECT_EQ(t.worldHash(), golden.final_hash) << std::hex << "got " << t.worldHash();
    EXPECT_EQ(t.patchCount(), golden.patches);
}

TEST(Determinism, snapshotMidwayThenSameOpsGivesTheSameHash) {
    const auto ops = goldenScript();
    ASSERT_GT(ops.size(), 100u);
    Terrain straight = goldenMap();
    testing::applyAll(straight, ops);

    Terrain first = goldenMap();
    const std::size_t half = ops.size() / 2;
    testing::applyAll(first, {ops.begin(), ops.begin() + static_cast<std::ptrdiff_t>(half)});
    auto decoded = decodeSnapshot(encodeSnapshot(first, half));
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    EXPECT_EQ(decoded->sequence, half);
    Terrain resumed = std::move(decoded->terrain);
    EXPECT_EQ(resumed.worldHash(), first.worldHash());
    testing::applyAll(resumed, {ops.begin() + static_cast<std::ptrdiff_t>(half), ops.end()});
    EXPECT_EQ(resumed.worldHash(), straight.worldHash());
    EXPECT_EQ(resumed.patchCount(), straight.patchCount());
}

TEST(Determinism, proceduralMapDependsOnlyOnItsSeed) {
    EXPECT_EQ(goldenMap().worldHash(), goldenMap().worldHash());
    ProceduralMapOptions o;
    o.seed = 43;
    o.width = 200;
    o.height = 170;
    EXPECT_NE(makeProceduralMap(o)->worldHash(), goldenMap().worldHash());
}

} // namespace
} // namespace terrain
