// Joins over a simulated internet link: how long a client takes from Connection::start() to a
// replica that holds the server's seq with its world hash, over a bottleneck of --rate-mbit and
// --rtt-ms (support/link_relay.h) and over plain loopback, for a client that ships the map (it
// holds the genesis: the server sends a genesis delta) and for one that does not (the whole
// snapshot). The world: the default map after --shots battle shots (battle_bench's battle), or
// srtm_n44w072 after --craters random craters of radius 50-400 m (client_join_bench's). The
// server starts at that state with no op log, as a server long past its first ops: every join
// is by snapshot or delta. With --keep-log the server made those ops itself and still holds them,
// so the client with the genesis resumes from seq 0: it gets the ops and applies them. Per kind:
// the first join (cold: the server builds its cache on its snapshot thread) and --joins more
// (warm: the cache is reused).
// Exit status: 0 when every join verified; 1 when one did not; 2 on a bad option or input.

#include "support/bench_facts.h"
#include "support/link_relay.h"
#include "support/loopback.h"

#include <terrain/battle.h>
#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/io/dem_import.h>
#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/server/server_thread.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#ifndef TERRAIN_DEM_DIR
#define TERRAIN_DEM_DIR "../shared/data/dem"
#endif

namespace {

using namespace terrain;
using Json = nlohmann::ordered_json;

struct JoinResult {
    double ms = -1.0; ///< -1: did not verify within the time limit
    std::uint64_t bytes_in = 0;
    std::uint64_t snapshot_bytes = 0;
    bool delta = false;
    bool resumed = false;
};

/// One client joins through `port`; with `genesis`, it starts from the map it ships.
JoinResult join(
    std::uint16_t port,
    std::uint64_t player,
    const std::optional<Terrain>& genesis,
    std::uint64_t seq,
    std::uint64_t hash,
    std::uint64_t max_replay_ops) {
    asio::io_context io;
    client::Replica replica;
    if (genesis && !replica.loadGenesis(*genesis))
        return {};
    client::ConnectionConfig config;
    config.port = port;
    config.token = testing::token(player, server::Role::kViewer);
    config.reconnect = false;
    config.max_replay_ops = max_replay_ops;
    auto connection = std::make_shared<client::Connection>(io, config, replica);
    const auto start = bench::Clock::now();
    connection->start();
    JoinResult r;
    while (bench::msSince(start) < 60000.0) {
        io.run_for(std::chrono::milliseconds(1));
        if (replica.seq() == seq && replica.worldHash() == hash &&
            (connection->stats().snapshots > 0 || connection->stats().resumes > 0)) {
            r.ms = bench::msSince(start);
            break;
        }
    }
    r.bytes_in = connection->stats().bytes_in;
    r.snapshot_bytes = connection->stats().snapshot_bytes;
    r.delta = connection->stats().genesis_deltas > 0;
    r.resumed = connection->stats().resumes > 0;
    connection->stop();
    io.run_for(std::chrono::milliseconds(1));
    return r;
}

/// How the client with the genesis joins: "resume" (replays the log) or "genesis" (a delta).
const char* joinKind(bool keep_log, std::uint64_t max_replay_ops, std::uint64_t applied) {
    return keep_log && (max_replay_ops == 0 || applied <= max_replay_ops) ? "resume" : "genesis";
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"join_link_bench: joins over a simulated link, with and without the genesis"};
    std::string world = "battle";
    std::string dem_dir = TERRAIN_DEM_DIR;
    int shots = 10000;
    int craters = 5000;
    double rate_mbit = 20.0;
    double rtt_ms = 40.0;
    int warm_joins = 3;
    std::string out;
    bool keep_log = false;
    std::uint64_t max_replay_ops = 0;
    app.add_option("--world", world, "battle | srtm")->check(CLI::IsMember({"battle", "srtm"}));
    app.add_option("--dem-dir", dem_dir, "folder holding srtm_n44w072/");
    app.add_option("--shots", shots, "battle shots on the default map")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--craters", craters, "random craters on srtm")->check(CLI::NonNegativeNumber);
    app.add_option("--rate-mbit", rate_mbit, "link bandwidth, Mbit/s")->check(CLI::PositiveNumber);
    app.add_option("--rtt-ms", rtt_ms, "link round trip, ms")->check(CLI::NonNegativeNumber);
    app.add_option("--joins", warm_joins, "warm joins per kind and link")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--out", out, "JSON report");
    app.add_flag(
        "--keep-log", keep_log,
        "the server applies the ops itself and keeps them: the genesis holder resumes from 0");
    app.add_option(
        "--max-replay-ops", max_replay_ops,
        "the clients' ConnectionConfig::max_replay_ops (0: no limit): past it, a delta");
    CLI11_PARSE(app, argc, argv);

    // the world and its genesis
    std::optional<Terrain> genesis;
    std::string name;
    if (world == "srtm") {
        const auto path = std::filesystem::path(dem_dir) / "srtm_n44w072";
        auto dem = io::importDem(path, {});
        if (!dem) {
            std::fprintf(
                stderr, "join_link_bench: cannot import %s: %s\n", path.c_str(),
                dem.error().message.c_str());
            return 2;
        }
        genesis.emplace(std::move(dem->terrain));
        name = "srtm_n44w072 + " + std::to_string(craters) + " craters R 50-400 m";
    } else {
        genesis.emplace(std::move(*makeProceduralMap({})));
        name = "default map + " + std::to_string(shots) + " battle shots";
    }
    Terrain grown = *genesis;
    std::uint64_t applied = 0;
    std::vector<DeformOp> history; // what was applied, in order

