// terrain-replay live: a recorded journal replayed through a real server to checked clients.
// Every client matches the journal at every seq; a replica corrupted behind the hashes' back is
// caught at that seq, named, repaired by the product's own repair path, and its desync report
// names the op and the tile, dumps both tiles and draws the difference.

#include "support/terrain_builders.h"

#include <terrain/journal/journal.h>
#include <terrain/replay/desync_report.h>
#include <terrain/replay/live_replay.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace terrain::testing {
namespace {

namespace fs = std::filesystem;

/// A journal of `count` ops of every kind on a 129 x 129 map, as a server would write it.
fs::path recordedMatch(const std::string& name, int count) {
    const fs::path dir =
        fs::temp_directory_path() / ("terrain-live-replay-" + name + std::to_string(getpid()));
    fs::remove_all(dir);
    Terrain world = smallMap(129);
    auto journal = journal::Journal::open(dir, {journal::Durability::kWrite, 2});
    EXPECT_TRUE(journal.ok());
    EXPECT_TRUE(journal->initialize(world, 0).ok());
    const OpKind kinds[] = {OpKind::kCrater, OpKind::kRaise, OpKind::kFlatten, OpKind::kSmooth};
    for (int i = 1; i <= count; ++i) {
        OpRequest r;
        r.kind = kinds[i % 4];
        r.x = 10.0 + (i * 37) % 108;
        r.y = 10.0 + (i * 53) % 108;
        r.radius = 2.0 + i % 5;
        r.height = r.kind == OpKind::kFlatten  ? 20.0
                   : r.kind == OpKind::kSmooth ? 0.0
                                               : 0.5 + (i % 3) * 0.7;
        r.strength = r.kind == OpKind::kRaise ? 1.0 : 0.25 + (i % 3) * 0.2;
        auto op = quantizeOp(r, world.spec());
        EXPECT_TRUE(op.ok()) << op.error().message;
        EXPECT_TRUE(world.apply(*op).ok());
        journal->append({static_cast<std::uint64_t>(i), *op, world.worldHash()});
    }
    EXPECT_TRUE(journal->commit().ok());
    return dir;
}

std::string readAll(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(LiveReplay, EveryClientMatchesTheJournalAtEverySeq) {
    const fs::path dir = recordedMatch("agree", 80);
    auto history = journal::readJournal(dir);
    ASSERT_TRUE(history.ok()) << history.error().message;
    ASSERT_EQ(history->records.size(), 80u);
    replay::LiveRunOptions options;
    options.clients = 3;
    options.window = 8;
    options.time_limit_seconds = 60;
    auto run = replay::runLiveReplay(*history, options);
    ASSERT_TRUE(run.ok()) << run.error().message;
    EXPECT_TRUE(replay::replayAgreed(*history, *run));
    EXPECT_FALSE(run->first_divergence);
    EXPECT_EQ(run->ops_fed, 80u);
    ASSERT_EQ(run->clients.size(), 3u);
    for (const replay::ClientTally& c : run->clients) {
        EXPECT_EQ(c.checked, 80u) << c.name;
        EXPECT_EQ(c.mismatches, 0u) << c.name;
        EXPECT_EQ(c.final_seq, 80u) << c.name;
        EXPECT_EQ(c.final_hash, history->report.final_hash) << c.name;
    }
    fs::remove_all(dir);
}

TEST(LiveReplay, ACorruptedReplicaIsCaughtAtItsSeqWithADesyncReport) {
    const fs::path dir = recordedMatch("desync", 60);
    auto history = journal::readJournal(dir);
    ASSERT_TRUE(history.ok()) << history.error().message;
    const WorldSpec spec = history->base.spec();
    // a local op the server never sent, on client 2 at seq 25: a mound at (100 m, 20 m)
    const DeformOp stray = *quantizeOp({OpKind::kRaise, 100.0, 20.0, 3.0, 1.5, 1.0}, spec);
    replay::LiveRunOptions options;
    options.clients = 3;
    options.window = 4;
    options.time_limit_seconds = 60;
    options.before_check = [&](std::size_t client, std::uint64_t seq, client::Replica& replica) {
        if (client == 2 && seq == 25) {
            ASSERT_TRUE(replica.terrainForTesting().apply(stray).ok());
        }
    };
    auto run = replay::runLiveReplay(*history, options);
    ASSERT_TRUE(run.ok()) << run.error().message;
    EXPECT_FALSE(replay::replayAgreed(*history, *run));
    ASSERT_TRUE(run->first_divergence);
    const replay::Divergence& d = *run->first_divergence;
    EXPECT_EQ(d.seq, 25u);
    EXPECT_EQ(d.client, 2u);
    EXPECT_FALSE(d.server_differs) << "the server was right; the client had diverged";
    EXPECT_EQ(d.op, history->records[24].op);
    EXPECT_EQ(d.expected_hash, history->records[24].world_hash);
    // the others never differed; the corrupted one was repaired and ends on the journal's world
    EXPECT_EQ(run->clients[0].mismatches, 0u);
    EXPECT_EQ(run->clients[1].mismatches, 0u);
    EXPECT_GE(run->clients[2].mismatches, 1u);
    EXPECT_GE(run->clients[2].repairs, 1u);
    EXPECT_EQ(run->clients[2].final_hash, history->report.final_hash);

    auto expected = replay::stateAt(*history, d.seq);
    ASSERT_TRUE(expected.ok());
    EXPECT_EQ(expected->worldHash(), d.expected_hash);
    EXPECT_TRUE(replay::differingTiles(*expected, *expected).empty());
    const fs::path report = dir / "desync-25";
    replay::DesyncFacts facts{d.seq,           d.op,           "client-2", dir.string(),
                              d.expected_hash, d.observed_hash};
    ASSERT_TRUE(replay::writeDesyncReport(report, facts, *expected, *d.observed).ok());

    const auto json = nlohmann::json::parse(readAll(report / "report.json"));
    EXPECT_EQ(json["seq"], 25);
    EXPECT_EQ(json["op"]["text"], describe(d.op, spec));
    // the stray mound's footprint lies in one tile: cells x 64..127, y 0..63 (tile 1)
    ASSERT_EQ(json["tiles"].size(), 1u);
    EXPECT_EQ(json["tiles"][0]["tile"], 1);
    EXPECT_GT(json["tiles"][0]["samples_differing"].get<int>(), 10);
    EXPECT_NEAR(json["tiles"][0]["max_difference_metres"].get<double>(), 1.5, 0.2);
    const std::string want = readAll(report / "tile-1-expected.txt");
    const std::string got = readAll(report / "tile-1-observed.txt");
    EXPECT_NE(want.find("samples\n"), std::string::npos);
    EXPECT_EQ(want.size() > 65 * 65, true);
    EXPECT_NE(want, got);
    EXPECT_GT(fs::file_size(report / "difference.png"), 100u);
    EXPECT_NE(readAll(report / "report.txt").find("1 tile(s) differ"), std::string::npos);
    fs::copy(
        report, "/tmp/desync-sample",
        fs::copy_options::overwrite_existing | fs::copy_options::recursive);
    fs::remove_all(dir);
}

TEST(LiveReplay, ReportsRefuseStatesOfDifferentWorlds) {
    const Terrain a = smallMap(129);
    const Terrain b = smallMap(257);
    const Status s =
        replay::writeDesyncReport(fs::temp_directory_path() / "terrain-desync-mismatch", {}, a, b);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().code, ErrorCode::kSizeMismatch);
}

} // namespace
} // namespace terrain::testing
