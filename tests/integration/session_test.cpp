// Server + clients over real loopback TCP: convergence, joins, reconnects, slow readers, bad
// peers, repair. Each test builds its own server on an ephemeral port.

#include "support/net_harness.h"
#include "support/terrain_builders.h"

#include <terrain/journal/journal.h>
#include <terrain/surface_query.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <map>
#include <random>
#include <thread>

namespace terrain::testing {
namespace {

namespace pb = wire::pb;
using server::Role;

server::ServerConfig fastConfig() {
    server::ServerConfig c;
    c.deform_rate_per_second = 1e6;
    c.deform_burst = 1e6;
    return c;
}

bool allAt(
    std::vector<std::unique_ptr<TestClient>>& clients, std::uint64_t seq, std::uint64_t hash) {
    for (auto& c : clients)
        if (!c->replica.ready() || c->replica.seq() != seq || c->replica.worldHash() != hash)
            return false;
    return true;
}

TEST(Session, ClientsConvergeAfterOpsFromSeveralDeformers) {
    TestServer srv(smallMap(), fastConfig());
    asio::io_context io;
    std::vector<std::unique_ptr<TestClient>> clients;
    for (int i = 0; i < 3; ++i)
        clients.push_back(
            std::make_unique<TestClient>(io, srv.port(), token(10 + i, Role::kDeformer)));
    for (int i = 0; i < 5; ++i)
        clients.push_back(
            std::make_unique<TestClient>(io, srv.port(), token(20 + i, Role::kViewer)));
    ASSERT_TRUE(runUntil(io, [&] { return allAt(clients, 0, srv.worldHash()); }));

    std::mt19937_64 rng(7);
    const WorldSpec spec = clients[0]->replica.terrain().spec();
    for (int round = 0; round < 40; ++round)
        for (int d = 0; d < 3; ++d)
            clients[static_cast<std::size_t>(d)]->connection->requestDeform(
                randomRequest(rng, spec));
    ASSERT_TRUE(runUntil(io, [&] {
        std::size_t answered = 0;
        for (int d = 0; d < 3; ++d)
            answered += clients[static_cast<std::size_t>(d)]->answers.size();
        return answered == 120;
    }));
    std::size_t accepted = 0;
    for (int d = 0; d < 3; ++d)
        for (const auto& a : clients[static_cast<std::size_t>(d)]->answers)
            accepted += a.accepted ? 1 : 0;
    EXPECT_EQ(accepted, 120u) << clients[0]->answers[0].reason;
    const std::uint64_t seq = srv.seq();
    EXPECT_EQ(seq, accepted);
    const std::uint64_t hash = srv.worldHash();
    ASSERT_TRUE(runUntil(io, [&] { return allAt(clients, seq, hash); }));
    for (auto& c : clients) {
        EXPECT_EQ(c->replica.stats().hash_mismatches, 0u);
        EXPECT_EQ(c->replica.stats().snapshots, 1u);
        EXPECT_EQ(c->replica.terrain().computeWorldHash(), hash);
        EXPECT_FALSE(c->replica.peekDirty().cells.empty());
    }
}

TEST(Session, LateJoinGetsSnapshotThenLiveOps) {
    TestServer srv(smallMap(), fastConfig());
    asio::io_context io;
    std::vector<std::unique_ptr<TestClient>> clients;
    clients.push_back(std::make_unique<TestClient>(io, srv.port(), token(1, Role::kDeformer)));
    ASSERT_TRUE(runUntil(io, [&] { return clients[0]->replica.ready(); }));
    std::mt19937_64 rng(11);
    const WorldSpec spec = clients[0]->replica.terrain().spec();
    for (int i = 0; i < 30; ++i)
        clients[0]->connection->requestDeform(randomRequest(rng, spec));
    ASSERT_TRUE(runUntil(io, [&] { return clients[0]->answers.size() == 30; }));
    clients.push_back(std::make_unique<TestClient>(io, srv.port(), token(2, Role::kViewer)));
    ASSERT_TRUE(runUntil(io, [&] { return allAt(clients, srv.seq(), srv.worldHash()); }));
    EXPECT_GT(clients[1]->replica.seq(), 0u);
    for (int i = 0; i < 10; ++i)
        clients[0]->connection->requestDeform(randomRequest(rng, spec));
    ASSERT_TRUE(runUntil(io, [&] { return clients[0]->answers.size() == 40; }));
    ASSERT_TRUE(runUntil(io, [&] { return allAt(clients, srv.seq(), srv.worldHash()); }));
    EXPECT_GT(clients[1]->replica.stats().ops_applied, 0u);
}

// returns the number of ops applied while `viewer` was away
void reconnectScenario(std::size_t log_capacity, int missed_ops, bool expect_resume) {
    server::ServerConfig config = fastConfig();
    config.op_log_capacity = log_capacity;
    TestServer srv(smallMap(), config);
    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    client::Replica kept; // the viewer's replica survives its connection
    auto connectViewer = [&] {
        client::ConnectionConfig cc;
        cc.port = srv.port();
        cc.token = token(2, Role::kViewer);
        auto c = std::make_shared<client::Connection>(io, cc, kept);
        c->start();
        return c;
    };
    auto viewer = connectViewer();
    std::mt19937_64 rng(3);
    ASSERT_TRUE(runUntil(io, [&] { return deformer.replica.ready() && kept.ready(); }));
    const WorldSpec spec = kept.terrain().spec();
    for (int i = 0; i < 5; ++i)
        deformer.connection->requestDeform(randomRequest(rng, spec));
    ASSERT_TRUE(runUntil(io, [&] { return kept.seq() == 5; }));
    viewer->stop();
    for (int i = 0; i < missed_ops; ++i)
        deformer.connection->requestDeform(randomRequest(rng, spec));
    ASSERT_TRUE(runUntil(io, [&] { return deformer.answers.size() == 5u + missed_ops; }));
    EXPECT_EQ(kept.seq(), 5u);
    viewer = connectViewer();
    ASSERT_TRUE(runUntil(
        io, [&] { return kept.seq() == srv.seq() && kept.worldHash() == srv.worldHash(); }));
    EXPECT_EQ(viewer->stats().resumes, expect_resume ? 1u : 0u);
    EXPECT_EQ(viewer->stats().snapshots, expect_resume ? 0u : 1u);
    EXPECT_EQ(kept.stats().snapshots, expect_resume ? 1u : 2u);
    viewer->stop();
}

TEST(Session, ReconnectWithinRetainedLogGetsOnlyMissedOps) {
    reconnectScenario(64, 20, true);
}

TEST(Session, ReconnectBeyondRetainedLogGetsSnapshot) {
    reconnectScenario(16, 40, false);
}

TEST(Session, AClientThatShipsTheMapJoinsByAGenesisDelta) {
    server::ServerConfig config = fastConfig();
    config.op_log_capacity = 16;
    TestServer srv(smallMap(), config);
    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    ASSERT_TRUE(runUntil(io, [&] { return deformer.replica.ready(); }));
    const WorldSpec spec = deformer.replica.terrain().spec();
    std::mt19937_64 rng(21);
    auto deform = [&](int n) {
        const std::size_t target = deformer.answers.size() + static_cast<std::size_t>(n);
        for (int i = 0; i < n; ++i)
            deformer.connection->requestDeform(randomRequest(rng, spec));
        ASSERT_TRUE(runUntil(io, [&] { return deformer.answers.size() == target; }));
    };
    // while the log still holds seq 1, a client at the genesis resumes from seq 0
    deform(5);
    TestClient early(io, srv.port(), token(2, Role::kViewer), true, {}, smallMap());
    ASSERT_TRUE(runUntil(io, [&] { return early.replica.seq() == srv.seq(); }));
    EXPECT_EQ(early.connection->stats().resumes, 1u);
    EXPECT_EQ(early.connection->stats().snapshots, 0u);

    // past the log: the genesis holder gets only what differs; the others the whole world
    deform(60);
    const std::uint64_t hash = srv.worldHash();
    TestClient shipped(io, srv.port(), token(3, Role::kViewer), true, {}, smallMap());
    TestClient bare(io, srv.port(), token(4, Role::kViewer));
    TestClient other_map(io, srv.port(), token(5, Role::kViewer), true, {}, smallMap(257, 6));
    std::vector<TestClient*> joiners = {&shipped, &bare, &other_map};
    ASSERT_TRUE(runUntil(io, [&] {
        return std::all_of(joiners.begin(), joiners.end(), [&](TestClient* c) {
            return c->replica.ready() && c->replica.worldHash() == hash;
        });
    }));
    EXPECT_EQ(shipped.connection->stats().genesis_deltas, 1u);
    EXPECT_EQ(shipped.connection->stats().snapshots, 1u);
    EXPECT_EQ(bare.connection->stats().genesis_deltas, 0u);
    EXPECT_EQ(other_map.connection->stats().genesis_deltas, 0u); // its genesis is not the server's
    EXPECT_EQ(other_map.connection->stats().snapshots, 1u);
    // 65 small craters touch a few tiles of 16: the delta is a fraction of the world
    EXPECT_LT(
        shipped.connection->stats().snapshot_bytes * 3, bare.connection->stats().snapshot_bytes);
    EXPECT_EQ(shipped.replica.terrain().computeWorldHash(), hash);

    // and goes on with live ops
    deform(10);
    ASSERT_TRUE(runUntil(io, [&] {
        return shipped.replica.seq() == srv.seq() && shipped.replica.worldHash() == srv.worldHash();
    }));
    const server::ServerStats stats = srv.stats();
    EXPECT_EQ(stats.genesis_deltas_sent, 1u);
    EXPECT_GE(stats.snapshots_sent, 3u); // the deformer, bare, other_map
}

TEST(Session, ReaderThatStopsReadingIsResyncedThenDisconnectedWithoutHurtingOthers) {
    server::ServerConfig config = fastConfig();
    config.outbound_budget_bytes = 8 << 10;
    config.snapshot_cache_max_lag = 1u << 30;
    server::TransportConfig transport;
    transport.socket_send_buffer_bytes = 8 << 10;
    TestServer srv(smallMap(129), config, nullptr, 0, transport);
    RawPeer stalled(srv.port(), 4096);
    stalled.sendHello(token(9, Role::kViewer)); // and then never reads
    asio::io_context io;
    std::vector<std::unique_ptr<TestClient>> clients;
    clients.push_back(std::make_unique<TestClient>(io, srv.port(), token(1, Role::kDeformer)));
    clients.push_back(std::make_unique<TestClient>(io, srv.port(), token(2, Role::kViewer)));
    ASSERT_TRUE(runUntil(io, [&] { return allAt(clients, 0, srv.worldHash()); }));
    std::mt19937_64 rng(5);
    const WorldSpec spec = clients[0]->replica.terrain().spec();
    std::size_t sent = 0;
    ASSERT_TRUE(runUntil(
        io,
        [&] {
            if (clients[0]->answers.size() == sent && sent < 3000) {
                for (int i = 0; i < 50; ++i)
                    clients[0]->connection->requestDeform(randomRequest(rng, spec));
                sent += 50;
            }
            return srv.stats().slow_disconnects == 1;
        },
        60.0));
    const server::ServerStats stats = srv.stats();
    EXPECT_GE(stats.resyncs, 1u);
    EXPECT_EQ(stats.slow_disconnects, 1u);
    ASSERT_TRUE(runUntil(io, [&] { return clients[0]->answers.size() == sent; }));
    ASSERT_TRUE(runUntil(io, [&] { return allAt(clients, srv.seq(), srv.worldHash()); }));
    for (auto& c : clients) {
        EXPECT_EQ(c->replica.stats().snapshots, 1u); // the healthy ones never needed a resync
        EXPECT_EQ(c->connection->stats().disconnects, 0u);
    }
    // memory went back: nothing is queued for the stalled peer any more
    EXPECT_LT(srv.call([&] { return srv.server().queuedBytes(); }), std::size_t{1} << 20);
}

struct AbuseCase {
    const char* name;
    std::function<void(RawPeer&)> act;
    pb::Reason expected;
};

TEST(Session, BadPeersGetAStatedReasonAndOthersAreUnaffected) {
    TestServer srv(smallMap(129), fastConfig());
    asio::io_context io;
    TestClient good(io, srv.port(), token(1, Role::kDeformer));
    ASSERT_TRUE(runUntil(io, [&] { return good.replica.ready(); }));

    const std::vector<AbuseCase> cases = {
        {"oversize frame",
         [](RawPeer& p) {
             p.sendBytes({0x80, 0x80, 0x80, 0x08});
         },
         pb::REASON_FRAME_TOO_LARGE},
        {"over-long prefix",
         [](RawPeer& p) {
             p.sendBytes({0x81, 0x80, 0x80, 0x80, 0x80, 0x01});
         },
         pb::REASON_BAD_FRAME},
        {"garbage body",
         [](RawPeer& p) {
             p.sendBytes({0x05, 0xff, 0xff, 0xff, 0xff, 0xff});
         },
         pb::REASON_BAD_FRAME},
        {"zero-length frame", [](RawPeer& p) { p.sendBytes({0x00}); }, pb::REASON_BAD_FRAME},
        {"a v1 client", [](RawPeer& p) { p.sendHello(token(2, Role::kViewer), 1); },
         pb::REASON_BAD_VERSION},
        {"bad token", [](RawPeer& p) { p.sendHello("v1.2.viewer.99999999999.00"); },
         pb::REASON_BAD_TOKEN},
        {"forged token",
         [](RawPeer& p) {
             const std::string other = "another-secret-of-enough-length";
             p.sendHello(server::mintToken(
                 {2, Role::kAdmin, unixNow() + 60},
                 std::vector<std::uint8_t>(other.begin(), other.end())));
         },
         pb::REASON_BAD_TOKEN},
        {"expired token", [](RawPeer& p) { p.sendHello(token(2, Role::kDeformer, -10)); },
         pb::REASON_BAD_TOKEN},
        {"request before hello",
         [](RawPeer& p) {
             pb::Envelope e;
             e.mutable_height_query()->set_x(1);
             p.send(e);
         },
         pb::REASON_PROTOCOL},
        {"server-only message",
         [](RawPeer& p) {
             p.sendHello(token(2, Role::kViewer));
             pb::Envelope e;
             e.mutable_op_applied()->set_seq(1);
             p.send(e);
         },
         pb::REASON_PROTOCOL},
        {"repair of more tiles than the limit",
         [](RawPeer& p) {
             p.sendHello(token(2, Role::kViewer));
             pb::Envelope e;
             for (int i = 0; i < 65; ++i)
                 e.mutable_repair_request()->add_tiles(0);
             p.send(e);
         },
         pb::REASON_OUT_OF_RANGE},
        {"repair of a tile outside the map",
         [](RawPeer& p) {
             p.sendHello(token(2, Role::kViewer));
             pb::Envelope e;
             e.mutable_repair_request()->add_tiles(100000);
             p.send(e);
         },
         pb::REASON_OUT_OF_RANGE},
    };
    for (const AbuseCase& c : cases) {
        RawPeer peer(srv.port());
        c.act(peer);
        std::string message;
        EXPECT_EQ(peer.readUntilDisconnect(10.0, &message), c.expected) << c.name;
        EXPECT_FALSE(message.empty()) << c.name;
    }
    {
        // truncated frame, then the peer goes away: the session just ends
        RawPeer peer(srv.port());
        peer.sendBytes({0x20, 0x01, 0x02});
    }
    // the well-behaved client kept working throughout
    const std::uint64_t before = srv.seq();
    good.connection->requestDeform(OpRequest{OpKind::kCrater, 30, 30, 3, 1, 0.3});
    ASSERT_TRUE(runUntil(io, [&] { return good.replica.seq() == before + 1; }));
    EXPECT_EQ(good.connection->stats().disconnects, 0u);
    EXPECT_GE(srv.stats().bad_tokens, 3u);
}

TEST(Session, RefusalsAndRateLimitsAffectOnlyTheRequest) {
    server::ServerConfig config;
    config.deform_rate_per_second = 1;
    config.deform_burst = 3;
    TestServer srv(smallMap(129), config);
    asio::io_context io;
    TestClient viewer(io, srv.port(), token(1, Role::kViewer));
    TestClient deformer(io, srv.port(), token(2, Role::kDeformer));
    ASSERT_TRUE(runUntil(io, [&] { return viewer.replica.ready() && deformer.replica.ready(); }));
    viewer.connection->requestDeform(OpRequest{OpKind::kCrater, 30, 30, 3, 1, 0.3});
    deformer.connection->requestDeform(OpRequest{OpKind::kCrater, 1e9, 30, 3, 1, 0.3});
    deformer.connection->requestDeform(OpRequest{OpKind::kCrater, 30, 30, -3, 1, 0.3});
    deformer.connection->requestDeform(OpRequest{OpKind::kCrater, 30, 30, 3, 1, 0.3});
    deformer.connection->requestDeform(OpRequest{OpKind::kCrater, 40, 30, 3, 1, 0.3});
    ASSERT_TRUE(
        runUntil(io, [&] { return viewer.answers.size() == 1 && deformer.answers.size() == 4; }));
    // refusals are answered at once, acceptances after the group commit: order by request id
    std::sort(deformer.answers.begin(), deformer.answers.end(), [](const auto& a, const auto& b) {
        return a.request_id < b.request_id;
    });
    EXPECT_FALSE(viewer.answers[0].accepted);
    EXPECT_NE(viewer.answers[0].reason.find("REASON_NOT_PERMITTED"), std::string::npos);
    EXPECT_NE(deformer.answers[0].reason.find("REASON_OUTSIDE_MAP"), std::string::npos);
    EXPECT_NE(deformer.answers[1].reason.find("REASON_OUT_OF_RANGE"), std::string::npos);
    EXPECT_TRUE(deformer.answers[2].accepted) << deformer.answers[2].reason;
    EXPECT_EQ(deformer.answers[2].seq, 1u);
    EXPECT_NE(deformer.answers[3].reason.find("REASON_RATE_LIMITED"), std::string::npos);
    ASSERT_TRUE(runUntil(io, [&] { return viewer.replica.seq() == 1; }));
    EXPECT_EQ(viewer.connection->stats().disconnects, 0u);
    EXPECT_EQ(deformer.connection->stats().disconnects, 0u);
}

TEST(Session, ForcedHashMismatchIsRepairedByTileRequest) {
    TestServer srv(smallMap(), fastConfig());
    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    TestClient victim(io, srv.port(), token(2, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return deformer.replica.ready() && victim.replica.ready(); }));
    // corrupt the victim far from where the server's next op lands
    ASSERT_TRUE(victim.replica.terrainForTesting()
                    .apply(*quantizeOp(
                        {OpKind::kRaise, 200, 200, 8, 2, 1}, victim.replica.terrain().spec()))
                    .ok());
    ASSERT_NE(victim.replica.worldHash(), srv.worldHash());
    deformer.connection->requestDeform(OpRequest{OpKind::kCrater, 20, 20, 3, 1, 0.3});
    ASSERT_TRUE(runUntil(io, [&] {
        return victim.replica.seq() == 1 && !victim.replica.diverged() &&
               victim.replica.worldHash() == srv.worldHash();
    }));
    EXPECT_EQ(victim.replica.stats().hash_mismatches, 1u);
    EXPECT_EQ(victim.replica.stats().repairs, 1u);
    EXPECT_EQ(victim.replica.stats().snapshots, 1u); // repaired by tiles, not a new snapshot
    EXPECT_GE(victim.connection->stats().repair_requests, 2u); // op tiles, then the corrupt one
    EXPECT_EQ(victim.replica.terrain().computeWorldHash(), srv.worldHash());
}

TEST(Session, APacedClientSpreadsABurstOverFramesAndConverges) {
    TestServer srv(smallMap(), fastConfig());
    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    TestClient paced(
        io, srv.port(), token(2, Role::kViewer), true, {.ops_per_frame = 2, .catch_up_frames = 4});
    ASSERT_TRUE(
        runUntil(io, [&] { return deformer.replica.ready() && paced.connection->synced(); }));
    std::mt19937_64 rng(5);
    const WorldSpec spec = deformer.replica.terrain().spec();
    for (int i = 0; i < 12; ++i)
        deformer.connection->requestDeform(randomRequest(rng, spec));
    // every op has arrived; none is applied until the frame loop asks
    ASSERT_TRUE(runUntil(
        io, [&] { return deformer.answers.size() == 12 && paced.connection->opsWaiting() == 12; }));
    ASSERT_EQ(srv.seq(), 12u);
    EXPECT_EQ(paced.replica.seq(), 0u);
    EXPECT_FALSE(paced.connection->synced()); // ops wait: not the server's state yet
    // 12 waiting, caught up within 4 frames: 3 a frame (more than the 2 asked)
    std::vector<std::size_t> per_frame;
    while (paced.connection->opsWaiting() > 0)
        per_frame.push_back(paced.connection->applyArrived());
    EXPECT_EQ(per_frame, (std::vector<std::size_t>{3, 3, 3, 3}));
    EXPECT_TRUE(paced.connection->synced());
    EXPECT_EQ(paced.replica.seq(), 12u);
    EXPECT_EQ(paced.replica.worldHash(), srv.worldHash());
    EXPECT_EQ(paced.replica.stats().hash_mismatches, 0u);
    EXPECT_EQ(paced.connection->applyArrived(), 0u);
}

TEST(Session, APacedClientThatDivergesIsRepairedWithItsInboxApplied) {
    TestServer srv(smallMap(), fastConfig());
    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    TestClient victim(
        io, srv.port(), token(2, Role::kViewer), true, {.ops_per_frame = 1, .catch_up_frames = 64});
    ASSERT_TRUE(runUntil(io, [&] { return deformer.replica.ready() && victim.replica.ready(); }));
    ASSERT_TRUE(victim.replica.terrainForTesting()
                    .apply(*quantizeOp(
                        {OpKind::kRaise, 200, 200, 8, 2, 1}, victim.replica.terrain().spec()))
                    .ok());
    for (int i = 0; i < 8; ++i)
        deformer.connection->requestDeform(OpRequest{OpKind::kCrater, 20.0 + 3 * i, 20, 3, 1, 0.3});
    // one op a frame: the first diverges and asks for a repair while the rest still wait; the
    // repair, at the server's later seq, applies them first
    ASSERT_TRUE(runUntil(io, [&] {
        victim.connection->applyArrived();
        return deformer.answers.size() == 8 && victim.connection->synced() &&
               victim.replica.seq() == 8 && victim.replica.worldHash() == srv.worldHash();
    }));
    EXPECT_GE(victim.replica.stats().hash_mismatches, 1u);
    EXPECT_GE(victim.replica.stats().repairs, 1u);
    EXPECT_EQ(victim.replica.stats().snapshots, 1u); // repaired by tiles, not a new snapshot
    EXPECT_EQ(victim.replica.terrain().computeWorldHash(), srv.worldHash());
}

TEST(Session, HeightAndRayQueriesMatchTheReplica) {
    TestServer srv(smallMap(), fastConfig());
    asio::io_context io;
    TestClient c(io, srv.port(), token(1, Role::kDeformer));
    ASSERT_TRUE(runUntil(io, [&] { return c.replica.ready(); }));
    c.connection->requestDeform(OpRequest{OpKind::kCrater, 100, 100, 4, 1.5, 0.3});
    ASSERT_TRUE(runUntil(io, [&] { return c.replica.seq() == 1; }));
    std::vector<client::HeightAnswer> heights;
    std::vector<client::RayAnswer> rays;
    c.connection->on_height_reply = [&](const client::HeightAnswer& a) { heights.push_back(a); };
    c.connection->on_ray_reply = [&](const client::RayAnswer& a) { rays.push_back(a); };
    c.connection->queryHeight(100.3, 99.1);
    c.connection->queryHeight(-5, 3);
    const double origin[3] = {90, 90, 200};
    const double dir[3] = {0.1, 0.1, -1};
    c.connection->castRay(origin, dir, 1000);
    const double bad[3] = {0, 0, std::numeric_limits<double>::quiet_NaN()};
    c.connection->castRay(origin, bad, 1000);
    ASSERT_TRUE(runUntil(io, [&] { return heights.size() == 2 && rays.size() == 2; }));
    EXPECT_TRUE(heights[0].inside);
    EXPECT_DOUBLE_EQ(heights[0].height, surfaceHeight(c.replica.terrain(), 100.3, 99.1));
    EXPECT_FALSE(heights[1].inside);
    const auto local = castRay(c.replica.terrain(), {90, 90, 200}, {0.1, 0.1, -1}, 1000);
    ASSERT_TRUE(local.has_value());
    ASSERT_TRUE(rays[0].hit);
    EXPECT_DOUBLE_EQ(rays[0].point[2], local->point.z);
    EXPECT_NE(rays[1].refused.find("REASON_OUT_OF_RANGE"), std::string::npos);
}

TEST(Session, PeerThatAsksButNeverReadsIsCutOffAtItsBudget) {
    server::ServerConfig config = fastConfig();
    config.outbound_budget_bytes = 64 << 10;
    config.close_linger_seconds = 0.2;
    server::TransportConfig transport;
    transport.socket_send_buffer_bytes = 8 << 10;
    TestServer srv(smallMap(1025), config, nullptr, 0, transport);
    RawPeer greedy(srv.port(), 4096);
    greedy.sendHello(token(9, Role::kViewer));
    pb::Envelope repair;
    for (std::uint32_t t = 0; t < 64; ++t)
        repair.mutable_repair_request()->add_tiles(t);
    for (int i = 0; i < 5; ++i)
        greedy.send(repair); // within the repair rate's burst, each reply far over the budget
    asio::io_context io;
    ASSERT_TRUE(runUntil(io, [&] { return srv.stats().slow_disconnects == 1; }));
    ASSERT_TRUE(
        runUntil(io, [&] { return srv.call([&] { return srv.server().sessionCount(); }) == 0; }));
    EXPECT_LT(srv.call([&] { return srv.server().queuedBytes(); }), std::size_t{1} << 20);
}

TEST(Session, JoinFarBehindTheCachedSnapshotIsNotTreatedAsSlow) {
    server::ServerConfig config = fastConfig();
    config.outbound_budget_bytes = 8 << 10;
    config.snapshot_cache_max_lag = 1u << 30;
    TestServer srv(smallMap(129), config);
    asio::io_context io;
    TestClient first(io, srv.port(), token(1, Role::kDeformer)); // builds the cached snapshot
    ASSERT_TRUE(runUntil(io, [&] { return first.replica.ready(); }));
    std::mt19937_64 rng(9);
    const WorldSpec spec = first.replica.terrain().spec();
    // in windows of 20, so that the deformer itself stays inside its small budget
    for (std::size_t sent = 0; sent < 600; sent += 20) {
        for (int i = 0; i < 20; ++i)
            first.connection->requestDeform(randomRequest(rng, spec));
        ASSERT_TRUE(runUntil(io, [&] { return first.answers.size() == sent + 20; }));
    }
    // 600 ops of tail would not fit an 8 KiB budget: the server must rebuild the snapshot
    TestClient late(io, srv.port(), token(2, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] {
        return late.replica.ready() && late.replica.seq() == srv.seq() &&
               late.replica.worldHash() == srv.worldHash();
    }));
    EXPECT_EQ(late.connection->stats().disconnects, 0u);
    EXPECT_EQ(srv.stats().slow_disconnects, 0u);
}