    const auto grow_start = bench::Clock::now();
    if (world == "srtm") {
        CraterSeries series;
        series.seed = 7;
        series.count = craters;
        series.min_radius = 50.0;
        series.max_radius = 400.0;
        for (const OpRequest& r : randomCraters(grown.spec(), series))
            if (auto op = quantizeOp(r, grown.spec()); op && grown.apply(*op)) {
                ++applied;
                history.push_back(*op);
            }
    } else {
        BattleOptions o; // battle_bench's battle: the zone at the map's centre
        o.zone_x = grown.spec().extentX() / 2;
        o.zone_y = grown.spec().extentY() / 2;
        BattleGenerator generator(o);
        for (int i = 0; i < shots; ++i) {
            const BattleShot shot = generator.next(grown);
            if (!shot.crater)
                continue;
            if (auto op = quantizeOp(*shot.crater, grown.spec()); op && grown.apply(*op)) {
                ++applied;
                history.push_back(*op);
            }
        }
    }
    const double grow_ms = bench::msSince(grow_start);
    const std::uint64_t hash = grown.worldHash();
    const std::size_t patches = grown.patchCount();
    std::printf(
        "join_link_bench: %s (%llu ops applied in %.0f ms, %zu patches)\n", name.c_str(),
        static_cast<unsigned long long>(applied), grow_ms, patches);

    server::ServerThreadOptions options;
    options.config.token_secret = testing::testSecret();
    options.seq = applied;
    if (keep_log) { // from the genesis, the ops in the server's log
        grown = *genesis;
        options.seq = 0;
        options.config.op_log_capacity = std::max<std::size_t>(8192, history.size() + 1);
        options.prepare = [&history](server::Authority& authority) {
            for (const DeformOp& op : history)
                if (!authority.apply(op))
                    std::fprintf(stderr, "join_link_bench: the server refused an op\n");
        };
    }
    auto server = server::ServerThread::start(std::move(grown), std::move(options));
    if (!server) {
        std::fprintf(stderr, "join_link_bench: %s\n", server.error().message.c_str());
        return 2;
    }
    const std::uint16_t direct = (*server)->port();
    testing::LinkShape shape{rate_mbit * 1e6, rtt_ms / 1000.0};
    testing::LinkRelay relay(direct, shape);

    bool ok = true;
    std::uint64_t player = 100;
    Json runs = Json::array();
    const std::optional<Terrain> none;
    // per link: the genesis holder first (its cold join builds the delta cache), then the bare
    // client (its cold join builds the whole snapshot's); a build makes both kinds from then on
    for (const bool linked : {true, false}) {
        for (const bool shipped : {true, false}) {
            std::vector<double> warm;
            JoinResult cold;
            JoinResult last;
            for (int i = 0; i <= warm_joins; ++i) {
                const JoinResult r = join(
                    linked ? relay.port() : direct, player++, shipped ? genesis : none, applied,
                    hash, max_replay_ops);
                const bool replays = keep_log && (max_replay_ops == 0 || applied <= max_replay_ops);
                if (r.ms < 0.0 || (replays ? r.resumed && !r.delta : r.delta) != shipped) {
                    std::fprintf(
                        stderr, "join_link_bench: FAIL: a join did not verify (%s, %s)\n",
                        linked ? "link" : "loopback", shipped ? "genesis" : "whole");
                    ok = false;
                }
                if (i == 0)
                    cold = r;
                else
                    warm.push_back(r.ms);
                last = r;
            }
            const bench::Summary w = bench::summarize(warm);
            std::printf(
                "  %-9s %-7s join: cold %6.0f ms, warm p50 %6.0f ms (max %6.0f); %.2f MiB in "
                "(snapshot %.2f MiB)\n",
                linked ? "link" : "loopback",
                shipped ? joinKind(keep_log, max_replay_ops, applied) : "whole", cold.ms, w.p50,
                w.max, bench::mib(last.bytes_in), bench::mib(last.snapshot_bytes));
            runs.push_back(
                {{"link", linked ? "simulated" : "loopback"},
                 {"client", shipped ? std::string("holds the genesis: ") +
                                          joinKind(keep_log, max_replay_ops, applied)
                                    : std::string("no genesis: whole")},
                 {"cold_ms", cold.ms},
                 {"warm_ms", {{"samples", w.n}, {"p50", w.p50}, {"max", w.max}, {"min", w.min}}},
                 {"bytes_in", last.bytes_in},
                 {"snapshot_bytes", last.snapshot_bytes}});
        }
    }
    const server::ServerStats stats = (*server)->stats();
    (*server)->stop();

    Json report{
        {"benchmark", "join_link_bench"},
        {"date", bench::isoNow()},
        {"cpu", bench::cpuModel()},
        {"world", name},
        {"ops_applied", applied},
        {"server_keeps_log", keep_log},
        {"max_replay_ops", max_replay_ops},
        {"patches", patches},
        {"link", {{"mbit_per_second", rate_mbit}, {"rtt_ms", rtt_ms}}},
        {"runs", runs},
        {"snapshots_built", stats.snapshots_built},
        {"ok", ok},
        {"note",
         "join = Connection::start() to a replica at the server's seq with its hash (client "
         "decode, checks and rehash included); link = a relay delivering each direction at the "
         "rate after half the round trip (support/link_relay.h: TCP slow start not modelled); "
         "cold = the first join of its kind after the server started or the other kind's "
         "build"}};
    std::printf("%s\n", report.dump(2).c_str());
    if (!out.empty()) {
        std::ofstream file(out);
        if (!file) {
            std::fprintf(stderr, "join_link_bench: cannot write %s\n", out.c_str());
            return 2;
        }
        file << report.dump(2) << "\n";
    }
    return ok ? 0 : 1;
}
