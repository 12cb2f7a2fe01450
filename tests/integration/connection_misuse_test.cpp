// What a game gets wrong with a connection, each answered at once and by name: a request made
// while no link is up is refused (not dropped in silence), a dead server is given up on after
// the configured time, and an old loss is not reported after a new link went live.

#include "support/net_harness.h"
#include "support/terrain_builders.h"

#include <chrono>
#include <string>

namespace terrain::testing {
namespace {

using server::Role;

// a loopback port nothing listens on (bound, read, closed)
std::uint16_t deadPort() {
    asio::io_context io;
    asio::ip::tcp::acceptor acceptor(io, {asio::ip::make_address("127.0.0.1"), 0});
    const std::uint16_t port = acceptor.local_endpoint().port();
    acceptor.close();
    return port;
}

client::ConnectionConfig configFor(std::uint16_t port, std::string tok) {
    client::ConnectionConfig config;
    config.port = port;
    config.token = std::move(tok);
    config.reconnect_delay_seconds = 0.05;
    config.reconnect_max_delay_seconds = 0.2;
    return config;
}

TEST(ConnectionMisuse, ARequestWithNoLinkUpIsRefusedAtOnceByName) {
    asio::io_context io;
    client::Replica replica;
    auto connection = std::make_shared<client::Connection>(io, configFor(deadPort(), "t"), replica);
    int answers = 0;
    connection->on_deform_reply = [&](const client::DeformAnswer&) { ++answers; };
    // before start(), and while the attempts fail
    EXPECT_EQ(connection->requestDeform(OpRequest{OpKind::kCrater, 30, 30, 3, 1, 0.3}), 0u);
    EXPECT_EQ(connection->lastRefusal().rfind("NOT_CONNECTED: ", 0), 0u)
        << connection->lastRefusal();
    connection->start();
    runUntil(
        io, [] { return false; }, 0.2);
    EXPECT_EQ(connection->queryHeight(10, 10), 0u);
    const double origin[3] = {10, 10, 100};
    const double down[3] = {0, 0, -1};
    EXPECT_EQ(connection->castRay(origin, down, 200), 0u);
    EXPECT_EQ(connection->lastRefusal().rfind("NOT_CONNECTED: ", 0), 0u);
    EXPECT_EQ(answers, 0);
    connection->stop();
}

TEST(ConnectionMisuse, ADeadServerIsGivenUpOnAfterTheConfiguredTime) {
    asio::io_context io;
    client::Replica replica;
    client::ConnectionConfig config = configFor(deadPort(), "t");
    config.give_up_seconds = 0.5;
    auto connection = std::make_shared<client::Connection>(io, config, replica);
    std::vector<std::string> disconnects;
    connection->on_disconnect = [&](const std::string& why) { disconnects.push_back(why); };
    const auto started = std::chrono::steady_clock::now();
    connection->start();
    ASSERT_TRUE(runUntil(
        io, [&] { return connection->state() == client::Connection::State::kClosed; }, 10.0));
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    EXPECT_GE(took, 0.5);
    EXPECT_LT(took, 5.0); // on time, not after a long backoff
    EXPECT_EQ(connection->lastDisconnect().rfind("CONNECT_TIMEOUT: ", 0), 0u)
        << connection->lastDisconnect();
    EXPECT_NE(connection->lastDisconnect().find("connect: "), std::string::npos)
        << "names the last failure: " << connection->lastDisconnect();
    ASSERT_FALSE(disconnects.empty());
    EXPECT_EQ(disconnects.back(), connection->lastDisconnect());
    // and it stays closed: nothing more is tried
    const std::uint64_t connects = connection->stats().connects;
    runUntil(
        io, [] { return false; }, 0.3);
    EXPECT_EQ(connection->state(), client::Connection::State::kClosed);
    EXPECT_EQ(connection->stats().connects, connects);
}

TEST(ConnectionMisuse, AnOldLossIsNotReportedOnceTheLinkIsLiveAgain) {
    TestServer srv(smallMap());
    asio::io_context io;
    TestClient c(io, srv.port(), token(7, Role::kDeformer));
    auto live = [&] { return c.connection->state() == client::Connection::State::kLive; };
    ASSERT_TRUE(runUntil(io, live));
    EXPECT_EQ(c.connection->lastDisconnect(), "");
    c.connection->dropForTesting();
    EXPECT_EQ(c.connection->lastDisconnect(), "dropped by the test");
    EXPECT_EQ(c.connection->requestDeform(OpRequest{OpKind::kCrater, 30, 30, 3, 1, 0.3}), 0u);
    ASSERT_TRUE(runUntil(io, live));
    EXPECT_EQ(c.connection->lastDisconnect(), "");
    // live again, requests go through and are answered
    const std::uint32_t id =
        c.connection->requestDeform(OpRequest{OpKind::kCrater, 30, 30, 3, 1, 0.3});
    EXPECT_NE(id, 0u);
    ASSERT_TRUE(runUntil(io, [&] { return !c.answers.empty(); }));
    EXPECT_EQ(c.answers.back().request_id, id);
    EXPECT_TRUE(c.answers.back().accepted) << c.answers.back().reason;
}

} // namespace
} // namespace terrain::testing
