// terrain-bot's library against a real server on loopback: two bots (one rendering offscreen)
// blast craters concurrently and end holding the server's world; the script is deterministic;
// reports survive a round trip and bad ones are refused by name.

#include "support/image_checks.h"
#include "support/net_harness.h"

#include <terrain/bot/bot.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <thread>

namespace terrain {
namespace {

using testing::TestServer;

std::filesystem::path outputDir() {
    const auto dir = std::filesystem::path(TERRAIN_TEST_OUTPUT_DIR) / "bot";
    std::filesystem::create_directories(dir);
    return dir;
}

bot::BotConfig
botConfig(const std::string& name, std::uint64_t seed, std::uint16_t port, std::uint64_t player) {
    bot::BotConfig c;
    c.name = name;
    c.port = port;
    c.token = testing::token(player, server::Role::kDeformer);
    c.script.seed = seed;
    c.script.frames = 90;
    c.script.craters = 5;
    c.script.viewport_width = 320;
    c.script.viewport_height = 200;
    c.script.orbit_radius_metres = 60.0;
    c.script.altitude_metres = 35.0;
    c.settle_seconds = 0.5;
    return c;
}

TEST(Bot, TwoBotsBlastCratersAndEndHoldingTheServersWorld) {
    TestServer server(testing::smallMap(257, 9));
    bot::BotConfig a = botConfig("alpha", 3, server.port(), 1);
    a.render = true;
    a.png_dir = outputDir() / "alpha";
    std::filesystem::remove_all(a.png_dir);
    bot::BotConfig b = botConfig("bravo", 4, server.port(), 2);
    b.fps = 60.0; // a game's frame loop: 90 frames take 1.5 s
    // they meet before settling, so both end at the server's last seq
    const auto barrier = outputDir() / "barrier";
    std::filesystem::remove_all(barrier);
    a.barrier_dir = b.barrier_dir = barrier;
    a.peers = b.peers = 2;

    std::optional<Result<bot::BotReport>> ra;
    std::optional<Result<bot::BotReport>> rb;
    std::thread ta([&] { ra.emplace(bot::runBot(a)); });
    std::thread tb([&] { rb.emplace(bot::runBot(b)); });
    ta.join();
    tb.join();
    ASSERT_TRUE(ra->ok()) << ra->error().message;
    ASSERT_TRUE(rb->ok()) << rb->error().message;
    const bot::BotReport& alpha = ra->value();
    const bot::BotReport& bravo = rb->value();

    EXPECT_EQ(alpha.craters_requested, 5);
    EXPECT_EQ(bravo.craters_requested, 5);
    EXPECT_EQ(alpha.craters_accepted + alpha.craters_missed, 5);
    EXPECT_EQ(server.seq(), std::uint64_t(alpha.craters_accepted + bravo.craters_accepted));
    for (const bot::BotReport* r : {&alpha, &bravo}) {
        EXPECT_TRUE(r->synced) << r->name;
        EXPECT_EQ(r->error, "") << r->name;
        EXPECT_EQ(r->final_seq, server.seq()) << r->name;
        EXPECT_EQ(r->world_hash, server.worldHash()) << r->name;
        std::uint64_t server_hash = 0;
        const bool retained =
            server.call([&] { return server.authority().log().hashAt(r->final_seq, server_hash); });
        ASSERT_TRUE(retained) << r->name;
        EXPECT_EQ(r->world_hash, server_hash) << r->name;
        EXPECT_EQ(r->hash_mismatches, 0u) << r->name;
        EXPECT_EQ(r->ops_applied, r->final_seq) << r->name; // every op's hash was checked
        EXPECT_EQ(r->frames, 90);
        EXPECT_GT(r->triangles.median, 100.0);
        // per op: drawn no later than converged, both within the run
        EXPECT_TRUE(r->async_tessellation) << r->name;
        EXPECT_GE(r->crater_frames_to_converged.max, r->crater_frames_to_drawn.max) << r->name;
        EXPECT_LT(r->crater_frames_to_converged.max, 90.0) << r->name;
        EXPECT_GT(r->crater_error_bound_until_converged_px.max, 0.0) << r->name;
    }
    // only the renderer counts uploads and writes frames
    EXPECT_GT(alpha.upload_bytes, 0u);
    EXPECT_EQ(alpha.upload_bytes, alpha.vertex_bytes + alpha.index_bytes);
    EXPECT_GT(alpha.render_ms.median, 0.0);
    EXPECT_EQ(bravo.upload_bytes, 0u);
    EXPECT_GE(bravo.seconds, 89.0 / 60.0) << "--fps 60 kept no pace";
    EXPECT_NE(alpha.renderer.find("OpenGL"), std::string::npos) << alpha.renderer;
    ASSERT_EQ(alpha.pngs.size(), 2u);

    // before and after show the same view; the craters changed part of it
    const auto read = [](const std::string& path) {
        auto image = testing::readRgbPngForTest(path);
        EXPECT_TRUE(image.has_value()) << path;
        return image.value_or(io::RgbImage{});
    };
    const io::RgbImage before = read(alpha.pngs[0]);
    const io::RgbImage after = read(alpha.pngs[1]);
    ASSERT_EQ(before.width, 320);
    ASSERT_EQ(before.height, 200);
    ASSERT_EQ(after.width, 320);
    ASSERT_EQ(after.height, 200);
    const double changed = testing::countDiffering(before, after, 16).fraction();
    std::printf("before/after: %.2f %% of pixels changed\n", 100.0 * changed);
    EXPECT_GT(changed, 0.005);
    EXPECT_LT(changed, 0.5);
    EXPECT_GT(testing::distinctColours(before), 1000);
}

TEST(Bot, TheScriptIsAFunctionOfTheSeed) {
    const Terrain t = testing::smallMap(257, 9);
    bot::ScriptOptions o;
    o.seed = 17;
    o.frames = 200;
    o.craters = 7;
    const bot::BotScript s1(o, t.spec());
    const bot::BotScript s2(o, t.spec());
    int due = 0;
    for (int f = 0; f < o.frames; ++f) {
        const roam::Camera c1 = s1.camera(f, t);
        const roam::Camera c2 = s2.camera(f, t);
        EXPECT_EQ(c1.eye, c2.eye);
        EXPECT_GT(c1.eye.z, surfaceHeight(t, c1.eye.x, c1.eye.y)); // above the ground
        if (s1.craterDue(f)) {
            ++due;
            EXPECT_LE(f, o.frames * 4 / 5);
            EXPECT_EQ(s1.shot(f).radius, s2.shot(f).radius);
            EXPECT_GE(s1.shot(f).radius, o.crater_radius_min);
            EXPECT_LE(s1.shot(f).radius, o.crater_radius_max);
        }
    }
    EXPECT_EQ(due, 7);
    o.seed = 18;
    const bot::BotScript other(o, t.spec());
    EXPECT_NE(other.focusX(), s1.focusX());
}

TEST(Bot, ReportsRoundTripAndBadOnesAreRefusedByName) {
    bot::BotReport r;
    r.name = "x";
    r.frames = 3;
    r.final_seq = 42;
    r.world_hash = 0xfedcba9876543210ull;
    r.synced = true;
    r.tessellate_ms = bot::Spread::of({3.0, 1.0, 2.0});
    r.crater_frames_to_converged = bot::Spread::of({4.0, 9.0});
    r.pngs = {"a.png"};
    r.error = "the world did not settle";
    const auto path = outputDir() / "report.json";
    ASSERT_TRUE(bot::writeReport(path, r).ok());
    auto back = bot::readReport(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->world_hash, r.world_hash);
    EXPECT_EQ(back->final_seq, 42u);
    EXPECT_EQ(back->tessellate_ms.median, 2.0);
    EXPECT_EQ(back->tessellate_ms.max, 3.0);
    EXPECT_EQ(back->crater_frames_to_converged.max, 9.0);
    EXPECT_EQ(back->pngs, r.pngs);
    EXPECT_EQ(back->error, r.error);

    // a hash that is not 16 hex digits is refused by name
    std::string text = bot::toJson(r);
    text.replace(text.find("fedcba9876543210"), 16, "-1");
    std::ofstream(outputDir() / "bad_hash.json") << text;
    auto bad_hash = bot::readReport(outputDir() / "bad_hash.json");
    ASSERT_FALSE(bad_hash.ok());
    EXPECT_NE(bad_hash.error().message.find("world_hash must be 16 hex digits"), std::string::npos);
    r.error.clear();

    std::ofstream(outputDir() / "bad.json") << "{\"name\": \"x\", \"frames\": 1}";
    auto bad = bot::readReport(outputDir() / "bad.json");
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("seconds"), std::string::npos) << bad.error().message;
    EXPECT_FALSE(bot::readReport(outputDir() / "missing.json").ok());

    // the table's verdict
    bot::BotReport other = r;
    EXPECT_TRUE(bot::printTable({r, other}, stdout));
    other.world_hash ^= 1;
    EXPECT_FALSE(bot::printTable({r, other}, stdout));
    other = r;
    other.synced = false;
    EXPECT_FALSE(bot::printTable({r, other}, stdout));
    other = r;
    other.error = "a PNG could not be written";
    EXPECT_FALSE(bot::printTable({r, other}, stdout));
}

} // namespace
} // namespace terrain
