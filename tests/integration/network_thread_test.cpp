// The game client's network thread (ClientOptions::network_thread) on its own, against a loopback
// server: the checked changes it hands over rebuild the server's world on another copy; asked
// for its whole state (what the frame does when its copy cannot replay a change), it hands over
// the server's world, from which a fresh copy follows the ops after; and an exception on the
// thread closes the client by name instead of ending the process.

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

// take()s until `done(news so far)` or 20 s; every change taken is appended to `changes`
bool takeUntil(
    NetworkThread& net,
    std::vector<client::ReplicaChange>& changes,
    NetworkNews& latest,
    const std::function<bool(const NetworkNews&)>& done) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
        NetworkNews news = net.take();
        for (client::ReplicaChange& c : news.changes)
            changes.push_back(std::move(c));
        for (client::DeformAnswer& a : news.answers)
            latest.answers.push_back(std::move(a));
        news.answers = std::move(latest.answers);
        news.changes.clear();
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

TEST(NetworkThread, ItsWholeStateIsTheServersWorldAndAFreshCopyFollowsOnFromIt) {
    TestServer srv(smallMap());
    NetworkThread net(networkConfigFor(srv.port(), token(21, Role::kDeformer)));
    std::vector<client::ReplicaChange> changes;
    NetworkNews latest;
    ASSERT_TRUE(takeUntil(net, changes, latest, [](const NetworkNews& n) { return n.synced; }));
    fireCraters(net, 5, 0);
    ASSERT_TRUE(takeUntil(net, changes, latest, [](const NetworkNews& n) {
        return n.answers.size() == 5 && n.seq == 5;
    }));
    for (const client::DeformAnswer& a : latest.answers)
        EXPECT_TRUE(a.accepted) << a.reason;
    EXPECT_EQ(latest.stats.hash_mismatches, 0u);

    // the changes handed over rebuild the server's world on the frame's copy
    client::Replica frame;
    for (const client::ReplicaChange& c : changes)
        ASSERT_TRUE(frame.replay(c).ok());
    EXPECT_EQ(frame.seq(), 5u);
    EXPECT_EQ(frame.worldHash(), srv.worldHash());

    // asked for its whole state: one change, the server's world at its seq
    changes.clear();
    net.resendState();
    ASSERT_TRUE(
        takeUntil(net, changes, latest, [&](const NetworkNews&) { return !changes.empty(); }));
    ASSERT_EQ(changes.size(), 1u);
    ASSERT_EQ(changes[0].kind, client::ReplicaChange::Kind::kState);
    EXPECT_EQ(changes[0].seq, 5u);
    ASSERT_NE(changes[0].state, nullptr);
    EXPECT_EQ(changes[0].state->worldHash(), srv.worldHash());

    // a fresh copy starts from it and follows the ops after it
    client::Replica fresh;
    ASSERT_TRUE(fresh.replay(changes[0]).ok());
    EXPECT_EQ(fresh.worldHash(), srv.worldHash());
    changes.clear();
    fireCraters(net, 3, 5);
    ASSERT_TRUE(takeUntil(net, changes, latest, [](const NetworkNews& n) { return n.seq == 8; }));
    for (const client::ReplicaChange& c : changes) {
        EXPECT_EQ(c.kind, client::ReplicaChange::Kind::kOp);
        ASSERT_TRUE(fresh.replay(c).ok());
    }
    EXPECT_EQ(fresh.seq(), 8u);
    EXPECT_EQ(fresh.worldHash(), srv.worldHash());
    net.stop();
}

TEST(NetworkThread, BeforeAnyWorldAskingForTheWholeStateHandsOverNothing) {
    TestServer srv(smallMap());
    // a token the server refuses: the link never holds a world
    NetworkThread net(networkConfigFor(srv.port(), "not a token"));
    net.resendState();
    std::vector<client::ReplicaChange> changes;
    NetworkNews latest;
    ASSERT_TRUE(takeUntil(net, changes, latest, [](const NetworkNews& n) { return n.closed; }));
    EXPECT_TRUE(changes.empty());
    EXPECT_FALSE(latest.synced);
}

TEST(NetworkThread, AnExceptionOnTheThreadClosesTheClientByNameAndStopStillJoins) {
    TestServer srv(smallMap());
    NetworkThread net(networkConfigFor(srv.port(), token(22, Role::kDeformer)));
    std::vector<client::ReplicaChange> changes;
    NetworkNews latest;
    ASSERT_TRUE(takeUntil(net, changes, latest, [](const NetworkNews& n) { return n.synced; }));
    net.throwOnTheThreadForTesting("out of tiles");
    ASSERT_TRUE(takeUntil(net, changes, latest, [](const NetworkNews& n) { return n.closed; }));
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