TEST(Session, QueriesAboveTheRateAreRefusedAndTheSessionStays) {
    server::ServerConfig config = fastConfig();
    config.query_rate_per_second = 10;
    config.query_burst = 20;
    TestServer srv(smallMap(129), config);
    asio::io_context io;
    TestClient c(io, srv.port(), token(1, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return c.replica.ready(); }));
    std::vector<client::HeightAnswer> answers;
    c.connection->on_height_reply = [&](const client::HeightAnswer& a) { answers.push_back(a); };
    for (int i = 0; i < 60; ++i)
        c.connection->queryHeight(10, 10);
    ASSERT_TRUE(runUntil(io, [&] { return answers.size() == 60; }));
    const auto refused = std::count_if(answers.begin(), answers.end(), [](const auto& a) {
        return a.refused.find("REASON_RATE_LIMITED") != std::string::npos;
    });
    EXPECT_GE(refused, 30);
    EXPECT_LE(refused, 40);
    EXPECT_EQ(c.connection->stats().disconnects, 0u);
}

TEST(Session, AJoinWaitingForItsSnapshotDelaysNoOtherSession) {
    // the join snapshot is built off the io thread: held there, the joiner waits while every
    // other session's ops go on; released, the joiner gets the snapshot and the ops after it
    server::ServerConfig config = fastConfig();
    config.outbound_budget_bytes = 4 << 10;   // a tail of 32 ops at most: 40 make the cache stale
    config.snapshot_cache_max_lag = 1u << 30; // no refresh ahead of a join
    std::atomic<bool> hold{false};
    std::atomic<int> builds{0};
    config.before_snapshot_build = [&] {
        ++builds;
        while (hold.load())
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
    };
    TestServer srv(smallMap(129), config);
    struct Release { // a failed assertion must not leave the build held: srv would never stop
        std::atomic<bool>& held;
        ~Release() { held = false; }
    } release{hold};
    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    TestClient viewer(io, srv.port(), token(2, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return deformer.replica.ready() && viewer.replica.ready(); }));
    std::mt19937_64 rng(4);
    const WorldSpec spec = deformer.replica.terrain().spec();
    const auto deform = [&](std::size_t n) {
        const std::size_t before = deformer.answers.size();
        for (std::size_t i = 0; i < n; ++i)
            deformer.connection->requestDeform(randomRequest(rng, spec));
        return runUntil(io, [&] { return deformer.answers.size() == before + n; });
    };
    for (int window = 0; window < 4; ++window)
        ASSERT_TRUE(deform(10));
    ASSERT_EQ(builds.load(), 1);
    const std::uint64_t before_hold = srv.seq();
    hold = true;
    TestClient late(io, srv.port(), token(3, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return builds.load() == 2; }));
    ASSERT_TRUE(deform(10)); // answered while the build is held
    ASSERT_TRUE(runUntil(io, [&] { return viewer.replica.seq() == srv.seq(); }));
    EXPECT_GT(viewer.replica.seq(), before_hold);
    EXPECT_FALSE(late.replica.ready()) << "the snapshot was held";
    hold = false;
    ASSERT_TRUE(runUntil(io, [&] {
        return late.replica.ready() && late.replica.seq() == srv.seq() &&
               late.replica.worldHash() == srv.worldHash();
    }));
    EXPECT_EQ(late.connection->stats().disconnects, 0u);
    EXPECT_EQ(srv.stats().snapshots_built, 2u);
}

