// The game client's network thread (ClientOptions::network_thread) on its own, against a loopback
// server: the syncs it hands over bring the frame's copy to the server's world without applying
// an op there, the tiles the ops changed and no more; before any world they bring nothing; and
// an exception on the thread closes the client by name instead of ending the process.

#include "network_thread.h"
#include "support/net_harness.h"
#include "support/terrain_builders.h"

#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace terrain::testing {
namespace {

using game::detail::NetworkNews;
using game::detail::NetworkThread;
using server::Role;

client::ConnectionConfig networkConfigFor(std::uint16_t port, std::string tok) {
    client::ConnectionConfig config;
    config.port = port;
    config.token = std::move(tok);
    config.reconnect_delay_seconds = 0.05;
    return config;
}

// take()s until `done(news so far)` or 20 s; `frame` follows every sync taken, and `synced_tiles`
// counts the tiles they carried
bool takeUntil(
    NetworkThread& net,
    client::Replica& frame,
    NetworkNews& latest,
    const std::function<bool(const NetworkNews&)>& done,
    std::size_t* synced_tiles = nullptr) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
        NetworkNews news = net.take();
        for (const client::ReplicaSync& sync : news.syncs) {
            frame.follow(sync);
            if (synced_tiles != nullptr)
                *synced_tiles += sync.terrain.tileCount();
        }
        for (client::DeformAnswer& a : news.answers)
            latest.answers.push_back(std::move(a));
        news.answers = std::move(latest.answers);
        news.syncs.clear();
        latest = std::move(news);
        if (done(latest))
            return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return false;
}

void fireCraters(NetworkThread& net, int n, int first) {
    for (int k = 0; k < n; ++k)
        net.requestDeform(
            OpRequest{OpKind::kCrater, 40.0 + 12.0 * (first + k), 60.0, 3.0, 1.0, 0.3});
}

TEST(NetworkThread, ItsSyncsBringTheFramesCopyToTheServersWorldApplyingNoOpThere) {
    TestServer srv(smallMap());
    NetworkThread net(networkConfigFor(srv.port(), token(21, Role::kDeformer)));
    client::Replica frame;
    frame.recordChanges(true); // as the frame's copy does for its tessellation worker
    NetworkNews latest;
    ASSERT_TRUE(takeUntil(net, frame, latest, [](const NetworkNews& n) { return n.synced; }));
    ASSERT_TRUE(frame.ready());
    EXPECT_TRUE(frame.takeDirty().all) << "the join's world, whole";
    (void)frame.takeChanges();
    fireCraters(net, 5, 0);
    std::size_t tiles = 0;
    ASSERT_TRUE(takeUntil(
        net, frame, latest,
        [&](const NetworkNews& n) { return n.answers.size() == 5 && frame.seq() == 5; }, &tiles));
    for (const client::DeformAnswer& a : latest.answers)
        EXPECT_TRUE(a.accepted) << a.reason;
    EXPECT_EQ(latest.stats.hash_mismatches, 0u);
    EXPECT_EQ(latest.seq, 5u);
    EXPECT_EQ(frame.worldHash(), srv.worldHash());
    EXPECT_EQ(frame.terrain().computeWorldHash(), srv.worldHash()) << "the bits, not the hash";
    EXPECT_EQ(frame.stats().ops_applied, 0u) << "the network's replica applied them, once";
    // the tiles the craters touched came, not the world: five craters on a row of the map
    EXPECT_GT(tiles, 0u);
    EXPECT_LT(tiles, 5u * static_cast<std::size_t>(frame.terrain().spec().tileCount()));
    // and the frame's copy passes the ops on (to its worker) with their cells
    const std::vector<client::ReplicaChange> passed = frame.takeChanges();
    ASSERT_EQ(passed.size(), 5u);
    for (const client::ReplicaChange& c : passed) {
        EXPECT_EQ(c.kind, client::ReplicaChange::Kind::kOp);
        EXPECT_FALSE(c.cells.empty());
    }
    EXPECT_EQ(frame.takeDirty().cells.size(), 5u);
    net.stop();
}

TEST(NetworkThread, BeforeAnyWorldItsSyncsBringNothing) {
    TestServer srv(smallMap());
    // a token the server refuses: the link never holds a world
    NetworkThread net(networkConfigFor(srv.port(), "not a token"));
    client::Replica frame;
    NetworkNews latest;
    ASSERT_TRUE(takeUntil(net, frame, latest, [](const NetworkNews& n) { return n.closed; }));
    EXPECT_FALSE(frame.ready());
    EXPECT_FALSE(latest.synced);
}

TEST(NetworkThread, AnExceptionOnTheThreadClosesTheClientByNameAndStopStillJoins) {
    TestServer srv(smallMap());
    NetworkThread net(networkConfigFor(srv.port(), token(22, Role::kDeformer)));
    client::Replica frame;
    NetworkNews latest;
    ASSERT_TRUE(takeUntil(net, frame, latest, [](const NetworkNews& n) { return n.synced; }));
    net.throwOnTheThreadForTesting("out of tiles");
    ASSERT_TRUE(takeUntil(net, frame, latest, [](const NetworkNews& n) { return n.closed; }));
    EXPECT_FALSE(latest.live);
    EXPECT_FALSE(latest.synced);
    EXPECT_EQ(latest.last_disconnect, "INTERNAL: network thread: out of tiles");
    // the server sees the link go: the connection was stopped, not left open
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (srv.stats().sessions_live != 0 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    EXPECT_EQ(srv.stats().sessions_live, 0u) << "the link is closed, not left open";
    net.stop(); // returns: the thread idles until stopped, then ends
}

} // namespace
} // namespace terrain::testing
