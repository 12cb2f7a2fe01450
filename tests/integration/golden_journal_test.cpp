// A recorded journal (tests/data/golden_journal: the golden op script on the golden map,
// recorded by the journal) replayed through a fresh server and several clients: every client
// must reach the recorded world hash at every seq. A server recovered from the same journal
// must serve the recorded final state.
//
// Regenerate (only when the format or the core changes on purpose, and say so in the commit):
//   TERRAIN_REGENERATE_GOLDEN_JOURNAL=1 ./build/release/tests/integration_tests
//       --gtest_filter=GoldenJournal.Regenerate

#include "support/journal_files.h"
#include "support/net_harness.h"

#include <terrain/journal/journal.h>
#include <terrain/journal/record_codec.h>
#include <terrain/op_script.h>
#include <terrain/snapshot.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace terrain::testing {
namespace {

namespace fs = std::filesystem;
using server::Role;

const fs::path kGoldenDir = fs::path(TERRAIN_TEST_DATA_DIR) / "golden_journal";

std::vector<journal::JournalRecord> readRecords(const fs::path& dir) {
    JournalFileRecords files = readJournalRecords(dir);
    EXPECT_EQ(files.undecodable, 0u) << dir;
    return std::move(files.records);
}

fs::path copyGolden() {
    const fs::path copy =
        fs::temp_directory_path() / ("terrain-golden-" + std::to_string(getpid()));
    fs::remove_all(copy);
    fs::create_directories(copy);
    for (const auto& entry : fs::directory_iterator(kGoldenDir))
        fs::copy_file(entry.path(), copy / entry.path().filename());
    return copy;
}

TEST(GoldenJournal, Regenerate) {
    if (!std::getenv("TERRAIN_REGENERATE_GOLDEN_JOURNAL"))
        GTEST_SKIP()
            << "set TERRAIN_REGENERATE_GOLDEN_JOURNAL=1 to rewrite tests/data/golden_journal";
    ProceduralMapOptions o;
    o.seed = 42;
    o.width = 200;
    o.height = 170;
    Terrain genesis = std::move(*makeProceduralMap(o));
    std::ifstream in(fs::path(TERRAIN_TEST_DATA_DIR) / "golden_ops.txt");
    std::stringstream text;
    text << in.rdbuf();
    auto ops = parseOpScript(text.str());
    ASSERT_TRUE(ops.ok());
    fs::remove_all(kGoldenDir);
    {
        auto j = journal::Journal::open(kGoldenDir, {journal::Durability::kFsync, 2});
        ASSERT_TRUE(j.ok());
        ASSERT_TRUE(j->initialize(genesis, 0).ok());
        server::Authority authority(std::move(genesis), 0, 16);
        for (const OpRequest& r : *ops) {
            auto a = authority.apply(r);
            if (!a)
                continue; // the script holds refusals on purpose
            j->append({a->seq, a->op, a->world_hash});
            ASSERT_TRUE(j->commit().ok());
            if (a->seq == 40) {
                ASSERT_TRUE(j->writeSnapshot(authority.terrain(), a->seq).ok());
            }
        }
    }
    fs::remove(kGoldenDir / "LOCK");
}

TEST(GoldenJournal, ReplayedThroughAFreshServerEveryClientMatchesEverySeq) {
    ASSERT_TRUE(fs::exists(kGoldenDir / "snapshot-00000000000000000000.trsn"))
        << "tests/data/golden_journal is missing its genesis snapshot";
    auto genesis = decodeSnapshot(readFileBytes(kGoldenDir / "snapshot-00000000000000000000.trsn"));
    ASSERT_TRUE(genesis.ok()) << genesis.error().message;
    const std::vector<journal::JournalRecord> records = readRecords(kGoldenDir);
    ASSERT_GT(records.size(), 200u);
    std::map<std::uint64_t, std::uint64_t> recorded;
    for (const auto& r : records)
        recorded[r.seq] = r.world_hash;

    server::ServerConfig config;
    config.deform_rate_per_second = 1e6;
    config.deform_burst = 1e6;
    TestServer srv(std::move(genesis->terrain), config);
    asio::io_context io;
    std::vector<std::unique_ptr<TestClient>> clients;
    clients.push_back(std::make_unique<TestClient>(io, srv.port(), token(1, Role::kDeformer)));
    for (int i = 0; i < 3; ++i)
        clients.push_back(
            std::make_unique<TestClient>(io, srv.port(), token(10 + i, Role::kViewer)));
    std::vector<std::map<std::uint64_t, std::uint64_t>> seen(clients.size());
    for (std::size_t i = 0; i < clients.size(); ++i)
        clients[i]->connection->on_applied = [&, i](std::uint64_t seq) {
            seen[i][seq] = clients[i]->replica.worldHash();
        };
    ASSERT_TRUE(runUntil(io, [&] {
        for (auto& c : clients)
            if (!c->replica.ready())
                return false;
        return true;
    }));
    // the recorded ops, canonical, in order, from one deformer (so the server numbers them alike)
    for (const auto& r : records)
        clients[0]->connection->requestDeform(r.op);
    ASSERT_TRUE(runUntil(io, [&] {
        for (auto& c : clients)
            if (c->replica.seq() != records.back().seq)
                return false;
        return true;
    }));
    for (std::size_t i = 0; i < clients.size(); ++i) {
        for (const auto& [seq, hash] : recorded) {
            ASSERT_TRUE(seen[i].count(seq)) << "client " << i << " never applied seq " << seq;
            ASSERT_EQ(seen[i][seq], hash) << "client " << i << " differs at seq " << seq;
        }
    }
    EXPECT_EQ(srv.worldHash(), records.back().world_hash);
}

TEST(GoldenJournal, RecoveredServerServesTheRecordedFinalState) {
    const fs::path copy = copyGolden();
    const std::vector<journal::JournalRecord> records = readRecords(copy);
    ASSERT_FALSE(records.empty());
    auto verified = journal::verifyJournal(copy);
    ASSERT_TRUE(verified.ok()) << verified.error().message;
    EXPECT_EQ(verified->final_hash, records.back().world_hash);
    EXPECT_EQ(verified->snapshots_checked, 2u);
    {
        auto j = journal::Journal::open(copy, {});
        ASSERT_TRUE(j.ok());
        auto recovered = j->recover();
        ASSERT_TRUE(recovered.ok()) << recovered.error().message;
        EXPECT_EQ(recovered->snapshot_seq, 40u);
        TestServer srv(std::move(recovered->terrain), {}, &*j, recovered->seq);
        asio::io_context io;
        TestClient c(io, srv.port(), token(1, Role::kViewer));
        ASSERT_TRUE(runUntil(io, [&] { return c.replica.ready(); }));
        EXPECT_EQ(c.replica.seq(), records.back().seq);
        EXPECT_EQ(c.replica.worldHash(), records.back().world_hash);
        srv.stop();
    }
    fs::remove_all(copy);
}

} // namespace
} // namespace terrain::testing