TEST(Session, AJournalSyncInProgressDelaysNoReplyAndTheNextGroupQueuesBehindIt) {
    // the commit pipeline: a group's fdatasync held on the commit thread; meanwhile the io
    // thread answers queries and accepts more ops (the next group), acknowledging none of them
    // until the held group is durable; then every op arrives in seq order
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("terrain_pipeline_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::atomic<bool> hold{false};
    std::atomic<int> syncs{0};
    journal::JournalOptions options;
    options.before_sync = [&] {
        ++syncs;
        while (hold.load())
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
    };
    auto opened = journal::Journal::open(dir, options);
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    journal::Journal j = std::move(*opened);
    ASSERT_TRUE(j.initialize(smallMap(129), 0).ok());
    struct Release {
        std::atomic<bool>& held;
        ~Release() { held = false; }
    };
    {
        TestServer srv(smallMap(129), fastConfig(), &j);
        // after srv: a failed assertion releases the sync before srv waits for its threads
        Release release{hold};
        asio::io_context io;
        TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
        TestClient viewer(io, srv.port(), token(2, Role::kViewer));
        ASSERT_TRUE(
            runUntil(io, [&] { return deformer.replica.ready() && viewer.replica.ready(); }));
        std::vector<std::uint64_t> applied;
        viewer.connection->on_applied = [&](std::uint64_t seq) { applied.push_back(seq); };
        std::vector<client::HeightAnswer> heights;
        viewer.connection->on_height_reply = [&](const client::HeightAnswer& a) {
            heights.push_back(a);
        };
        std::mt19937_64 rng(5);
        const WorldSpec spec = deformer.replica.terrain().spec();
        hold = true;
        deformer.connection->requestDeform(randomRequest(rng, spec));
        ASSERT_TRUE(runUntil(io, [&] { return syncs.load() == 1; })); // its sync is held
        for (int i = 0; i < 5; ++i) // the next group, accepted while the first is out
            deformer.connection->requestDeform(randomRequest(rng, spec));
        viewer.connection->queryHeight(20.0, 20.0);
        ASSERT_TRUE(runUntil(io, [&] { return heights.size() == 1; }))
            << "a query waited for the journal";
        EXPECT_TRUE(deformer.answers.empty()) << "an op was acknowledged before it was durable";
        EXPECT_TRUE(applied.empty()) << "an op was broadcast before it was durable";
        hold = false;
        ASSERT_TRUE(runUntil(io, [&] { return deformer.answers.size() == 6; }));
        ASSERT_TRUE(runUntil(io, [&] { return viewer.replica.seq() == 6; }));
        EXPECT_EQ(applied, (std::vector<std::uint64_t>{1, 2, 3, 4, 5, 6}));
        EXPECT_EQ(viewer.replica.worldHash(), srv.worldHash());
        for (std::size_t i = 0; i < 6; ++i)
            EXPECT_EQ(deformer.answers[i].seq, i + 1);
        EXPECT_EQ(syncs.load(), 2); // two groups: the held one and the five behind it
        EXPECT_EQ(srv.stats().commits, 2u);
        EXPECT_EQ(j.lastSeq(), 6u);
    }
    std::filesystem::remove_all(dir);
}

void batchedBurst(bool hash_per_op) {
    server::ServerConfig config = fastConfig();
    config.batch_broadcasts = true;
    config.batch_hash_per_op = hash_per_op;
    TestServer srv(smallMap(), config);
    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    TestClient viewer(io, srv.port(), token(2, Role::kViewer));
    client::OpPacing paced;
    paced.ops_per_frame = 3;
    TestClient slow(io, srv.port(), token(3, Role::kViewer), true, paced);
    ASSERT_TRUE(runUntil(io, [&] {
        return deformer.replica.ready() && viewer.replica.ready() && slow.replica.ready();
    }));
    std::mt19937_64 rng(9);
    const WorldSpec spec = deformer.replica.terrain().spec();
    for (int i = 0; i < 60; ++i) // one write: a burst the server commits in one or few groups
        deformer.connection->requestDeform(randomRequest(rng, spec));
    ASSERT_TRUE(runUntil(io, [&] {
        slow.connection->applyArrived(); // a frame loop: a few ops a frame
        return deformer.answers.size() == 60 && viewer.replica.seq() == srv.seq() &&
               slow.replica.seq() == srv.seq();
    }));
    const std::uint64_t hash = srv.worldHash();
    for (TestClient* c : {&deformer, &viewer, &slow}) {
        EXPECT_EQ(c->replica.worldHash(), hash);
        EXPECT_EQ(c->replica.verifiedSeq(), srv.seq()) << "the last op of the last batch checked";
        EXPECT_EQ(c->replica.stats().hash_mismatches, 0u);
        EXPECT_GT(c->connection->stats().op_batches, 0u);
    }
    // accepted requests are answered in seq order (some random craters are refused: too deep)
    std::uint64_t last = 0;
    for (const client::DeformAnswer& a : deformer.answers) {
        if (!a.accepted)
            continue;
        EXPECT_EQ(a.seq, last + 1);
        last = a.seq;
    }
    EXPECT_EQ(last, srv.seq());
    const double per_op = static_cast<double>(viewer.connection->stats().op_bytes_in) /
                          static_cast<double>(srv.seq());
    // an OpApplied is about 30 bytes; batched, the hash and framing are shared
    if (hash_per_op)
        EXPECT_LT(per_op, 30.0);
    else
        EXPECT_LT(per_op, 20.0);
}

TEST(Session, ABurstGoesOutInBatchesAndEveryClientConverges) {
    batchedBurst(false);
}

TEST(Session, BatchesWithEveryOpsHashConvergeToo) {
    batchedBurst(true);
}

/// A HealthRequest as the first frame, as `terrain-server health` sends it: one HealthReply.
void expectHealthReply(std::uint16_t port) {
    RawPeer probe(port);
    pb::Envelope e;
    e.mutable_health_request();
    probe.send(e);
    probe.readUntilDisconnect(0.5);
    ASSERT_EQ(probe.received.size(), 1u);
    EXPECT_EQ(probe.received[0], pb::Envelope::kHealthReply);
}

TEST(Session, HealthRequestAnswersWithoutAToken) {
    TestServer srv(smallMap(129), fastConfig());
    expectHealthReply(srv.port());
}

// A flood in one write: the session closes for flooding with most of it unread. Its Disconnect
// must still reach the peer (a socket closed with unread input sends a reset, and the peer's
// kernel drops what it had not read yet, the Disconnect with it).
TEST(Session, AFloodInOneWriteStillGetsItsDisconnectReason) {
    TestServer srv(smallMap(129), fastConfig());
    for (int attempt = 0; attempt < 3; ++attempt) {
        RawPeer peer(srv.port());
        std::vector<std::uint8_t> bytes;
        pb::Envelope hello;
        hello.mutable_hello()->set_protocol_version(wire::kProtocolVersion);
        hello.mutable_hello()->set_token(token(2, Role::kViewer));
        wire::appendFrame(hello, bytes);
        pb::Envelope ping;
        for (int i = 0; i < 6000; ++i) {
            ping.mutable_ping()->set_nonce(static_cast<std::uint64_t>(i) + 1);
            wire::appendFrame(ping, bytes);
        }
        peer.sendBytes(bytes);
        std::string message;
        EXPECT_EQ(peer.readUntilDisconnect(10.0, &message), pb::REASON_FLOODING)
            << "attempt " << attempt;
        EXPECT_NE(message.find("frames per second"), std::string::npos) << message;
    }
}

// The health command, tried as an operator would, against a server whose player slots are all
// taken: it must answer, not be refused as one more player.
TEST(Session, HealthAnswersWhenEveryPlayerSlotIsTaken) {
    server::ServerConfig config = fastConfig();
    config.max_sessions = 2;
    TestServer srv(smallMap(129), config);
    asio::io_context io;
    TestClient a(io, srv.port(), token(1, Role::kViewer));
    TestClient b(io, srv.port(), token(2, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return a.replica.ready() && b.replica.ready(); }));
    {
        RawPeer third(srv.port());
        third.sendHello(token(3, Role::kViewer));
        std::string message;
        EXPECT_EQ(third.readUntilDisconnect(5.0, &message), pb::REASON_SERVER_FULL);
        EXPECT_NE(message.find("player"), std::string::npos) << message;
    }
    expectHealthReply(srv.port());
}

