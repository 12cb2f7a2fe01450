// The protocol machines back to back (ServerHub + SessionMachine, ClientMachine) over the
// simulated link of support/sim_net.h: no sockets, no threads, virtual time. Every run is
// deterministic, so a link can be cut at each of its deliveries in turn, and a failure names the
// exact step.

#include "support/loopback.h"
#include "support/sim_net.h"
#include "support/terrain_builders.h"

#include <terrain/journal/journal.h>
#include <terrain/procedural_map.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <random>
#include <set>

namespace terrain::testing {
namespace {

using server::Role;

struct Scenario {
    int ops = 120;
    double op_interval = 0.01; ///< seconds between the deformer's requests
    int viewers = 2;
    double late_join_at = 0.4; ///< a viewer that ships the map joins then (negative: none)
    std::uint64_t late_max_replay_ops = 0; ///< that viewer's ConnectionConfig::max_replay_ops
    LinkSpec link;                         ///< every client's
    LinkSpec victim_link;                  ///< viewer 0's
    std::uint64_t cut_viewer_at = 0;
    std::uint64_t cut_deformer_at = 0;
    server::ServerConfig config;
    journal::Journal* journal = nullptr;
    double commit_delay = 0.002;
};

struct Outcome {
    std::uint64_t seq = 0;
    std::uint64_t hash = 0;
    bool converged = false;
    std::uint64_t victim_deliveries = 0;
    std::uint64_t deformer_deliveries = 0;
    std::vector<std::uint64_t> digests;
    std::uint64_t steps = 0;
    server::ServerStats stats;
    client::ConnectionStats victim;
    client::ConnectionStats late;
    std::size_t victim_drops = 0;
    std::vector<std::uint64_t> accepted_seqs;
    std::string why; ///< what did not converge
};

/// Runs a deformer and viewers against one hub; every client must end at the hub's broadcast
/// seq with its hash (checked by each replica on every op it applies) within 60 virtual seconds.
Outcome runScenario(const Scenario& s) {
    SimWorld world;
    world.commit_delay = s.commit_delay;
    Terrain map = smallMap(129);
    server::ServerConfig config = s.config;
    config.token_secret = testSecret();
    config.deform_rate_per_second = 1e4; // the scenario sets the pace
    config.deform_burst = 1e4;
    server::Authority authority(map, 0, config.op_log_capacity);
    if (s.journal) {
        EXPECT_TRUE(s.journal->initialize(map, 0).ok());
    }
    server::ServerHub hub(world, config, authority, s.journal);
    auto tok = [&](std::uint64_t player, Role role) {
        return server::mintToken({player, role, world.unixSeconds() + 3600}, testSecret());
    };
    auto clientConfig = [&](std::uint64_t player, Role role) {
        client::ConnectionConfig c;
        c.token = tok(player, role);
        c.reconnect_delay_seconds = 0.05;
        return c;
    };

    std::vector<std::unique_ptr<SimClient>> clients;
    SimClient* late_client = nullptr;
    auto viewer = [&](int i, LinkSpec link) -> SimClient& {
        clients.push_back(std::make_unique<SimClient>(
            world, hub, clientConfig(100 + i, Role::kViewer), link, "viewer" + std::to_string(i)));
        return *clients.back();
    };
    SimClient& victim = viewer(0, s.victim_link);
    victim.cut_at_delivery = s.cut_viewer_at;
    victim.connect();
    for (int i = 1; i < s.viewers; ++i)
        viewer(i, s.link).connect();
    clients.push_back(std::make_unique<SimClient>(
        world, hub, clientConfig(1, Role::kDeformer), s.link, "deformer"));
    SimClient& deformer = *clients.back();
    deformer.cut_at_delivery = s.cut_deformer_at;
    deformer.connect();
    if (s.late_join_at >= 0)
        world.at(s.late_join_at, [&] {
            client::ConnectionConfig c = clientConfig(199, Role::kViewer);
            c.max_replay_ops = s.late_max_replay_ops;
            clients.push_back(std::make_unique<SimClient>(world, hub, c, s.link, "late"));
            late_client = clients.back().get();
            SimClient& late = *late_client;
            EXPECT_TRUE(late.replica.loadGenesis(smallMap(129)).ok());
            late.connect();
        });

    std::mt19937_64 rng(11);
    std::vector<OpRequest> requests;
    for (int i = 0; i < s.ops; ++i)
        requests.push_back(randomRequest(rng, authority.terrain().spec()));
    // the deformer asks once it is live, one request per interval; asks made while its link is
    // down are lost, as a game's would be
    for (int i = 0; i < s.ops; ++i)
        world.at(0.2 + i * s.op_interval, [&, i] {
            deformer.call([&] { deformer.machine.requestDeform(requests[i]); });
        });

    const double end_of_ops = 0.2 + s.ops * s.op_interval;
    Outcome out;
    auto converged = [&] {
        if (world.now < end_of_ops + 0.5)
            return false;
        for (const auto& c : clients) {
            if (!c->machine.synced() || c->replica.seq() != hub.broadcastSeq() ||
                c->replica.worldHash() != hub.broadcastHash())
                return false;
        }
        return hub.broadcastHash() == authority.terrain().worldHash();
    };
    out.converged = world.runUntil(converged, 60.0);
    if (!out.converged) {
        for (const auto& c : clients)
            if (!c->machine.synced() || c->replica.seq() != hub.broadcastSeq())
                out.why += "a client at seq " + std::to_string(c->replica.seq()) + " of " +
                           std::to_string(hub.broadcastSeq()) +
                           (c->machine.synced() ? "" : " (not synced)") + "; ";
    }
    out.seq = hub.broadcastSeq();
    out.hash = hub.broadcastHash();
    out.victim_deliveries = victim.deliveries;
    out.deformer_deliveries = deformer.deliveries;
    for (const auto& c : clients)
        out.digests.push_back(c->digest);
    out.steps = world.steps;
    out.stats = hub.stats();
    out.victim = victim.machine.stats();
    out.victim_drops = victim.drops.size();
    if (late_client)
        out.late = late_client->machine.stats();
    for (const client::DeformAnswer& a : deformer.answers)
        if (a.accepted)
            out.accepted_seqs.push_back(a.seq);
    return out;
}

// Two viewers and a deformer join by snapshot; a viewer that ships the map joins late, past
// the retained log, by a genesis delta.
TEST(ProtocolSim, ClientsJoinFollowAndConvergeOverA20MbitLink) {
    Scenario s;
    s.config.op_log_capacity = 32;
    s.late_join_at = 1.0;
    const Outcome out = runScenario(s);
    ASSERT_TRUE(out.converged) << out.why;
    EXPECT_EQ(out.seq, 120u);
    EXPECT_EQ(out.accepted_seqs.size(), 120u);
    EXPECT_EQ(out.stats.genesis_deltas_sent, 1u);
    EXPECT_EQ(out.stats.snapshots_sent, 3u);
    EXPECT_EQ(out.stats.resyncs, 0u);
}

// A client that ships the map joins while the server still holds every op: it resumes from seq
// 0 and replays them, unless they are more than its max_replay_ops; then it asks for a snapshot
// at once and gets the genesis delta, skipping the ops already on their way.
TEST(ProtocolSim, AGenesisHolderReplaysTheLogOrAsksForTheDeltaPastItsReplayLimit) {
    Scenario s;
    s.late_join_at = 1.0; // about 80 ops in, all in the log
    const Outcome replayed = runScenario(s);
    ASSERT_TRUE(replayed.converged) << replayed.why;
    EXPECT_EQ(replayed.late.resumes, 1u);
    EXPECT_EQ(replayed.late.snapshots, 0u);
    s.late_max_replay_ops = 10;
    const Outcome limited = runScenario(s);
    ASSERT_TRUE(limited.converged) << limited.why;
    EXPECT_EQ(limited.late.genesis_deltas, 1u);
    EXPECT_EQ(limited.stats.genesis_deltas_sent, 1u);
    EXPECT_EQ(limited.hash, replayed.hash);
}

TEST(ProtocolSim, ARunIsAPureFunctionOfItsInputs) {
    Scenario s;
    s.cut_viewer_at = 7;
    const Outcome a = runScenario(s);
    const Outcome b = runScenario(s);
    ASSERT_TRUE(a.converged) << a.why;
    EXPECT_EQ(a.hash, b.hash);
    EXPECT_EQ(a.steps, b.steps);
    EXPECT_EQ(a.digests, b.digests);
    EXPECT_EQ(a.victim_deliveries, b.victim_deliveries);
}

// A viewer's link cut at each delivery in turn (the handshake, the welcome, every snapshot
// chunk, ops, replies): it reconnects, resumes or rejoins, and ends at the server's state.
TEST(ProtocolSim, AViewerCutAtEveryDeliveryEndsConverged) {
    Scenario s;
    s.ops = 40;
    s.late_join_at = -1;
    s.config.snapshot_chunk_bytes = 4096; // many chunks to cut between
    const Outcome baseline = runScenario(s);
    ASSERT_TRUE(baseline.converged) << baseline.why;
    ASSERT_GT(baseline.victim_deliveries, 20u);
    for (std::uint64_t k = 1; k <= baseline.victim_deliveries; ++k) {
        s.cut_viewer_at = k;
        const Outcome out = runScenario(s);
        ASSERT_TRUE(out.converged) << "cut at delivery " << k << ": " << out.why;
        EXPECT_EQ(out.hash, baseline.hash) << "cut at delivery " << k;
        EXPECT_EQ(out.victim_drops, 1u) << "cut at delivery " << k;
    }
}

// The deformer cut at each delivery: requests in flight may be lost, but no op is applied
// twice, every acknowledged seq is distinct, and everyone converges.
TEST(ProtocolSim, TheDeformerCutAtEveryDeliveryLosesNoStateAndAppliesNothingTwice) {
    Scenario s;
    s.ops = 30;
    s.late_join_at = -1;
    s.viewers = 1;
    const Outcome baseline = runScenario(s);
    ASSERT_TRUE(baseline.converged) << baseline.why;
    for (std::uint64_t k = 1; k <= baseline.deformer_deliveries; ++k) {
        s.cut_deformer_at = k;
        const Outcome out = runScenario(s);
        ASSERT_TRUE(out.converged) << "cut at delivery " << k << ": " << out.why;
        const std::set<std::uint64_t> distinct(out.accepted_seqs.begin(), out.accepted_seqs.end());
        EXPECT_EQ(distinct.size(), out.accepted_seqs.size()) << "cut at delivery " << k;
        EXPECT_LE(out.accepted_seqs.size(), out.seq) << "cut at delivery " << k;
        EXPECT_EQ(out.stats.ops_accepted, out.seq) << "cut at delivery " << k;
    }
}

// A link that delivers nothing for two seconds while ops keep coming: the session's backlog
// passes its budget, it is resynced by snapshot, and it catches up once the link moves.
TEST(ProtocolSim, AStalledLinkIsResyncedAndCatchesUp) {
    Scenario s;
    s.ops = 300;
    s.op_interval = 0.005;
    s.late_join_at = -1;
    s.config.outbound_budget_bytes = 4 << 10;
    s.victim_link.stall_from = 0.5;
    s.victim_link.stall_to = 2.5;
    const Outcome out = runScenario(s);
    ASSERT_TRUE(out.converged) << out.why;
    EXPECT_GE(out.stats.resyncs, 1u);
    EXPECT_GE(out.victim.snapshots, 2u); // the join, then the resync
}

// A link slower than the op stream: resynced, over budget again before the resync was read,
// cut as a slow consumer; it comes back once the burst is over and converges.
TEST(ProtocolSim, ALinkSlowerThanTheStreamIsCutAsASlowConsumerAndRejoins) {
    Scenario s;
    s.ops = 400;
    s.op_interval = 0.0025;
    s.late_join_at = -1;
    s.config.outbound_budget_bytes = 2 << 10;
    s.victim_link.bytes_per_second = 8000;
    const Outcome out = runScenario(s);
    ASSERT_TRUE(out.converged) << out.why;
    EXPECT_GE(out.stats.slow_disconnects, 1u);
    EXPECT_GE(out.victim_drops, 1u);
}

// Pipelined group commits through a real journal (each completion 5 ms after its write) with
// batched broadcasts, and a viewer cut mid-run: seq order holds and everyone converges.
TEST(ProtocolSim, PipelinedCommitsWithBatchesKeepSeqOrderAcrossACut) {
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / "terrain_protocol_sim_journal";
    std::filesystem::remove_all(dir);
    auto opened = journal::Journal::open(dir);
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    journal::Journal j = std::move(*opened);
    Scenario s;
    s.ops = 200;
    s.op_interval = 0.001;
    s.journal = &j;
    s.commit_delay = 0.005;
    s.config.batch_broadcasts = true;
    s.cut_viewer_at = 9;
    const Outcome out = runScenario(s);
    ASSERT_TRUE(out.converged) << out.why;
    EXPECT_GE(out.seq, 190u); // a random op may be refused
    EXPECT_EQ(out.accepted_seqs.size(), out.seq);
    EXPECT_LT(out.stats.commits, out.seq / 2); // ops accepted during a commit joined the next group
    EXPECT_GT(out.victim.op_batches, 0u);
    EXPECT_EQ(j.lastSeq(), out.seq);
    std::filesystem::remove_all(dir);
}

} // namespace
} // namespace terrain::testing
