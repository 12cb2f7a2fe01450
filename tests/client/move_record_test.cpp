// The tessellator's moves per crater in the golden battle, held to their record: the first
// kOps of the golden battle's shots (tests/data/golden_battle_ops.txt, on its 257 x 257 map), one
// a frame, under a camera circling the zone 60 m up and looking in (tau 1 px, 1280 x 720), each
// frame one synchronous update. The splits and merges per crater are compared with the figure
// recorded below: the test fails when they exceed twice it (a change that makes a crater cost
// more moves is a regression, however fast each move) or fall under half of it (the
// tessellation stopped following the craters). A deliberate change records the new figure here,
// with the commit that made it.

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/roam/tessellator.h>
#include <terrain/terrain.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace terrain::testing {
namespace {

constexpr int kOps = 300;
// Recorded 2026-12-07 (stop 55): 876,414 splits and merges over the first 300 craters, 96 % of
// them in cells a crater changed within 60 frames, 41 % undoing a move made there shortly before
// (the zone is patch-dense, the mesh at its 400,000 cap from the 200th crater on). Far above what
// the issue asks: this pins the figure so that it can only fall, not hides it.
constexpr double kRecordedMovesPerCrater = 2921.4;

std::string readText(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

roam::Camera circling(int frame, glm::dvec3 zone) {
    const double angle = 0.004 * frame;
    roam::Camera c;
    c.eye = zone + glm::dvec3(80.0 * std::cos(angle), 80.0 * std::sin(angle), 60.0);
    c.forward = zone - c.eye;
    c.fovy_radians = 60.0 * M_PI / 180.0;
    c.viewport_width = 1280;
    c.viewport_height = 720;
    c.near_plane = 0.25;
    return c;
}

TEST(MoveRecord, TheGoldenBattlesCratersCostNoMoreThanTwiceTheirRecordedMoves) {
    std::istringstream golden(readText(TERRAIN_TEST_DATA_DIR "/golden_battle.txt"));
    std::int32_t size = 0;
    std::uint64_t seed = 0;
    std::string ops_file;
    for (std::string key; golden >> key;) {
        if (key == "map")
            golden >> size >> seed;
        else if (key == "ops")
            golden >> ops_file;
        else
            golden.ignore(1 << 20, '\n');
    }
    ASSERT_GT(size, 0) << "tests/data/golden_battle.txt names no map";
    auto ops = parseCanonicalOps(readText(TERRAIN_TEST_DATA_DIR "/" + ops_file));
    ASSERT_TRUE(ops.ok()) << ops.error().message;
    ASSERT_GE(ops->size(), static_cast<std::size_t>(kOps));
    ProceduralMapOptions o;
    o.seed = seed;
    o.width = o.height = size;
    auto world = makeProceduralMap(o);
    ASSERT_TRUE(world.ok()) << world.error().message;

    roam::TessellatorOptions options;
    options.tau_pixels = 1.0;
    options.max_triangles = 400'000; // the bot's and the library's cap
    options.count_moves_by_place = true;
    roam::Tessellator tess(*world, options);
    const glm::dvec3 zone(world->spec().extentX() / 2, world->spec().extentY() / 2, 0.0);
    // the first build, to the end (the work budget spreads it over updates), is not a crater's
    for (int k = 0; k < 1000; ++k) {
        const roam::FrameStats& s = tess.update(circling(0, zone));
        if (k > 0 && s.splits + s.merges == 0)
            break;
    }
    std::int64_t moves = 0;
    std::int64_t in_footprint = 0;
    std::int64_t undone = 0;
    for (int f = 1; f <= kOps; ++f) {
        auto effect = world->apply((*ops)[static_cast<std::size_t>(f - 1)]);
        ASSERT_TRUE(effect.ok()) << effect.error().message;
        const CellRect cells[] = {effect->cells};
        tess.terrainChanged(cells, false);
        const roam::FrameStats& s = tess.update(circling(f, zone));
        moves += s.splits + s.merges;
        in_footprint += s.moves_in_footprint;
        undone += s.moves_undone;
    }
    const double per_crater = static_cast<double>(moves) / kOps;
    std::printf(
        "golden battle, first %d craters: %lld splits and merges, %.1f a crater, %.0f %% in "
        "their footprints, %.0f %% undoing one (record %.1f)\n",
        kOps, static_cast<long long>(moves), per_crater,
        moves > 0 ? 100.0 * static_cast<double>(in_footprint) / static_cast<double>(moves) : 0.0,
        moves > 0 ? 100.0 * static_cast<double>(undone) / static_cast<double>(moves) : 0.0,
        kRecordedMovesPerCrater);
    EXPECT_LE(per_crater, 2.0 * kRecordedMovesPerCrater) << "a crater costs more moves";
    EXPECT_GE(per_crater, 0.5 * kRecordedMovesPerCrater) << "the mesh stopped following";
}

} // namespace
} // namespace terrain::testing
