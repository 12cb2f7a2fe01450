// The client a game links (terrain::game::Client), against a live server on loopback, used as a
// game uses it: join, fire craters, follow the world exactly, tessellate for a camera and read
// the tiles in metres. And each misuse answered at once, by name: bad options and parameters, a
// request before the world is loaded, a bad token, a dead server, a call after close().

#include "support/net_harness.h"
#include "support/terrain_builders.h"

#include <terrain/game/client.h>

#include <cmath>
#include <string>

namespace terrain::testing {
namespace {

using game::ClientError;
using server::Role;

server::ServerConfig fastServer() {
    server::ServerConfig c;
    c.deform_rate_per_second = 1e6;
    c.deform_burst = 1e6;
    return c;
}

game::ClientOptions optionsFor(std::uint16_t port, std::string tok) {
    game::ClientOptions o;
    o.port = port;
    o.token = std::move(tok);
    o.give_up_seconds = 10.0;
    return o;
}

std::uint16_t nothingListens() {
    asio::io_context io;
    asio::ip::tcp::acceptor acceptor(io, {asio::ip::make_address("127.0.0.1"), 0});
    const std::uint16_t port = acceptor.local_endpoint().port();
    acceptor.close();
    return port;
}

game::Camera lookingAcross(double x, double y, double z) {
    game::Camera c;
    c.eye[0] = x;
    c.eye[1] = y;
    c.eye[2] = z;
    c.forward[0] = 1.0;
    c.forward[1] = 0.6;
    c.forward[2] = -0.4;
    c.viewport_width = 640;
    c.viewport_height = 360;
    return c;
}

// pumps and tessellates frames until `done`, at most `frames`
template <typename F> bool frames(game::Client& client, const game::Camera& camera, int n, F done) {
    for (int f = 0; f < n; ++f) {
        if (!client.pump())
            return false;
        if (!client.tessellate(camera))
            return false;
        if (done())
            return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return done();
}

TEST(GameClient, JoinsDeformsFollowsTheServerExactlyAndDrawsTilesInMetres) {
    TestServer srv(smallMap(257), fastServer());
    game::Client client(optionsFor(srv.port(), token(41, Role::kDeformer)));
    // nothing to do before connect()
    EXPECT_EQ(client.pump().error, ClientError::kNotConnected);
    EXPECT_EQ(client.requestCrater(50, 50, 3, 1).error, ClientError::kNotConnected);
    ASSERT_TRUE(client.connect());
    EXPECT_EQ(client.connect().error, ClientError::kBadParameter) << "twice";
    const game::ClientResult synced = client.waitSynced(20.0);
    ASSERT_TRUE(synced) << synced.message;
    game::WorldState w = client.world();
    EXPECT_TRUE(w.loaded && w.live && w.synced && !w.closed);
    EXPECT_EQ(w.world_hash, srv.worldHash());
    EXPECT_DOUBLE_EQ(w.extent_x, 256.0);

    // bad parameters: refused at once, the rule named, nothing sent
    const game::ClientResult nan = client.requestCrater(std::nan(""), 50, 3, 1);
    EXPECT_EQ(nan.error, ClientError::kBadParameter);
    EXPECT_FALSE(nan.message.empty());
    EXPECT_EQ(client.requestCrater(5000, 50, 3, 1).error, ClientError::kBadParameter);
    EXPECT_EQ(client.requestCrater(50, 50, -3, 1).error, ClientError::kBadParameter);
    EXPECT_EQ(
        client.requestOp(static_cast<game::OpKind>(9), 50, 50, 3, 1).error,
        ClientError::kBadParameter);
    game::TileBuffers none;
    EXPECT_EQ(client.tile(0, none).error, ClientError::kBadParameter) << "no tiles before a camera";

    // a camera over the map: the tiles come in metres, inside the map, their indices in range
    const game::Camera camera = lookingAcross(30, 40, 60);
    bool changed = false;
    ASSERT_TRUE(client.tessellate(camera, &changed));
    EXPECT_TRUE(changed) << "the first frame shows the world";
    ASSERT_EQ(client.tileCount(), 16);
    std::int64_t triangles = 0;
    for (std::int32_t t = 0; t < client.tileCount(); ++t) {
        game::TileBuffers b;
        ASSERT_TRUE(client.tile(t, b));
        EXPECT_TRUE(client.tileChanged(t));
        EXPECT_TRUE(b.indices_rewritten && b.vertices_all_changed);
        ASSERT_EQ(b.index_count % 3, 0u);
        for (std::uint32_t i = 0; i < b.index_count; ++i)
            ASSERT_LT(b.indices[i], b.vertex_count);
        for (std::uint32_t v = 0; v < b.vertex_count; ++v) {
            ASSERT_GE(b.vertices[v].x, 0.0f);
            ASSERT_LE(b.vertices[v].x, 256.0f);
            ASSERT_GE(b.vertices[v].y, 0.0f);
            ASSERT_LE(b.vertices[v].y, 256.0f);
        }
        if (b.visible)
            triangles += b.index_count / 3;
        client.markUploaded(t);
        EXPECT_FALSE(client.tileChanged(t));
    }
    EXPECT_GT(triangles, 1000);
    // a base vertex sits on the replica's ground, in metres: tile 0's first is the map's corner
    {
        game::TileBuffers b;
        ASSERT_TRUE(client.tile(0, b));
        double h = 0.0;
        ASSERT_TRUE(client.heightAt(b.vertices[0].x, b.vertices[0].y, h));
        EXPECT_NEAR(b.vertices[0].z, h, 1e-3);
    }
    EXPECT_EQ(client.tessellate(game::Camera{}, nullptr).error, ClientError::kNone);
    game::Camera bad = camera;
    bad.eye[2] = std::nan("");
    EXPECT_EQ(client.tessellate(bad).error, ClientError::kBadParameter);

    // craters where the camera looks: every one answered, the world the server's at every frame
    std::vector<std::uint32_t> ids;
    for (int i = 0; i < 12; ++i) {
        const game::ClientResult r = client.requestCrater(60.0 + 6 * i, 60.0 + 3 * i, 3.0, 1.5);
        ASSERT_TRUE(r) << r.message;
        EXPECT_NE(r.request_id, 0u);
        ids.push_back(r.request_id);
    }
    std::vector<game::OpAnswer> answers;
    ASSERT_TRUE(frames(client, camera, 2000, [&] {
        for (game::OpAnswer& a : client.takeAnswers())
            answers.push_back(a);
        return answers.size() == ids.size() && client.world().seq == srv.seq() &&
               client.world().synced;
    }));
    for (std::size_t i = 0; i < answers.size(); ++i) {
        EXPECT_EQ(answers[i].request_id, ids[i]);
        EXPECT_TRUE(answers[i].accepted) << answers[i].reason;
    }
    w = client.world();
    EXPECT_EQ(w.seq, 12u);
    EXPECT_EQ(w.world_hash, srv.worldHash());
    EXPECT_EQ(w.ops_applied, 12u);
    EXPECT_EQ(w.hash_mismatches, 0u);
    // the craters reached the tiles: some changed since they were uploaded
    ASSERT_TRUE(frames(client, camera, 500, [&] { return client.meshLag() == 0; }));
    int changed_tiles = 0;
    for (std::int32_t t = 0; t < client.tileCount(); ++t)
        changed_tiles += client.tileChanged(t) ? 1 : 0;
    EXPECT_GT(changed_tiles, 0);
    EXPECT_GT(client.meshErrorPixels(), 0.0);

    // use after close: every call says so
    client.close();
    EXPECT_EQ(client.pump().error, ClientError::kClosed);
    EXPECT_EQ(client.requestCrater(50, 50, 3, 1).error, ClientError::kClosed);
    EXPECT_EQ(client.tessellate(camera).error, ClientError::kClosed);
    EXPECT_EQ(client.waitSynced(1.0).error, ClientError::kClosed);
    EXPECT_EQ(client.connect().error, ClientError::kClosed);
    EXPECT_TRUE(client.world().closed);
    EXPECT_EQ(client.lastError(), "closed by the game");
}

TEST(GameClient, BadOptionsAreRefusedAtConnectByName) {
    auto refused = [](game::ClientOptions o) {
        game::Client client(std::move(o));
        const game::ClientResult r = client.connect();
        EXPECT_EQ(r.error, ClientError::kBadParameter);
        return r.message;
    };
    game::ClientOptions o = optionsFor(7777, "t");
    o.host = "";
    EXPECT_NE(refused(o).find("host"), std::string::npos);
    o = optionsFor(0, "t");
    EXPECT_NE(refused(o).find("port"), std::string::npos);
    o = optionsFor(7777, "");
    EXPECT_NE(refused(o).find("token"), std::string::npos);
    o = optionsFor(7777, "t");
    o.tau_pixels = 0.0;
    EXPECT_NE(refused(o).find("tau_pixels"), std::string::npos);
    o = optionsFor(7777, "t");
    o.give_up_seconds = std::nan("");
    EXPECT_NE(refused(o).find("timeouts"), std::string::npos);
}

TEST(GameClient, ABadTokenIsRefusedByTheServerAndClosesTheClient) {
    TestServer srv(smallMap(129), fastServer());
    game::Client client(optionsFor(srv.port(), "not-a-token"));
    ASSERT_TRUE(client.connect());
    const game::ClientResult r = client.waitSynced(10.0);
    EXPECT_EQ(r.error, ClientError::kRefusedByServer) << r.message;
    EXPECT_NE(r.message.find("BAD_TOKEN"), std::string::npos) << r.message;
    EXPECT_TRUE(client.world().closed);
    EXPECT_EQ(client.pump().error, ClientError::kRefusedByServer);
}

TEST(GameClient, ADeadServerTimesOutInsteadOfRetryingForever) {
    game::ClientOptions o = optionsFor(nothingListens(), "t");
    o.give_up_seconds = 0.5;
    game::Client client(o);
    ASSERT_TRUE(client.connect());
    EXPECT_EQ(client.requestCrater(50, 50, 3, 1).error, ClientError::kNotSynced);
    const game::ClientResult r = client.waitSynced(10.0);
    EXPECT_EQ(r.error, ClientError::kTimedOut) << r.message;
    EXPECT_NE(r.message.find("CONNECT_TIMEOUT"), std::string::npos) << r.message;
    EXPECT_TRUE(client.world().closed);
}

TEST(GameClient, AViewerTokenMayWatchButItsCratersAreRefusedByTheServer) {
    TestServer srv(smallMap(129), fastServer());
    game::Client client(optionsFor(srv.port(), token(42, Role::kViewer)));
    ASSERT_TRUE(client.connect());
    ASSERT_TRUE(client.waitSynced(20.0));
    const game::ClientResult r = client.requestCrater(50, 50, 3, 1);
    ASSERT_TRUE(r) << "sent: the server decides";
    std::vector<game::OpAnswer> answers;
    ASSERT_TRUE(frames(client, lookingAcross(20, 20, 40), 2000, [&] {
        answers = client.takeAnswers();
        return !answers.empty();
    }));
    EXPECT_FALSE(answers[0].accepted);
    EXPECT_NE(answers[0].reason.find("NOT_PERMITTED"), std::string::npos) << answers[0].reason;
    EXPECT_TRUE(client.world().live) << "a refusal, not a disconnect";
}

} // namespace
} // namespace terrain::testing
