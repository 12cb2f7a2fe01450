// The game client in a battle, through the library a game links: the measured client is
// terrain::game::Client over libterrain_client.so (this program links nothing else of the
// client), joined to a terrain-server process, drawing 60 frames a second from a flight camera
// while another client of the library fires the battle's shots at the server: one a frame and a
// burst of --burst every --burst-every frames, as client_battle_bench delivers them. The shots
// are the battle generator's (terrain_core, linked only to aim them: an authority applies each
// before aiming the next, and its world hash must be the server's and the client's at the end).
//
// Per frame, timed on the frame thread: pump() (the network and the frame's share of the ops, or
// with --network-thread their replay), tessellate() (the camera in, the newest tiles out), and
// the upload: every changed tile's dirty index pages and vertex runs copied into the "engine's"
// arrays, then markUploaded(). The join is timed too: frames pumped until synced (the longest
// pump among them), and the first tessellate(), which waits for the whole world's first mesh.
// Exit status: 0; 1 when a hash differs or the client falls out; 2 on a bad option.

#include "api/live_server.h"
#include "support/bench_facts.h"

#include <terrain/battle.h>
#include <terrain/deform_op.h>
#include <terrain/game/client.h>
#include <terrain/procedural_map.h>
#include <terrain/terrain.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace terrain;
using Json = nlohmann::ordered_json;
using bench::Clock;

struct Settings {
    int shots = 2000;
    int burst = 20;
    int burst_every = 100;
    std::string flight = "hover";
    bool network_thread = false;
    int ops_per_frame = game::ClientOptions{}.ops_per_frame;
    double fps = 60.0;
    double tau = 1.0;
    int width = 1280;
    int height = 720;
    std::string out;
};

Json summaryJson(const bench::Summary& s) {
    return Json{{"n", s.n}, {"p50", s.p50}, {"p99", s.p99}, {"max", s.max}, {"mean", s.mean}};
}

// client_battle_bench's flights: "hover" 60 m above the zone, 80 m out, circling it (a turn in
// 30 s) and looking in; "cross" 10 m above the ground at 20 m/s, 150 m before the zone to 150 m
// past it and back. Heights from the client's own replica (heightAt: exact).
game::Camera flightCamera(const Settings& s, int f, game::Client& client, const BattleOptions& o) {
    constexpr double kPi = 3.14159265358979323846;
    game::Camera c;
    c.viewport_width = s.width;
    c.viewport_height = s.height;
    c.near_plane = 0.5;
    double zone_z = 0.0;
    client.heightAt(o.zone_x, o.zone_y, zone_z);
    if (s.flight == "hover") {
        const double a = 0.2 * kPi / 180.0 * f;
        c.eye[0] = o.zone_x + 80.0 * std::cos(a);
        c.eye[1] = o.zone_y + 80.0 * std::sin(a);
        c.eye[2] = zone_z + 60.0;
        c.forward[0] = o.zone_x - c.eye[0];
        c.forward[1] = o.zone_y - c.eye[1];
        c.forward[2] = zone_z - c.eye[2];
        return c;
    }
    const double leg = 300.0;
    const double d = std::fmod(f * 20.0 / 60.0, 2.0 * leg);
    const double along = d < leg ? d - leg / 2 : leg / 2 - (d - leg);
    const double dir = d < leg ? 1.0 : -1.0;
    c.eye[0] = o.zone_x + along;
    c.eye[1] = o.zone_y + 5.0;
    double ground = 0.0;
    client.heightAt(c.eye[0], c.eye[1], ground);
    c.eye[2] = ground + 10.0;
    c.forward[0] = dir;
    c.forward[1] = 0.0;
    c.forward[2] = -0.25;
    return c;
}

// The battle's ops, aimed and applied by an authority: the requests in metres (exact: quanta
// are 1/1024 m and strength 1/65536) and the world hash after the last.
struct Battle {
    std::vector<OpRequest> requests;
    std::uint64_t final_hash = 0;
    BattleOptions options;
};

