// kill -9 of a real terrain-server process under load, then a restart on the same data
// directory: every acknowledged op must be in the journal with the world hash the clients saw,
// the restarted server must resume at (or after) the last acknowledged seq, and clients must
// converge again.

#include "support/journal_files.h"
#include "support/net_harness.h"
#include "support/server_process.h"

#include <terrain/journal/journal.h>
#include <terrain/journal/record_codec.h>
#include <terrain/snapshot.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace terrain::testing {
namespace {

namespace fs = std::filesystem;
using server::Role;

struct ServerProcess {
    pid_t pid = -1;
    std::uint16_t port = 0;
};

ServerProcess spawnServer(
    const fs::path& dir,
    const std::string& tag,
    std::vector<std::string> snapshot_rule = {"--snapshot-every", "150"}) {
    const fs::path port_file = dir / ("port-" + tag);
    fs::remove(port_file);
    std::vector<std::string> args = {
        "--port-file", port_file.string(), "--data-dir", (dir / "data").string(), "--size",
        "129",         "--durability",     "fsync",      "--deform-rate",         "100000"};
    args.insert(args.end(), snapshot_rule.begin(), snapshot_rule.end());
    const pid_t pid = spawnServerProcess(args, (dir / ("server-" + tag + ".log")).string());
    ServerProcess p;
    p.pid = pid;
    for (int i = 0; i < 1000 && p.port == 0; ++i) {
        std::ifstream in(port_file);
        int port = 0;
        if (in >> port)
            p.port = static_cast<std::uint16_t>(port);
        else
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return p;
}

/// The server log's "recovered seq S (snapshot N + R records replayed": {S, R}, or nullopt for
/// a start that recovered nothing.
std::optional<std::pair<std::uint64_t, std::uint64_t>> recoveredFromLog(const fs::path& log) {
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line)) {
        const std::size_t at = line.find("recovered seq ");
        if (at == std::string::npos)
            continue;
        unsigned long long seq = 0, snapshot = 0, replayed = 0;
        if (std::sscanf(
                line.c_str() + at, "recovered seq %llu (snapshot %llu + %llu records replayed",
                &seq, &snapshot, &replayed) == 3)
            return std::make_pair(std::uint64_t{seq}, std::uint64_t{replayed});
    }
    return std::nullopt;
}

/// Seqs of the snapshot files in the data directory, ascending.
std::vector<std::uint64_t> snapshotSeqs(const fs::path& data) {
    std::vector<std::uint64_t> seqs;
    for (const auto& entry : fs::directory_iterator(data)) {
        const std::string name = entry.path().filename().string();
        if (name.starts_with("snapshot-") && name.ends_with(".trsn"))
            seqs.push_back(std::stoull(name.substr(9, 20)));
    }
    std::sort(seqs.begin(), seqs.end());
    return seqs;
}