// A client refused for a full server backs off: its delay doubles with each refusal (0.05 s,
// 0.1, 0.2, ...), so in 2 s it tries about 6 times, not 40; once a slot frees it joins.
TEST(Session, AClientRefusedForAFullServerBacksOff) {
    server::ServerConfig config = fastConfig();
    config.max_sessions = 1;
    TestServer srv(smallMap(129), config);
    asio::io_context io;
    auto first = std::make_unique<TestClient>(io, srv.port(), token(1, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return first->replica.ready(); }));
    TestClient second(io, srv.port(), token(2, Role::kViewer)); // reconnects every 0.05 s
    io.run_for(std::chrono::seconds(2));
    const std::uint64_t tries = second.connection->stats().connects;
    EXPECT_GE(tries, 3u);
    EXPECT_LE(tries, 8u) << "no backoff: a refused client retried " << tries << " times in 2 s";
    ASSERT_FALSE(second.disconnects.empty());
    EXPECT_NE(second.disconnects.back().find("REASON_SERVER_FULL"), std::string::npos);
    first.reset(); // a slot frees: the next try joins
    ASSERT_TRUE(runUntil(
        io, [&] { return second.replica.ready(); }, 10.0));
}

// Connections that never say Hello have their own limits, in all and per address: a few idle
// sockets (reopened as each times out) cannot keep players out.
TEST(Session, ConnectionsThatNeverSayHelloTakeNoPlayersPlace) {
    server::ServerConfig config = fastConfig();
    config.max_sessions = 2;
    config.max_pending_sessions = 4;
    config.max_pending_per_address = 2;
    TestServer srv(smallMap(129), config);
    // one address holds its share of idle sockets; its next one is refused at once
    std::vector<std::unique_ptr<RawPeer>> idle;
    for (int i = 0; i < 2; ++i)
        idle.push_back(std::make_unique<RawPeer>(srv.port(), 0, "127.0.0.2"));
    {
        RawPeer extra(srv.port(), 0, "127.0.0.2");
        std::string message;
        EXPECT_EQ(extra.readUntilDisconnect(5.0, &message), pb::REASON_SERVER_FULL);
        EXPECT_NE(message.find("127.0.0.2"), std::string::npos) << message;
    }
    // players (from another address) still take both slots
    asio::io_context io;
    TestClient a(io, srv.port(), token(1, Role::kViewer));
    TestClient b(io, srv.port(), token(2, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return a.replica.ready() && b.replica.ready(); }));
    EXPECT_EQ(a.connection->stats().disconnects + b.connection->stats().disconnects, 0u);
    // idle sockets from more addresses fill the pending limit; past it, any address is refused
    for (const char* from : {"127.0.0.3", "127.0.0.4"})
        idle.push_back(std::make_unique<RawPeer>(srv.port(), 0, from));
    RawPeer over(srv.port(), 0, "127.0.0.5");
    std::string message;
    EXPECT_EQ(over.readUntilDisconnect(5.0, &message), pb::REASON_SERVER_FULL);
    EXPECT_NE(message.find("waiting"), std::string::npos) << message;
}

