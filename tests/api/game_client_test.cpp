// The client a game links (terrain::game::Client over libterrain_client.so's C ABI; this test
// links nothing else of ours), against a live terrain-server process, used as a game uses it:
// join, fire craters, follow the world exactly, tessellate for a camera and read the tiles in
// metres. And each misuse answered at once, by name: bad options and parameters, a request
// before the world is loaded, a bad token, a dead server, a call after close().

#include "api/live_server.h"

#include <terrain/game/client.h>

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

namespace terrain::testing {
namespace {

using game::ClientError;

game::ClientOptions optionsFor(std::uint16_t port, std::string tok) {
    game::ClientOptions o;
    o.port = port;
    o.token = std::move(tok);
    o.give_up_seconds = 10.0;
    return o;
}

// a loopback port nothing listens on (bound, read, closed)
std::uint16_t nothingListens() {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t n = sizeof a;
    bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
    close(fd);
    return ntohs(a.sin_port);
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

// Each test with the network pumped by the game (pump()) and on the client's own thread.
class GameClientOn : public ::testing::TestWithParam<bool> {
  protected:
    static game::ClientOptions options(std::uint16_t port, std::string tok) {
        game::ClientOptions o = optionsFor(port, std::move(tok));
        o.network_thread = GetParam();
        return o;
    }
};
INSTANTIATE_TEST_SUITE_P(
    , GameClientOn, ::testing::Bool(), [](const ::testing::TestParamInfo<bool>& info) {
        return info.param ? "ItsOwnNetworkThread" : "TheGamesThread";
    });

TEST_P(GameClientOn, JoinsDeformsFollowsTheServerExactlyAndDrawsTilesInMetres) {
    LiveServer srv(257);
    ASSERT_NE(srv.port(), 0) << "the server did not start";
    game::Client client(options(srv.port(), srv.token(41, "deformer")));
    // nothing to do before connect()
    EXPECT_EQ(client.pump().error, ClientError::kNotConnected);
    EXPECT_EQ(client.requestCrater(50, 50, 3, 1).error, ClientError::kNotConnected);
    ASSERT_TRUE(client.connect());
    EXPECT_EQ(client.connect().error, ClientError::kBadParameter) << "twice";
    const game::ClientResult synced = client.waitSynced(20.0);
    ASSERT_TRUE(synced) << synced.message;
    game::WorldState w = client.world();
    EXPECT_TRUE(w.loaded && w.live && w.synced && !w.closed);
    EXPECT_EQ(w.world_hash, srv.world().hash);
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
        // counter-clockwise seen from above (z up), as EMBEDDING.md tells an engine
        for (std::uint32_t i = 0; i + 2 < b.index_count; i += 3) {
            const game::Vertex& p0 = b.vertices[b.indices[i]];
            const game::Vertex& p1 = b.vertices[b.indices[i + 1]];
            const game::Vertex& p2 = b.vertices[b.indices[i + 2]];
            const double area = (double(p1.x) - p0.x) * (double(p2.y) - p0.y) -
                                (double(p2.x) - p0.x) * (double(p1.y) - p0.y);
            ASSERT_GT(area, 0.0) << "tile " << t << " triangle " << i / 3;
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
        return answers.size() == ids.size() && client.world().seq == ids.size() &&
               client.world().synced;
    }));
    for (std::size_t i = 0; i < answers.size(); ++i) {
        EXPECT_EQ(answers[i].request_id, ids[i]);
        EXPECT_TRUE(answers[i].accepted) << answers[i].reason;
    }
    w = client.world();
    EXPECT_EQ(w.seq, 12u);
    const LiveServer::World server = srv.world();
    ASSERT_TRUE(server.ok);
    EXPECT_EQ(w.seq, server.seq);
    EXPECT_EQ(w.world_hash, server.hash) << "the replica is the server's world, bit for bit";
    EXPECT_EQ(w.ops_applied, 12u);
    EXPECT_EQ(w.hash_mismatches, 0u);
    // the craters reached the tiles: some changed since they were uploaded (lag 1: the tiles
    // are of the frame before, posted after every op was applied)
    ASSERT_TRUE(frames(client, camera, 2000, [&] { return client.meshLag() <= 1; }));
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
    EXPECT_NE(client.lastError().find("closed by the game"), std::string::npos)
        << client.lastError();
}

// A game that draws no frame for a while (a loading screen, a stop in a debugger) while others
// fire: the link holds, nothing is resynced, and the first pump after finds the server's world.
TEST_P(GameClientOn, AGameThatStopsPumpingFindsTheServersWorldAfterwards) {
    LiveServer srv(257);
    game::ClientOptions quiet = options(srv.port(), srv.token(43, "viewer"));
    quiet.ops_per_frame = 0; // every op that arrived, in the first pump
    game::Client watcher(quiet);
    game::Client shooter(optionsFor(srv.port(), srv.token(44, "deformer")));
    ASSERT_TRUE(watcher.connect());
    ASSERT_TRUE(shooter.connect());
    ASSERT_TRUE(watcher.waitSynced(20.0));
    ASSERT_TRUE(shooter.waitSynced(20.0));
    for (int i = 0; i < 40; ++i)
        ASSERT_TRUE(shooter.requestCrater(20.0 + 5 * i, 30.0 + 4 * i, 3.0, 1.0));
    ASSERT_TRUE(frames(shooter, lookingAcross(20, 20, 40), 4000, [&] {
        return shooter.world().seq == 40 && shooter.world().synced;
    }));
    std::this_thread::sleep_for(std::chrono::milliseconds(300)); // the watcher's stall, longer
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (watcher.world().seq < 40 && std::chrono::steady_clock::now() < deadline) {
        ASSERT_TRUE(watcher.pump());
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const game::WorldState w = watcher.world();
    EXPECT_EQ(w.seq, 40u);
    EXPECT_EQ(w.world_hash, shooter.world().world_hash);
    EXPECT_EQ(w.world_hash, srv.world().hash);
    EXPECT_EQ(w.snapshots, 1u) << "the join only: nothing was resynced";
    EXPECT_EQ(w.hash_mismatches, 0u);
    EXPECT_TRUE(w.live);
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

TEST_P(GameClientOn, ABadTokenIsRefusedByTheServerAndClosesTheClient) {
    LiveServer srv(129);
    game::Client client(options(srv.port(), "not-a-token"));
    ASSERT_TRUE(client.connect());
    const game::ClientResult r = client.waitSynced(10.0);
    EXPECT_EQ(r.error, ClientError::kRefusedByServer) << r.message;
    EXPECT_NE(r.message.find("BAD_TOKEN"), std::string::npos) << r.message;
    EXPECT_TRUE(client.world().closed);
    EXPECT_EQ(client.pump().error, ClientError::kRefusedByServer);
}

TEST_P(GameClientOn, ADeadServerTimesOutInsteadOfRetryingForever) {
    game::ClientOptions o = options(nothingListens(), "t");
    o.give_up_seconds = 0.5;
    game::Client client(o);
    ASSERT_TRUE(client.connect());
    EXPECT_EQ(client.requestCrater(50, 50, 3, 1).error, ClientError::kNotSynced);
    const game::ClientResult r = client.waitSynced(10.0);
    EXPECT_EQ(r.error, ClientError::kTimedOut) << r.message;
    EXPECT_NE(r.message.find("CONNECT_TIMEOUT"), std::string::npos) << r.message;
    EXPECT_TRUE(client.world().closed);
}

TEST_P(GameClientOn, AViewerTokenMayWatchButItsCratersAreRefusedByTheServer) {
    LiveServer srv(129);
    game::Client client(options(srv.port(), srv.token(42, "viewer")));
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

// runs a command, its stdout and exit status
struct Ran {
    std::string out;
    int status = -1;
};
Ran run(const std::string& command) {
    Ran r;
    if (FILE* p = popen((command + " 2>&1").c_str(), "r")) {
        char buffer[512];
        while (std::fgets(buffer, sizeof buffer, p) != nullptr)
            r.out += buffer;
        const int status = pclose(p);
        r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    return r;
}

// examples/c/crater.c, built as C99 with every warning an error: joins, fires a crater, and
// ends holding the server's world
TEST(GameClientC, TheC99ExampleJoinsFiresACraterAndHoldsTheServersWorld) {
    LiveServer srv(257);
    ASSERT_NE(srv.port(), 0);
    const Ran r =
        run(std::string(TERRAIN_C_EXAMPLE_BIN) + " 127.0.0.1 " + std::to_string(srv.port()) + " " +
            srv.token(51, "deformer"));
    ASSERT_EQ(r.status, 0) << r.out;
    const LiveServer::World w = srv.world();
    ASSERT_TRUE(w.ok);
    char expected[64];
    std::snprintf(
        expected, sizeof expected, "seq %llu hash %016llx", static_cast<unsigned long long>(w.seq),
        static_cast<unsigned long long>(w.hash));
    EXPECT_EQ(w.seq, 1u);
    EXPECT_NE(r.out.find(expected), std::string::npos)
        << r.out << " (the server: " << expected << ")";
}

#if !defined(                                                                                      \
    TERRAIN_SANITIZED) // python3 cannot load a sanitized library (its runtime must come first)
// tests/api/test_c_abi.py: the C ABI through Python's ctypes, as another language binds it
TEST(GameClientC, PythonThroughCtypesJoinsDeformsAndHoldsTheServersWorld) {
    if (run("python3 -c 'import ctypes'").status != 0)
        GTEST_SKIP() << "no python3 with ctypes here (.ci/setup installs python3)";
    LiveServer srv(257);
    ASSERT_NE(srv.port(), 0);
    const Ran r = run(
        std::string("python3 ") + TERRAIN_PYTHON_TEST + " " + TERRAIN_CLIENT_LIBRARY + " " +
        std::to_string(srv.port()) + " " + srv.token(52, "deformer") + " " + TERRAIN_SERVER_BIN);
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("python ctypes: seq 20 hash "), std::string::npos) << r.out;
}

// tests/api/test_replica_abi.py: the replica alone (terrain_replica.h) follows the server's
// journal from its snapshot files, the procedural genesis and a genesis delta, every op's hash
// checked; a diverged replica is repaired from the server's tile records
TEST(ReplicaC, PythonFollowsTheServersJournalThroughTheReplicaAlone) {
    if (run("python3 -c 'import ctypes'").status != 0)
        GTEST_SKIP() << "no python3 with ctypes here (.ci/setup installs python3)";
    LiveServer srv(
        257, {"--durability", "write", "--snapshot-every", "30", "--snapshot-replay-seconds", "0"});
    ASSERT_NE(srv.port(), 0);
    const Ran r =
        run(std::string("python3 ") + TERRAIN_PYTHON_REPLICA_TEST + " " + TERRAIN_CLIENT_LIBRARY +
            " " + std::to_string(srv.port()) + " " + srv.token(53, "deformer") + " " +
            srv.dataDir() + " 1 257");
    EXPECT_EQ(r.status, 0) << r.out;
    // one replica follows all 130 ops; the others follow from later snapshots
    unsigned followed = 0;
    const auto at = r.out.find("python replica: ");
    ASSERT_NE(at, std::string::npos) << r.out;
    ASSERT_EQ(std::sscanf(r.out.c_str() + at, "python replica: %u ops followed", &followed), 1);
    EXPECT_GE(followed, 260u) << r.out;
}
#endif

} // namespace
} // namespace terrain::testing
