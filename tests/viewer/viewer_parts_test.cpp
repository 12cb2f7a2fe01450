// The viewer's parts that need no window: its option rules and the in-process server it joins
// over loopback TCP.

#include "support/net_harness.h"

#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/procedural_map.h>
#include <terrain/viewer/in_process_server.h>
#include <terrain/viewer/viewer_options.h>

#include <CLI/CLI.hpp>
#include <gtest/gtest.h>

#include <asio.hpp>
#include <chrono>

namespace terrain::viewer {
namespace {

/// Parses `args` like the program does; the error text of either stage, or "" when accepted.
std::string parse(const std::string& args, ViewerOptions& o) {
    CLI::App app;
    addViewerOptions(app, o);
    try {
        app.parse(args, false);
    } catch (const CLI::ParseError& e) {
        return e.what();
    }
    Status s = finishViewerOptions(o);
    return s ? "" : s.error().message;
}

std::string parse(const std::string& args) {
    ViewerOptions o;
    return parse(args, o);
}

TEST(ViewerOptions, DefaultsRunInProcess) {
    ViewerOptions o;
    EXPECT_EQ(parse("", o), "");
    EXPECT_TRUE(o.inProcess());
    EXPECT_EQ(o.host, "127.0.0.1");
    EXPECT_EQ(o.width, 1280);
    EXPECT_EQ(o.height, 720);
    EXPECT_EQ(o.tau_pixels, 2.0);
}

TEST(ViewerOptions, ConnectNeedsHostPortAndToken) {
    ViewerOptions o;
    EXPECT_EQ(parse("--connect example.org:7777 --token abc", o), "");
    EXPECT_EQ(o.host, "example.org");
    EXPECT_EQ(o.port, 7777);
    EXPECT_FALSE(o.inProcess());
    ViewerOptions v6;
    EXPECT_EQ(parse("--connect [::1]:9000 --token abc", v6), "");
    EXPECT_EQ(v6.host, "::1");
    EXPECT_EQ(parse("--connect example.org --token abc"), "--connect must be host:port");
    EXPECT_NE(
        parse("--connect example.org:0 --token abc").find("port in 1..65535"), std::string::npos);
    EXPECT_NE(
        parse("--connect example.org:7x --token abc").find("port in 1..65535"), std::string::npos);
    EXPECT_NE(
        parse("--connect example.org:7777").find("--connect needs --token"), std::string::npos);
    // the map options belong to the in-process server
    EXPECT_NE(parse("--connect example.org:7777 --token abc --size 257"), "");
}

TEST(ViewerOptions, RulesAreNamed) {
    EXPECT_EQ(parse("--tau 0"), "--tau must be > 0 (pixels)");
    EXPECT_EQ(parse("--tau -1"), "--tau must be > 0 (pixels)");
    EXPECT_EQ(parse("--max-triangles 10"), "--max-triangles must be >= 1000");
    EXPECT_EQ(
        parse("--geomorph 1"), "--geomorph must be within [0, 1) (a share of tau; 0 turns it off)");
    EXPECT_EQ(parse("--width 0"), "--width and --height must be within 1..16384");
    EXPECT_EQ(parse("--size 20"), "--size must be within 65..8193 vertices");
    EXPECT_EQ(parse("--frames -1"), "--frames must be >= 0");
    EXPECT_EQ(parse("--auto-crater -5"), "--auto-crater must be >= 0");
    EXPECT_EQ(parse("--crater-radius 0"), "--crater-radius must be > 0 (metres)");
    EXPECT_EQ(parse("--join-timeout 0"), "--join-timeout must be > 0 (seconds)");
    EXPECT_EQ(parse("--size 257 --frames 300 --fly --auto-crater 100 --tau 3"), "");
}

using terrain::testing::runUntil;

TEST(InProcessServer, ServesItsMapToADeformer) {
    ProceduralMapOptions map;
    map.width = 129;
    map.height = 129;
    Result<Terrain> terrain = makeProceduralMap(map);
    ASSERT_TRUE(terrain.ok());
    const std::uint64_t genesis = terrain->worldHash();
    Result<std::unique_ptr<InProcessServer>> server = InProcessServer::start(std::move(*terrain));
    ASSERT_TRUE(server.ok()) << server.error().message;
    InProcessServer& s = **server;
    EXPECT_GT(s.port(), 0);
    EXPECT_EQ(s.state().seq, 0u);
    EXPECT_EQ(s.state().world_hash, genesis);

    client::Replica replica; // outlives the connection's handlers, which io holds
    asio::io_context io;
    client::ConnectionConfig config;
    config.port = s.port();
    config.token = s.deformerToken();
    auto connection = std::make_shared<client::Connection>(io, config, replica);
    std::vector<client::DeformAnswer> answers;
    connection->on_deform_reply = [&](const client::DeformAnswer& a) { answers.push_back(a); };
    connection->start();
    ASSERT_TRUE(runUntil(io, [&] { return connection->synced(); }));
    EXPECT_EQ(replica.worldHash(), genesis);

    OpRequest crater;
    crater.kind = OpKind::kCrater;
    crater.x = 64.0;
    crater.y = 64.0;
    crater.radius = 8.0;
    crater.height = 3.0;
    crater.strength = 0.3;
    connection->requestDeform(crater);
    ASSERT_TRUE(runUntil(io, [&] { return !answers.empty() && replica.seq() == 1; }));
    EXPECT_TRUE(answers[0].accepted) << answers[0].reason;
    EXPECT_TRUE(connection->synced());
    const InProcessServer::State st = s.state();
    EXPECT_EQ(st.seq, 1u);
    EXPECT_EQ(st.ops_accepted, 1u);
    EXPECT_EQ(st.world_hash, replica.worldHash());
    EXPECT_NE(st.world_hash, genesis);
    connection->stop();
}

} // namespace
} // namespace terrain::viewer