TEST(Session, HealthPairsTheBroadcastSeqWithItsOwnHash) {
    // Deform and health requests in one write: the server applies each deform at once but
    // broadcasts it only when the read pass ends, so every health reply is answered while ops are
    // accepted and not yet committed. Its (seq, hash) must still be one state: the hash after op
    // seq, as broadcast, not the authority's newer terrain.
    TestServer srv(smallMap(129), fastConfig());
    const std::uint64_t start_hash = srv.worldHash();
    RawPeer peer(srv.port());
    peer.sendHello(token(1, Role::kDeformer));
    std::vector<std::uint8_t> bytes;
    for (std::uint32_t i = 0; i < 20; ++i) {
        pb::Envelope deform;
        deform.mutable_deform()->set_request_id(i + 1);
        OpRequest r;
        r.kind = OpKind::kCrater;
        r.x = 20.0 + 4.0 * i;
        r.y = 40.0;
        r.radius = 3.0;
        r.height = 1.0;
        r.strength = 0.5;
        wire::requestToWire(r, *deform.mutable_deform()->mutable_metres());
        wire::appendFrame(deform, bytes);
        pb::Envelope health;
        health.mutable_health_request();
        wire::appendFrame(health, bytes);
    }
    peer.sendBytes(bytes);
    peer.readUntilDisconnect(1.0);
    std::map<std::uint64_t, std::uint64_t> hash_at{{0, start_hash}};
    std::vector<std::pair<std::uint64_t, std::uint64_t>> health;
    std::uint64_t seq = 0;
    for (const pb::Envelope& e : peer.envelopes) {
        if (e.has_op_applied()) { // seq is stated every 16th op, else the previous one's + 1
            seq = e.op_applied().seq() != 0 ? e.op_applied().seq() : seq + 1;
            hash_at[seq] = e.op_applied().world_hash();
        }
        if (e.has_health_reply())
            health.emplace_back(e.health_reply().seq(), e.health_reply().world_hash());
        if (e.has_deform_reply() && e.deform_reply().has_refused())
            ADD_FAILURE() << e.deform_reply().refused().DebugString();
    }
    ASSERT_EQ(hash_at.size(), 21u) << "every deform must be accepted and broadcast";
    ASSERT_EQ(health.size(), 20u);
    for (const auto& [at, hash] : health) {
        ASSERT_TRUE(hash_at.count(at) != 0) << at;
        EXPECT_EQ(hash, hash_at[at]) << "health at seq " << at;
    }
}

} // namespace
} // namespace terrain::testing
