// The soak, short: fuzzed ops of every kind (battle aiming, random, the rules' extremes, invalid
// ones) through a live server keeping a journal, to several clients; the journal replayed
// offline; every client's hash equal to the journal's at every seq. The long run (100,000 ops,
// 8 clients) is `terrain-replay soak`, with its figures in BENCHMARKS.md.

#include "support/terrain_builders.h"
#include "support/thread_bits.h"

#include <terrain/replay/soak.h>
#include <terrain/replay/soak_ops.h>

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <variant>

namespace terrain::testing {
namespace {

namespace fs = std::filesystem;

fs::path freshDir(const std::string& name) {
    const fs::path dir =
        fs::temp_directory_path() / ("terrain-soak-" + name + "-" + std::to_string(getpid()));
    fs::remove_all(dir);
    return dir;
}

TEST(SoakOps, TheMixIsSeededAndEachKindIsWhatItSays) {
    const Terrain world = smallMap(257);
    replay::SoakOps a(7, world.spec());
    replay::SoakOps b(7, world.spec());
    int valid_extremes = 0, refused_invalid = 0;
    for (int i = 0; i < 2000; ++i) {
        const replay::SoakCounts before = a.counts();
        const replay::FeedRequest ra = a.next(world);
        const replay::FeedRequest rb = b.next(world);
        ASSERT_EQ(ra.index(), rb.index()) << "op " << i;
        if (const DeformOp* op = std::get_if<DeformOp>(&ra)) {
            EXPECT_EQ(*op, std::get<DeformOp>(rb));
            // extremes are canonical and sit at the rules' edges, still inside them
            EXPECT_TRUE(validateOp(*op, world.spec()).ok()) << describe(*op, world.spec());
            ++valid_extremes;
        } else {
            const OpRequest& r = std::get<OpRequest>(ra);
            const OpRequest& s = std::get<OpRequest>(rb);
            EXPECT_TRUE(
                (std::isnan(r.x) && std::isnan(s.x)) || (r.x == s.x && r.radius == s.radius));
            const bool invalid = a.counts().invalid > before.invalid;
            if (invalid) {
                EXPECT_FALSE(quantizeOp(r, world.spec()).ok()) << "an invalid op passed";
                ++refused_invalid;
            } else {
                EXPECT_TRUE(quantizeOp(r, world.spec()).ok())
                    << quantizeOp(r, world.spec()).error().message;
            }
        }
    }
    const replay::SoakCounts& c = a.counts();
    EXPECT_EQ(c.total(), 2000u);
    EXPECT_EQ(c.extreme, static_cast<std::uint64_t>(valid_extremes));
    EXPECT_EQ(c.invalid, static_cast<std::uint64_t>(refused_invalid));
    // 60 / 25 / 10 / 5 % (battle shots that leave the map count as random)
    EXPECT_NEAR(c.battle + c.random, 1700.0, 60.0);
    EXPECT_NEAR(c.extreme, 200.0, 45.0);
    EXPECT_NEAR(c.invalid, 100.0, 35.0);
    EXPECT_GT(c.battle, 900u);
}

// The mix (every kind, the rules' extremes, refusals) applied with a thread pool gives the serial
// path's bits at every op, at 2, 4 and 8 threads.
TEST(SoakOps, TheMixHasTheSameBitsAtEveryThreadCount) {
    const Terrain world = smallMap(257);
    replay::SoakOps mix(11, world.spec());
    Terrain serial = world;
    std::vector<std::pair<DeformOp, std::uint64_t>> applied;
    for (int i = 0; i < 1500; ++i) {
        const replay::FeedRequest r = mix.next(serial);
        Result<DeformOp> op = std::holds_alternative<DeformOp>(r)
                                  ? Result<DeformOp>(std::get<DeformOp>(r))
                                  : quantizeOp(std::get<OpRequest>(r), serial.spec());
        if (!op || !serial.apply(*op).ok())
            continue; // refused: changes nothing on any path
        applied.emplace_back(*op, serial.worldHash());
    }
    ASSERT_GT(applied.size(), 1200u);
    for (unsigned threads : {2u, 4u, 8u})
        testing::expectSameBitsWithThreads(world, applied, serial, threads);
}

TEST(Soak, EveryClientMatchesTheOfflineReplayOfTheServersJournalAtEverySeq) {
    replay::SoakOptions options;
    options.ops = 600;
    options.seed = 3;
    options.map_size = 129;
    options.directory = freshDir("agree");
    options.live.clients = 3;
    options.live.window = 16;
    options.live.time_limit_seconds = 120;
    auto run = replay::runSoak(options);
    ASSERT_TRUE(run.ok()) << run.error().message;
    EXPECT_TRUE(run->agreed()) << run->first_disagreement;
    EXPECT_EQ(run->live.ops_fed, 600u);
    EXPECT_EQ(run->live.ops_accepted + run->live.refused(), 600u);
    EXPECT_EQ(run->live.refused(), run->counts.invalid) << run->live.first_refusal;
    EXPECT_GT(run->counts.battle, 0u);
    EXPECT_GT(run->counts.extreme, 0u);
    EXPECT_GT(run->counts.invalid, 0u);
    EXPECT_EQ(run->offline.records_checked, run->live.ops_accepted);
    EXPECT_EQ(run->seqs_compared, 3 * run->live.ops_accepted);
    for (const replay::ClientTally& c : run->live.clients) {
        EXPECT_EQ(c.checked, run->live.ops_accepted) << c.name;
        EXPECT_EQ(c.server_mismatches, 0u) << c.name;
        EXPECT_EQ(c.final_hash, run->offline.final_hash) << c.name;
    }
    fs::remove_all(options.directory);
}

TEST(Soak, AClientThatDivergesIsCountedAgainstTheJournal) {
    replay::SoakOptions options;
    options.ops = 120;
    options.map_size = 129;
    options.directory = freshDir("diverge");
    options.live.clients = 2;
    options.live.window = 4;
    options.live.time_limit_seconds = 60;
    // client 1 applies a stray op at seq 40 and is repaired by the product's own path: the
    // journal comparison still finds the seqs it held a wrong world
    options.live.before_check = [](std::size_t client, std::uint64_t seq, client::Replica& r) {
        if (client == 1 && seq == 40) {
            ASSERT_TRUE(
                r.terrainForTesting()
                    .apply(*quantizeOp({OpKind::kRaise, 60, 60, 3, 1, 1}, r.terrain().spec()))
                    .ok());
        }
    };
    auto run = replay::runSoak(options);
    ASSERT_TRUE(run.ok()) << run.error().message;
    EXPECT_FALSE(run->agreed());
    EXPECT_GE(run->disagreements, 1u);
    EXPECT_NE(run->first_disagreement.find("client-1 at seq 40"), std::string::npos)
        << run->first_disagreement;
    fs::remove_all(options.directory);
}

TEST(Soak, RefusesADirectoryThatHoldsSomething) {
    const fs::path dir = freshDir("busy");
    fs::create_directories(dir);
    std::ofstream(dir / "keep") << "x";
    replay::SoakOptions options;
    options.ops = 1;
    options.directory = dir;
    auto run = replay::runSoak(options);
    ASSERT_FALSE(run.ok());
    EXPECT_NE(run.error().message.find("is not empty"), std::string::npos);
    EXPECT_TRUE(fs::exists(dir / "keep"));
    fs::remove_all(dir);
}

} // namespace
} // namespace terrain::testing