void killNine(const ServerProcess& p) {
    ASSERT_EQ(::kill(p.pid, SIGKILL), 0);
    int status = 0;
    waitpid(p.pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
}

void stopCleanly(const ServerProcess& p) {
    ASSERT_EQ(::kill(p.pid, SIGTERM), 0);
    int status = 0;
    waitpid(p.pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "SIGTERM must drain cleanly";
}

/// `count` acknowledged craters from a fresh deformer.
void deform(std::uint16_t port, int count, std::uint64_t seed) {
    asio::io_context io;
    TestClient client(io, port, token(7, Role::kDeformer), false);
    ASSERT_TRUE(runUntil(io, [&] { return client.replica.ready(); }));
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> pos(3.0, 125.0);
    for (int i = 0; i < count; ++i)
        client.connection->requestDeform(
            OpRequest{OpKind::kCrater, pos(rng), pos(rng), 2.5, 0.8, 0.3});
    ASSERT_TRUE(runUntil(
        io, [&] { return client.answers.size() == static_cast<std::size_t>(count); }, 60.0));
    client.connection->stop();
}

// FORMAT.md: a clean stop leaves a snapshot at its last seq and the next start replays nothing,
// after a recovery too; and a recovery that replayed records snapshots at once, so that a second
// crash does not replay them again. Neither periodic rule is on here.
TEST(CrashRecovery, RecoveredRecordsAreReplayedOnlyOnce) {
    const fs::path dir = fs::temp_directory_path() / ("terrain-once-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::vector<std::string> no_rule = {
        "--snapshot-every", "0", "--snapshot-replay-seconds", "0"};
    const auto start = [&](const std::string& tag) {
        ServerProcess p = spawnServer(dir, tag, no_rule);
        EXPECT_NE(p.port, 0) << "terrain-server did not start; see " << dir;
        return p;
    };
    const auto replayed = [&](const std::string& tag) -> std::uint64_t {
        auto r = recoveredFromLog(dir / ("server-" + tag + ".log"));
        EXPECT_TRUE(r.has_value()) << "no recovery line in server-" << tag << ".log";
        return r ? r->second : ~std::uint64_t{0};
    };

    ServerProcess a = start("a");
    ASSERT_NE(a.port, 0);
    deform(a.port, 40, 1);
    killNine(a);
    // kill -9 -> restart -> SIGTERM at once (the recovery's own snapshot may still be in flight)
    ServerProcess b = start("b");
    ASSERT_NE(b.port, 0);
    EXPECT_EQ(replayed("b"), 40u);
    stopCleanly(b);
    EXPECT_EQ(snapshotSeqs(dir / "data").back(), 40u);
    ServerProcess c = start("c");
    ASSERT_NE(c.port, 0);
    EXPECT_EQ(replayed("c"), 0u) << "a clean stop after a recovery must leave a snapshot";
    // more ops, kill -9 -> restart -> kill -9 once the recovery's snapshot is on disk
    deform(c.port, 30, 2);
    killNine(c);
    ServerProcess d = start("d");
    ASSERT_NE(d.port, 0);
    EXPECT_EQ(replayed("d"), 30u);
    for (int i = 0; i < 500 && snapshotSeqs(dir / "data").back() != 70; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_EQ(snapshotSeqs(dir / "data").back(), 70u) << "no snapshot after the recovery";
    killNine(d);
    ServerProcess e = start("e");
    ASSERT_NE(e.port, 0);
    EXPECT_EQ(replayed("e"), 0u);
    stopCleanly(e);
    auto verified = journal::verifyJournal(dir / "data");
    ASSERT_TRUE(verified.ok()) << verified.error().message;
    EXPECT_EQ(verified->last_seq, 70u);
    fs::remove_all(dir);
}

// The time rule alone: snapshots follow the measured apply time of the ops since the last one.
TEST(CrashRecovery, SnapshotsFollowTheReplayBudget) {
    const fs::path dir = fs::temp_directory_path() / ("terrain-budget-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    // 2 ms of apply: a few of these craters (each well over 0.02 ms on any machine)
    ServerProcess p =
        spawnServer(dir, "a", {"--snapshot-every", "0", "--snapshot-replay-seconds", "0.002"});
    ASSERT_NE(p.port, 0) << "terrain-server did not start; see " << dir;
    deform(p.port, 200, 3);
    std::vector<std::uint64_t> seqs;
    for (int i = 0; i < 500; ++i) {
        seqs = snapshotSeqs(dir / "data");
        if (seqs.back() > 0)
            break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_GT(seqs.back(), 0u) << "no snapshot after 200 ops with a 2 ms replay budget";
    killNine(p);
    ServerProcess q = spawnServer(dir, "b", {"--snapshot-every", "0"});
    ASSERT_NE(q.port, 0);
    auto r = recoveredFromLog(dir / "server-b.log");
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->first, 200u);
    EXPECT_LT(r->second, 200u);
    stopCleanly(q);
    fs::remove_all(dir);
}

TEST(CrashRecovery, KillNineUnderLoadLosesNoAcknowledgedOp) {
    const fs::path dir = fs::temp_directory_path() / ("terrain-crash-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    ServerProcess proc = spawnServer(dir, "a");
    ASSERT_NE(proc.port, 0) << "terrain-server did not start; see " << dir;

    asio::io_context io;
    auto deformer = std::make_unique<TestClient>(io, proc.port, token(1, Role::kDeformer), false);
    auto viewer = std::make_unique<TestClient>(io, proc.port, token(2, Role::kViewer), false);
    ASSERT_TRUE(runUntil(io, [&] { return deformer->replica.ready() && viewer->replica.ready(); }));
    // the hash every client verified at each seq
    std::map<std::uint64_t, std::uint64_t> seen;
    viewer->connection->on_applied = [&](std::uint64_t seq) {
        seen[seq] = viewer->replica.worldHash();
    };

    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> pos(3.0, 125.0);
    std::size_t sent = 0;
    // keep 16 requests in flight; the viewer leaves at 150 acknowledged (it will be behind at
    // the restart, and must resume from the restored log); kill once 300 are acknowledged
    bool viewer_left = false;
    auto acked = [&] {
        std::uint64_t n = 0;
        for (const auto& a : deformer->answers)
            n += a.accepted ? 1 : 0;
        return n;
    };
    ASSERT_TRUE(runUntil(
        io,
        [&] {
            while (sent < deformer->answers.size() + 16) {
                deformer->connection->requestDeform(
                    OpRequest{OpKind::kCrater, pos(rng), pos(rng), 2.5, 0.8, 0.3});
                ++sent;
            }
            if (acked() >= 150 && !viewer_left) {
                viewer->connection->stop();
                viewer_left = true;
            }
            return acked() >= 300;
        },
        60.0));
    ASSERT_EQ(::kill(proc.pid, SIGKILL), 0);
    int status = 0;
    waitpid(proc.pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    io.restart();
    io.run_for(std::chrono::milliseconds(100)); // drain what was already on the wire

    std::uint64_t max_acked = 0;
    for (const auto& a : deformer->answers)
        if (a.accepted)
            max_acked = std::max(max_acked, a.seq);
    ASSERT_GE(max_acked, 300u);

    auto verified = journal::verifyJournal(dir / "data");
    ASSERT_TRUE(verified.ok()) << verified.error().message;
    EXPECT_GE(verified->last_seq, max_acked);
    // ops up to the oldest kept snapshot are in it (older segments are pruned): its state must
    // be the one the clients verified at that seq; verifyJournal() chained it to every later one
    {
        std::ostringstream name;
        name << "snapshot-" << std::setw(20) << std::setfill('0') << verified->base_seq << ".trsn";
        auto base = decodeSnapshot(readFileBytes(dir / "data" / name.str()));
        ASSERT_TRUE(base.ok()) << name.str();
        if (seen.count(verified->base_seq)) {
            EXPECT_EQ(base->terrain.worldHash(), seen[verified->base_seq]);
        }
    }
    // every later acknowledged op is in the journal, with the hash the clients verified
    std::map<std::uint64_t, journal::JournalRecord> records;
    for (const auto& r : readJournalRecords(dir / "data").records)
        records[r.seq] = r;
    for (std::uint64_t s = verified->base_seq + 1; s <= max_acked; ++s) {
        auto it = records.find(s);
        ASSERT_NE(it, records.end()) << "acknowledged seq " << s << " is not in the journal";
        if (seen.count(s)) {
            EXPECT_EQ(it->second.world_hash, seen[s]) << "seq " << s;
        }
    }

    const std::uint64_t left_at = viewer->replica.seq();
    // restart on the same directory: the server resumes at the journal's last seq
    ServerProcess again = spawnServer(dir, "b");
    ASSERT_NE(again.port, 0) << "terrain-server did not restart; see " << dir;
    client::Replica& kept = viewer->replica;
    client::ConnectionConfig cc;
    cc.port = again.port;
    cc.token = token(2, Role::kViewer);
    auto reconnected = std::make_shared<client::Connection>(io, cc, kept);
    reconnected->start();
    TestClient fresh(io, again.port, token(3, Role::kDeformer));
    ASSERT_TRUE(runUntil(io, [&] { return fresh.replica.ready(); }));
    EXPECT_EQ(fresh.replica.seq(), verified->last_seq);
    EXPECT_EQ(fresh.replica.worldHash(), verified->final_hash);
    // the viewer left well behind: the restarted server rebuilt its retained log from the
    // journal, so it gets the ops it missed, not a snapshot
    ASSERT_LT(left_at + 100, verified->last_seq);
    ASSERT_TRUE(runUntil(io, [&] { return kept.seq() == verified->last_seq; }));
    EXPECT_EQ(reconnected->stats().resumes, 1u);
    EXPECT_EQ(reconnected->stats().snapshots, 0u);
    EXPECT_EQ(kept.stats().snapshots, 1u); // the first join's only
    // new ops after the restart reach both the resumed and the fresh client
    fresh.connection->requestDeform(OpRequest{OpKind::kCrater, 60, 60, 3, 1, 0.3});
    ASSERT_TRUE(runUntil(io, [&] {
        return kept.seq() == verified->last_seq + 1 && fresh.replica.seq() == kept.seq() &&
               kept.worldHash() == fresh.replica.worldHash();
    }));
    EXPECT_EQ(kept.stats().hash_mismatches, 0u);
    reconnected->stop();
    // five more ops the viewer misses, then a clean stop: it writes a snapshot at the last seq
    // and the next start replays nothing, so the log comes from the segments before it
    for (int i = 0; i < 5; ++i)
        fresh.connection->requestDeform(OpRequest{OpKind::kCrater, 30.0 + 15 * i, 90, 3, 1, 0.3});
    ASSERT_TRUE(runUntil(io, [&] { return fresh.replica.seq() == verified->last_seq + 6; }));
    ::kill(again.pid, SIGTERM);
    waitpid(again.pid, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "SIGTERM must drain cleanly";
    // after a clean stop the journal still verifies, including the post-restart ops
    auto final_check = journal::verifyJournal(dir / "data");
    ASSERT_TRUE(final_check.ok()) << final_check.error().message;
    EXPECT_EQ(final_check->last_seq, verified->last_seq + 6);

    ServerProcess third = spawnServer(dir, "c");
    ASSERT_NE(third.port, 0) << "terrain-server did not restart; see " << dir;
    cc.port = third.port;
    auto resumed = std::make_shared<client::Connection>(io, cc, kept);
    resumed->start();
    ASSERT_TRUE(runUntil(io, [&] { return kept.seq() == final_check->last_seq; }));
    EXPECT_EQ(kept.worldHash(), final_check->final_hash);
    EXPECT_EQ(resumed->stats().resumes, 1u);
    EXPECT_EQ(resumed->stats().snapshots, 0u);
    EXPECT_EQ(kept.stats().hash_mismatches, 0u);
    resumed->stop();
    ::kill(third.pid, SIGTERM);
    waitpid(third.pid, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    fs::remove_all(dir);
}

} // namespace
} // namespace terrain::testing
