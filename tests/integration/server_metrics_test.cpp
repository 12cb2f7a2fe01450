// The probes and the Prometheus endpoint over real HTTP, as an orchestrator and a scraper use
// them: liveness, readiness (false once draining), and figures that move with real traffic.

#include "support/net_harness.h"
#include "support/terrain_builders.h"

#include <terrain/server/recovery_status.h>

#include <sstream>

namespace terrain::testing {
namespace {

using server::Role;

/// Sends `head` (a request line and headers) and returns the whole response (the server closes).
std::string httpExchange(std::uint16_t port, const std::string& head) {
    asio::io_context io;
    asio::ip::tcp::socket socket(io);
    socket.connect({asio::ip::make_address("127.0.0.1"), port});
    asio::write(socket, asio::buffer(head));
    std::string response;
    asio::error_code ec;
    std::array<char, 4096> buf{};
    while (!ec) {
        const std::size_t n = socket.read_some(asio::buffer(buf), ec);
        response.append(buf.data(), n);
    }
    return response;
}

std::string get(std::uint16_t port, const std::string& path) {
    return httpExchange(port, "GET " + path + " HTTP/1.1\r\nHost: test\r\n\r\n");
}

int statusOf(const std::string& response) {
    return response.rfind("HTTP/1.1 ", 0) == 0 ? std::stoi(response.substr(9, 3)) : -1;
}

/// The value of the sample `series` (name and labels as exposed), or -1 when absent.
double sample(const std::string& exposition, const std::string& series) {
    std::istringstream lines(exposition);
    for (std::string line; std::getline(lines, line);)
        if (line.rfind(series + " ", 0) == 0)
            return std::stod(line.substr(series.size() + 1));
    return -1.0;
}

TEST(ServerMetrics, ProbesAnswerAndFiguresFollowRealTraffic) {
    server::ServerConfig config;
    config.deform_rate_per_second = 1e6;
    config.deform_burst = 1e6;
    server::TransportConfig transport;
    transport.metrics_port = 0;
    TestServer srv(smallMap(129), config, nullptr, 0, transport);
    const std::uint16_t port = srv.call([&] { return srv.server().metricsPort(); });
    ASSERT_NE(port, 0);
    EXPECT_EQ(statusOf(get(port, "/livez")), 200);
    EXPECT_EQ(statusOf(get(port, "/readyz")), 200);
    const std::string before = get(port, "/metrics");
    EXPECT_EQ(statusOf(before), 200);
    EXPECT_NE(before.find("Content-Type: text/plain; version=0.0.4"), std::string::npos);
    EXPECT_EQ(sample(before, "terrain_ops_accepted_total"), 0.0);

    asio::io_context io;
    TestClient deformer(io, srv.port(), token(1, Role::kDeformer));
    TestClient viewer(io, srv.port(), token(2, Role::kViewer));
    ASSERT_TRUE(runUntil(io, [&] { return deformer.replica.ready() && viewer.replica.ready(); }));
    for (int i = 0; i < 5; ++i)
        deformer.connection->requestDeform(
            OpRequest{OpKind::kCrater, 20.0 + 15 * i, 40, 3, 1, 0.3});
    deformer.connection->requestDeform(OpRequest{OpKind::kCrater, -50, 40, 3, 1, 0.3}); // off map
    ASSERT_TRUE(
        runUntil(io, [&] { return viewer.replica.seq() == 5 && deformer.answers.size() == 6; }));

    const std::string after = get(port, "/metrics");
    EXPECT_EQ(sample(after, "terrain_ops_accepted_total"), 5.0);
    // refusals by reason: the off-map crater's
    EXPECT_EQ(sample(after, "terrain_ops_refused_total{reason=\"REASON_OUTSIDE_MAP\"}"), 1.0);
    EXPECT_EQ(sample(before, "terrain_ops_refused_total{reason=\"REASON_OUTSIDE_MAP\"}"), -1.0);
    // the hub's timings: 5 applies, 5 broadcasts, 2 joins; bytes both ways
    EXPECT_EQ(sample(after, "terrain_op_apply_seconds_count"), 5.0);
    EXPECT_GT(sample(after, "terrain_op_apply_seconds_sum"), 0.0);
    EXPECT_EQ(sample(after, "terrain_broadcast_latency_seconds_count"), 5.0);
    EXPECT_GE(
        sample(after, "terrain_broadcast_latency_seconds_sum"),
        sample(after, "terrain_op_apply_seconds_sum"));
    EXPECT_EQ(sample(after, "terrain_join_seconds_count"), 2.0);
    EXPECT_GT(sample(after, "terrain_bytes_in_total"), 0.0);
    EXPECT_GT(sample(after, "terrain_bytes_out_total"), sample(after, "terrain_bytes_in_total"));
    EXPECT_EQ(sample(after, "terrain_broadcast_seq"), 5.0);
    EXPECT_EQ(sample(after, "terrain_sessions{role=\"deformer\",state=\"live\"}"), 1.0);
    EXPECT_EQ(sample(after, "terrain_sessions{role=\"viewer\",state=\"live\"}"), 1.0);
    EXPECT_GE(sample(after, "terrain_connections_accepted_total"), 2.0);
    EXPECT_GE(sample(after, "terrain_snapshot_joins_total"), 2.0);
    EXPECT_GT(sample(after, "terrain_bytes_out_total"), sample(before, "terrain_bytes_out_total"));
    EXPECT_GE(sample(after, "terrain_snapshot_build_seconds_count"), 1.0); // the join snapshot
    // no journal: nothing recovered, nothing a restart would replay (the series are there)
    EXPECT_EQ(sample(after, "terrain_recovery_seconds"), 0.0);
    EXPECT_EQ(sample(after, "terrain_recovery_replayed_records"), 0.0);
    EXPECT_EQ(sample(after, "terrain_journal_replay_pending_seconds"), 0.0);

    // what a scraper or a stray client may send
    EXPECT_EQ(statusOf(httpExchange(port, "POST /metrics HTTP/1.1\r\n\r\n")), 405);
    EXPECT_EQ(statusOf(get(port, "/nothing")), 404);
    EXPECT_EQ(statusOf(httpExchange(port, "HELLO\r\n\r\n")), 400);
    EXPECT_EQ(statusOf(httpExchange(port, "GET /" + std::string(9000, 'a') + "\r\n\r\n")), 400);

    // draining: not ready, still alive
    srv.call([&] {
        srv.server().shutdown([] {});
        return 0;
    });
    const std::string draining = get(port, "/readyz");
    EXPECT_EQ(statusOf(draining), 503);
    EXPECT_NE(draining.find("draining"), std::string::npos);
    EXPECT_EQ(statusOf(get(port, "/livez")), 200);
    EXPECT_EQ(sample(get(port, "/metrics"), "terrain_ready"), 0.0);
}

TEST(ServerMetrics, WhileTheJournalRecoversTheProbesSayAliveAndNotReady) {
    auto status = server::RecoveryStatus::start("127.0.0.1", 0);
    ASSERT_TRUE(status.ok()) << status.error().message;
    const std::uint16_t port = (*status)->port();
    ASSERT_NE(port, 0);
    EXPECT_EQ(statusOf(get(port, "/livez")), 200);
    const std::string ready = get(port, "/readyz");
    EXPECT_EQ(statusOf(ready), 503);
    EXPECT_NE(ready.find("recovering"), std::string::npos);
    EXPECT_EQ(statusOf(get(port, "/metrics")), 503);
    EXPECT_EQ(statusOf(get(port, "/nowhere")), 404);
    (*status)->stop();
    (*status)->stop(); // idempotent
    // the port is free for the Server's own responder
    asio::io_context io;
    asio::ip::tcp::acceptor again(io);
    again.open(asio::ip::tcp::v4());
    again.set_option(asio::ip::tcp::acceptor::reuse_address(true));
    asio::error_code ec;
    again.bind({asio::ip::make_address("127.0.0.1"), port}, ec);
    EXPECT_FALSE(ec) << ec.message();
}

} // namespace
} // namespace terrain::testing