Battle aimTheBattle(int shots) {
    Battle b;
    Terrain authority = std::move(*makeProceduralMap(ProceduralMapOptions{})); // the server's
    BattleGenerator generator(b.options);
    const WorldSpec& spec = authority.spec();
    const double u = spec.units_per_metre;
    while (static_cast<int>(b.requests.size()) < shots) {
        const BattleShot shot = generator.next(authority);
        if (!shot.crater)
            continue;
        const Result<DeformOp> op = quantizeOp(*shot.crater, spec);
        if (!op || !authority.apply(*op))
            continue;
        b.requests.push_back(
            {OpKind::kCrater, static_cast<double>(op->center_x) / u,
             static_cast<double>(op->center_y) / u, op->radius / u, op->height / u,
             op->strength / 65536.0});
    }
    b.final_hash = authority.worldHash();
    return b;
}

// The engine's copy of one tile's buffers, kept as a game keeps its GPU buffers.
struct EngineTile {
    std::vector<game::Vertex> vertices;
    std::vector<std::uint32_t> indices;
};

// Copies what changed in tile t (dirty index pages, vertex runs) into `e`; the bytes copied.
std::size_t upload(const game::TileBuffers& b, EngineTile& e) {
    std::size_t bytes = 0;
    e.vertices.resize(b.vertex_count);
    e.indices.resize(b.index_count);
    if (b.vertices_all_changed) {
        std::memcpy(e.vertices.data(), b.vertices, b.vertex_count * sizeof(game::Vertex));
        bytes += b.vertex_count * sizeof(game::Vertex);
    } else {
        for (std::uint32_t r = 0; r < b.vertex_run_count; ++r) {
            const game::VertexRun run = b.vertex_runs[r];
            std::memcpy(
                e.vertices.data() + run.begin, b.vertices + run.begin,
                (run.end - run.begin) * sizeof(game::Vertex));
            bytes += (run.end - run.begin) * sizeof(game::Vertex);
        }
    }
    const std::uint32_t page = game::Client::indicesPerPage();
    if (b.indices_rewritten) {
        std::memcpy(e.indices.data(), b.indices, b.index_count * sizeof(std::uint32_t));
        bytes += b.index_count * sizeof(std::uint32_t);
    } else {
        for (std::uint32_t p = 0; p < b.dirty_page_count; ++p) {
            const std::uint32_t begin = b.dirty_pages[p] * page;
            const std::uint32_t end = std::min(begin + page, b.index_count);
            if (begin >= end)
                continue;
            std::memcpy(
                e.indices.data() + begin, b.indices + begin, (end - begin) * sizeof(std::uint32_t));
            bytes += (end - begin) * sizeof(std::uint32_t);
        }
    }
    return bytes;
}

