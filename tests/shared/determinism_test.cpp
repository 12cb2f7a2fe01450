// The world hash after a fixed op script is golden: checked into tests/data, and the same in
// release, debug and sanitizer builds and on every platform.

#include "support/terrain_builders.h"
#include "support/thread_bits.h"

#include <terrain/battle.h>
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

// The golden battle: 2,000 shots of the battle generator, recorded as canonical ops
// (tests/data/golden_battle_ops.txt, made by `battle_bench --map-size 257 --map-seed 42
// --shots 2000 --zone-x 128 --zone-y 128 --ops ...`), replayed to the golden hash. The same
// check runs from the clang build (golden_battle_check) and under qemu on aarch64 and s390x.
struct GoldenBattle {
    std::int32_t size = 0;
    std::uint64_t seed = 0;
    std::string ops_file;
    std::uint64_t map_hash = 0;
    std::uint64_t final_hash = 0;
    std::size_t patches = 0;
};

GoldenBattle readGoldenBattle() {
    GoldenBattle g;
    std::istringstream in(readText(TERRAIN_TEST_DATA_DIR "/golden_battle.txt"));
    for (std::string key; in >> key;) {
        if (key[0] == '#')
            in.ignore(1 << 20, '\n');
        else if (key == "map")
            in >> g.size >> g.seed;
        else if (key == "ops")
            in >> g.ops_file;
        else if (key == "map_hash")
            in >> std::hex >> g.map_hash >> std::dec;
        else if (key == "final")
            in >> std::hex >> g.final_hash >> std::dec;
        else if (key == "patches")
            in >> g.patches;
    }
    return g;
}

Terrain goldenBattleMap(const GoldenBattle& g) {
    ProceduralMapOptions o;
    o.seed = g.seed;
    o.width = o.height = g.size;
    return std::move(*makeProceduralMap(o));
}

TEST(Determinism, theGoldenBattleReplaysToTheGoldenHash) {
    const GoldenBattle g = readGoldenBattle();
    ASSERT_NE(g.final_hash, 0u) << "tests/data/golden_battle.txt is missing or empty";
    auto ops = parseCanonicalOps(readText(TERRAIN_TEST_DATA_DIR "/" + g.ops_file));
    ASSERT_TRUE(ops.ok()) << ops.error().message;
    ASSERT_GE(ops->size(), 1900u);
    Terrain t = goldenBattleMap(g);
    EXPECT_EQ(t.worldHash(), g.map_hash);
    for (const DeformOp& op : *ops)
        ASSERT_TRUE(t.apply(op).ok()) << formatCanonicalOp(op);
    EXPECT_EQ(t.worldHash(), g.final_hash) << std::hex << "got " << t.worldHash();
    EXPECT_EQ(t.patchCount(), g.patches);
}

// Terrain::apply with a thread pool: the world hash after every op of the golden battle, and
// every tile hash at its end, equal the serial path's at 1, 2, 4 and 8 threads
TEST(Determinism, theGoldenBattleHasTheSameBitsAtEveryThreadCount) {
    const GoldenBattle g = readGoldenBattle();
    auto ops = parseCanonicalOps(readText(TERRAIN_TEST_DATA_DIR "/" + g.ops_file));
    ASSERT_TRUE(ops.ok()) << ops.error().message;
    const Terrain start = goldenBattleMap(g);
    Terrain serial = start;
    std::vector<std::pair<DeformOp, std::uint64_t>> applied;
    for (const DeformOp& op : *ops) {
        ASSERT_TRUE(serial.apply(op).ok()) << formatCanonicalOp(op);
        applied.emplace_back(op, serial.worldHash());
    }
    ASSERT_EQ(serial.worldHash(), g.final_hash);
    for (unsigned threads : {1u, 2u, 4u, 8u})
        testing::expectSameBitsWithThreads(start, applied, serial, threads);
}

// the generator still aims the recorded shots on this platform (it casts rays in doubles, so
// the recording, not the generator, is what other platforms replay)
TEST(BattleGenerator, stillAimsTheRecordedShotsOfTheGoldenBattle) {
    const GoldenBattle g = readGoldenBattle();
    auto recorded = parseCanonicalOps(readText(TERRAIN_TEST_DATA_DIR "/" + g.ops_file));
    ASSERT_TRUE(recorded.ok()) << recorded.error().message;
    Terrain t = goldenBattleMap(g);
    BattleOptions o;
    o.zone_x = o.zone_y = 128;
    BattleGenerator generator(o);
    std::size_t next = 0;
    for (int shot = 0; shot < 2000 && next < recorded->size(); ++shot) {
        const BattleShot s = generator.next(t);
        if (!s.crater)
            continue;
        auto op = quantizeOp(*s.crater, t.spec());
        ASSERT_TRUE(op.ok()) << op.error().message;
        ASSERT_EQ(formatCanonicalOp(*op), formatCanonicalOp((*recorded)[next])) << "shot " << shot;
        ASSERT_TRUE(t.apply(*op).ok());
        ++next;
    }
    EXPECT_EQ(next, recorded->size());
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