int run(const Settings& s) {
    std::fprintf(stderr, "aiming %d shots...\n", s.shots);
    const Battle battle = aimTheBattle(s.shots);
    testing::LiveServer srv(1025, {"--no-journal"});
    if (srv.port() == 0) {
        std::fprintf(stderr, "the server did not start\n");
        return 1;
    }

    game::ClientOptions o;
    o.port = srv.port();
    o.token = srv.token(71, "viewer");
    o.tau_pixels = s.tau;
    o.ops_per_frame = s.ops_per_frame;
    o.network_thread = s.network_thread;
    game::Client client(o);
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / s.fps));

    // the join, a frame at a time as a game's loading screen pumps it
    const auto join_start = Clock::now();
    if (!client.connect())
        return 1;
    std::vector<double> join_pumps;
    while (!client.world().synced) {
        const auto t = Clock::now();
        if (const game::ClientResult r = client.pump(); !r) {
            std::fprintf(stderr, "join: %s\n", r.message.c_str());
            return 1;
        }
        join_pumps.push_back(bench::msSince(t));
        if (bench::msSince(join_start) > 60000.0) {
            std::fprintf(stderr, "join: not synced after 60 s\n");
            return 1;
        }
        std::this_thread::sleep_until(t + period);
    }
    const double join_ms = bench::msSince(join_start);
    const auto first = Clock::now();
    if (!client.tessellate(flightCamera(s, 0, client, battle.options)))
        return 1;
    const double first_tessellate_ms = bench::msSince(first);

    // the shooter: its own client of the library, on its own thread, firing on the frame clock
    std::atomic<bool> shooter_ready{false}, shooter_failed{false};
    std::atomic<int> fired{0};
    Clock::time_point battle_start{};
    std::atomic<bool> go{false};
    std::thread shooter([&] {
        game::ClientOptions so;
        so.port = srv.port();
        so.token = srv.token(72, "deformer");
        game::Client gun(so);
        if (!gun.connect() || !gun.waitSynced(60.0)) {
            shooter_failed = true;
            shooter_ready = true;
            return;
        }
        shooter_ready = true;
        while (!go)
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        int sent = 0;
        for (int f = 0; sent < s.shots; ++f) {
            const int due = f > 0 && f % s.burst_every == 0 ? s.burst : 1;
            for (int k = 0; k < due && sent < s.shots; ++k, ++sent) {
                const OpRequest& r = battle.requests[static_cast<std::size_t>(sent)];
                if (!gun.requestCrater(r.x, r.y, r.radius, r.height, r.strength)) {
                    shooter_failed = true;
                    return;
                }
            }
            fired = sent;
            gun.pump();
            gun.takeAnswers();
            std::this_thread::sleep_until(battle_start + (f + 1) * period);
        }
        // answers until every shot is applied on the server's side of this client
        for (int i = 0; i < 30000 && gun.world().seq < static_cast<std::uint64_t>(s.shots); ++i) {
            gun.pump();
            gun.takeAnswers();
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
    });
    while (!shooter_ready)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (shooter_failed) {
        shooter.join();
        std::fprintf(stderr, "the shooter could not join or fire\n");
        return 1;
    }

    std::vector<EngineTile> engine;
    std::vector<double> pump_ms, tessellate_ms, upload_ms, frame_ms, error_px;
    std::vector<double> lag;
    std::size_t uploaded_bytes = 0;
    const auto total = static_cast<std::uint64_t>(s.shots);
    battle_start = Clock::now();
    go = true;
    auto deadline = battle_start;
    int frames = 0;
    const int max_frames = s.shots * 3 + 3000;
    for (int f = 1; f <= max_frames; ++f) {
        const game::Camera camera = flightCamera(s, f, client, battle.options);
        const auto t0 = Clock::now();
        if (const game::ClientResult r = client.pump(); !r) {
            std::fprintf(stderr, "pump: %s\n", r.message.c_str());
            break;
        }
        const auto t1 = Clock::now();
        if (!client.tessellate(camera))
            break;
        const auto t2 = Clock::now();
        engine.resize(static_cast<std::size_t>(client.tileCount()));
        for (std::int32_t t = 0; t < client.tileCount(); ++t) {
            if (!client.tileChanged(t))
                continue;
            game::TileBuffers b;
            client.tile(t, b);
            uploaded_bytes += upload(b, engine[static_cast<std::size_t>(t)]);
            client.markUploaded(t);
        }
        const auto t3 = Clock::now();
        const auto ms = [](Clock::time_point a, Clock::time_point b) {
            return std::chrono::duration<double, std::milli>(b - a).count();
        };
        pump_ms.push_back(ms(t0, t1));
        tessellate_ms.push_back(ms(t1, t2));
        upload_ms.push_back(ms(t2, t3));
        frame_ms.push_back(ms(t0, t3));
        lag.push_back(static_cast<double>(client.meshLag()));
        error_px.push_back(client.meshErrorPixels());
        frames = f;
        const game::WorldState w = client.world();
        if (w.seq == total && fired == s.shots && client.meshLag() <= 1)
            break;
        deadline = std::max(deadline + period, Clock::now() - period);
        std::this_thread::sleep_until(deadline);
    }
    const double battle_s = bench::msSince(battle_start) / 1000.0;
    shooter.join();
    const game::WorldState w = client.world();
    const testing::LiveServer::World server = srv.world();
    const bool exact = w.seq == total && w.world_hash == battle.final_hash && server.ok &&
                       server.hash == battle.final_hash && w.hash_mismatches == 0;

    const bench::Summary frame = bench::summarize(frame_ms);
    const bench::Summary lags = bench::summarize(lag);
    const bench::Summary err = bench::summarize(error_px);
    Json report{
        {"bench", "game_client_bench"},
        {"when", bench::isoNow()},
        {"cpu", bench::cpuModel()},
        {"settings",
         {{"shots", s.shots},
          {"burst", s.burst},
          {"burst_every", s.burst_every},
          {"flight", s.flight},
          {"network_thread", s.network_thread},
          {"ops_per_frame", s.ops_per_frame},
          {"fps", s.fps},
          {"tau", s.tau},
          {"viewport", {s.width, s.height}}}},
        {"join",
         {{"ms", join_ms},
          {"pumps", join_pumps.size()},
          {"pump_ms", summaryJson(bench::summarize(join_pumps))},
          {"first_tessellate_ms", first_tessellate_ms}}},
        {"frames", frames},
        {"battle_seconds", battle_s},
        {"frame_thread_ms",
         {{"total", summaryJson(frame)},
          {"first_frame", frame_ms.empty() ? 0.0 : frame_ms.front()},
          {"after_the_first",
           summaryJson(bench::summarize(
               frame_ms.size() > 1 ? std::vector<double>(frame_ms.begin() + 1, frame_ms.end())
                                   : std::vector<double>{}))},
          {"pump", summaryJson(bench::summarize(pump_ms))},
          {"tessellate", summaryJson(bench::summarize(tessellate_ms))},
          {"upload", summaryJson(bench::summarize(upload_ms))}}},
        {"mesh", {{"lag_frames", summaryJson(lags)}, {"error_pixels", summaryJson(err)}}},
        {"uploaded_bytes", uploaded_bytes},
        {"resident_mib", bench::mib(bench::residentBytes())},
        {"world",
         {{"seq", w.seq},
          {"hash", w.world_hash},
          {"authority_hash", battle.final_hash},
          {"server_hash", server.hash},
          {"hash_mismatches", w.hash_mismatches},
          {"snapshots", w.snapshots},
          {"exact", exact}}}};
    std::printf(
        "game_client_bench %s%s: %d frames, frame thread p50 %.2f p99 %.2f max %.2f ms "
        "(pump p99 %.2f, tessellate p99 %.2f, upload p99 %.2f); lag p50 %.0f p99 %.0f; error "
        "p50 %.2f p99 %.2f px; join %.0f ms (longest pump %.1f ms, first tessellate %.0f ms); "
        "%s\n",
        s.flight.c_str(), s.network_thread ? " --network-thread" : "", frames, frame.p50, frame.p99,
        frame.max, bench::summarize(pump_ms).p99, bench::summarize(tessellate_ms).p99,
        bench::summarize(upload_ms).p99, lags.p50, lags.p99, err.p50, err.p99, join_ms,
        bench::summarize(join_pumps).max, first_tessellate_ms,
        exact ? "the server's world, bit for bit" : "NOT EXACT");
    if (!s.out.empty()) {
        std::ofstream(s.out) << report.dump(2) << "\n";
    }
    return exact ? 0 : 1;
}

} // namespace

int main(int argc, char** argv) {
    Settings s;
    CLI::App app{"the game client in a battle, through libterrain_client.so"};
    app.add_option("--shots", s.shots, "battle shots")->check(CLI::Range(1, 100000));
    app.add_option("--burst", s.burst, "shots fired in one frame every --burst-every frames")
        ->check(CLI::Range(1, 1000));
    app.add_option("--burst-every", s.burst_every, "frames between bursts")
        ->check(CLI::Range(1, 100000));
    app.add_option("--flight", s.flight, "hover | cross")->check(CLI::IsMember({"hover", "cross"}));
    app.add_flag("--network-thread", s.network_thread, "the client's network on its own thread");
    app.add_option("--ops-per-frame", s.ops_per_frame, "ops applied per pump at least")
        ->check(CLI::Range(0, 100000));
    app.add_option("--fps", s.fps, "frames a second")->check(CLI::Range(1.0, 1000.0));
    app.add_option("--tau", s.tau, "screen-space error bound, pixels")->check(CLI::PositiveNumber);
    app.add_option("--out", s.out, "JSON report");
    CLI11_PARSE(app, argc, argv);
    return run(s);
}
