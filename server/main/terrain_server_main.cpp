// terrain-server: the authoritative terrain service.
//   terrain-server [serve] [options]       run (default)
//   terrain-server token --player 7 --role deformer [--ttl 3600]   mint an access token
//   terrain-server health [--connect host:port]                    exit 0 when serving
// Every option also reads an environment variable (TERRAIN_*), so containers need no flags.

#include <terrain/io/genesis.h>
#include <terrain/journal/journal.h>
#include <terrain/procedural_map.h>
#include <terrain/server/agones_sdk.h>
#include <terrain/server/auth_token.h>
#include <terrain/server/authority.h>
#include <terrain/server/recovery_status.h>
#include <terrain/server/server.h>
#include <terrain/task_runner.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>

#include <CLI/CLI.hpp>
#include <sched.h>

#include <algorithm>
#include <asio.hpp>
#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

namespace {

using namespace terrain;
namespace pb = wire::pb;

/// The CPUs this process may run on (its affinity: a container's cpuset), at most 8: an op's
/// tasks are a few hundred microseconds, and more threads only spin.
unsigned defaultApplyThreads() {
    unsigned cpus = ThreadPool::hardwareThreads();
#ifdef __linux__
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof(set), &set) == 0)
        cpus = static_cast<unsigned>(std::max(1, CPU_COUNT(&set)));
#endif
    return std::min(cpus, 8u);
}

struct Options {
    std::string bind = "0.0.0.0";
    int port = 7777;
    int metrics_port = -1;
    std::string log_format = "text";
    bool agones = false;
    int agones_sdk_port = 9358;
    int agones_health_ms = 2000;
    std::string data_dir = "terrain-data";
    bool no_journal = false;
    std::string durability = "fsync";
    std::string secret;
    std::string secret_file;
    std::string dem;
    std::uint64_t seed = 1;
    int size = 1025;
    std::optional<double> tolerance; ///< unset: the genesis source's default
    std::size_t max_sessions = 1024;
    std::size_t max_pending = server::ServerConfig{}.max_pending_sessions;
    std::size_t max_pending_per_address = server::ServerConfig{}.max_pending_per_address;
    std::size_t outbound_budget = 4 << 20;
    std::size_t op_log = 8192;
    std::uint64_t snapshot_cache_lag = server::ServerConfig{}.snapshot_cache_max_lag;
    double deform_rate = 30.0;
    std::uint64_t snapshot_every = 20000;
    double snapshot_replay_seconds = server::ServerConfig{}.journal_snapshot_replay_seconds;
    unsigned apply_threads = defaultApplyThreads();
    bool batch_broadcasts = false;
    bool batch_hash_per_op = false;
    std::string port_file;
    // token
    std::uint64_t player = 0;
    std::string role = "viewer";
    std::int64_t ttl = 3600;
    // health
    std::string connect = "127.0.0.1:7777";
};

Result<std::vector<std::uint8_t>> loadSecret(const Options& o) {
    std::string text = o.secret;
    if (!o.secret_file.empty()) {
        std::ifstream in(o.secret_file);
        if (!in)
            return makeError(ErrorCode::kIo, "cannot read token secret file " + o.secret_file);
        std::getline(in, text);
    }
    if (text.empty())
        return makeError(
            ErrorCode::kOutOfRange,
            "no token secret: set --token-secret, --token-secret-file or TERRAIN_TOKEN_SECRET");
    return server::parseSecret(text);
}

Result<io::Genesis> genesis(const Options& o) {
    io::GenesisOptions g;
    g.dem = o.dem;
    g.seed = o.seed;
    g.size = o.size;
    g.patch_tolerance_metres = o.tolerance;
    return io::makeGenesis(g);
}

/// printf into a string, for log messages.
[[gnu::format(printf, 1, 2)]] std::string strf(const char* format, ...) {
    std::va_list args;
    va_start(args, format);
    std::va_list again;
    va_copy(again, args);
    const int n = std::vsnprintf(nullptr, 0, format, args);
    va_end(args);
    std::string out(static_cast<std::size_t>(std::max(n, 0)) + 1, '\0');
    std::vsnprintf(out.data(), out.size(), format, again);
    va_end(again);
    out.resize(static_cast<std::size_t>(std::max(n, 0)));
    return out;
}

/// The world a server starts from: its journal's (recovered, or a new one with the genesis),
/// or the genesis alone under --no-journal.
struct OpenedWorld {
    std::optional<journal::Journal> journal;
    std::optional<Terrain> terrain;
    std::uint64_t seq = 0;
    std::optional<journal::RecoveredHistory> history;
    server::RecoveryReport recovery;
};

/// Opens (or creates) the journal and recovers the world from it, replaying on `apply_pool`.
/// Returns 0, or the exit code after logging why (2: a bad setting).
int openWorld(
    const Options& o, ThreadPool& apply_pool, server::LogWriter& log, OpenedWorld& world) {
    const auto t0 = std::chrono::steady_clock::now();
    if (o.no_journal) {
        Result<io::Genesis> made = genesis(o);
        if (!made) {
            log.error(
                "map.failed", "terrain-server", strf("map: %s", made.error().message.c_str()));
            return 1;
        }
        world.terrain.emplace(std::move(made->terrain));
        log.info(
            "journal.none", "journal",
            "none (--no-journal): ops are acknowledged without durability");
        return 0;
    }
    Result<journal::Durability> durability = journal::parseDurability(o.durability);
    if (!durability) {
        log.error("config.durability", "terrain-server", durability.error().message);
        return 2;
    }
    journal::JournalOptions journal_options{*durability, 2, o.op_log};
    journal_options.apply_runner = &apply_pool;
    // segments of 65,536 records (3.7 MB): the time rule snapshots every few seconds, and
    // a new segment at each cost the io thread two fsyncs (FORMAT.md, "Writing")
    journal_options.segment_records = 65536;
    Result<journal::Journal> opened = journal::Journal::open(o.data_dir, journal_options);
    if (!opened) {
        log.error("journal.open_failed", "terrain-server", opened.error().message);
        return 1;
    }
    journal::Journal& journal = world.journal.emplace(std::move(*opened));
    if (journal.empty()) {
        Result<io::Genesis> made = genesis(o);
        if (!made) {
            log.error(
                "map.failed", "terrain-server", strf("map: %s", made.error().message.c_str()));
            return 1;
        }
        if (Status s = journal.initialize(made->terrain, 0); !s) {
            log.error("journal.init_failed", "terrain-server", s.error().message);
            return 1;
        }
        world.terrain.emplace(std::move(made->terrain));
        log.info(
            "journal.new_world", "journal",
            strf("new world in %s: %s", o.data_dir.c_str(), made->source.c_str()));
        return 0;
    }
    Result<journal::RecoveredState> recovered = journal.recover(o.op_log);
    if (!recovered) {
        log.error(
            "journal.recovery_refused", "terrain-server",
            strf("recovery refused: %s", recovered.error().message.c_str()));
        return 1;
    }
    world.recovery.snapshot_seq = recovered->snapshot_seq;
    world.recovery.replayed_records = recovered->replayed_records;
    world.recovery.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (const std::string& note : recovered->notes)
        log.info("journal.note", "journal", note);
    log.info(
        "journal.recovered", "journal",
        strf(
            "recovered seq %llu (snapshot %llu + %zu records replayed, hashes verified, "
            "%zu torn bytes dropped) in %.0f ms",
            static_cast<unsigned long long>(recovered->seq),
            static_cast<unsigned long long>(recovered->snapshot_seq), recovered->replayed_records,
            recovered->torn_bytes_dropped, 1000.0 * world.recovery.seconds));
    world.seq = recovered->seq;
    world.terrain.emplace(std::move(recovered->terrain));
    world.history = std::move(recovered->history);
    return 0;
}

/// The retained log as it was before the restart: clients a few ops behind resume across it.
void restoreRetainedLog(
    server::Authority& authority,
    const journal::RecoveredHistory& history,
    server::LogWriter& log) {
    std::vector<server::LoggedOp> ops;
    ops.reserve(history.records.size());
    for (const journal::JournalRecord& r : history.records)
        ops.push_back({r.seq, r.op, r.world_hash});
    // without it the world is still whole: clients behind then join by snapshot
    if (Status s = authority.restoreLog(history.base_seq, history.base_hash, ops); !s)
        log.info(
            "journal.log_not_restored", "journal",
            strf(
                "retained log not restored (clients behind will get snapshots): %s",
                s.error().message.c_str()));
    else
        log.info(
            "journal.log_restored", "journal",
            strf(
                "%zu ops retained for resumes (from seq %llu)", ops.size(),
                static_cast<unsigned long long>(authority.log().resumableFrom())));
}

server::TransportConfig transportConfig(const Options& o) {
    server::TransportConfig transport;
    transport.bind_address = o.bind;
    transport.port = static_cast<std::uint16_t>(o.port);
    transport.metrics_port = o.metrics_port;
    return transport;
}

server::ServerConfig serverConfig(const Options& o, std::vector<std::uint8_t> secret) {
    server::ServerConfig config;
    config.max_sessions = o.max_sessions;
    config.max_pending_sessions = o.max_pending;
    config.max_pending_per_address = o.max_pending_per_address;
    config.outbound_budget_bytes = o.outbound_budget;
    config.op_log_capacity = o.op_log;
    config.deform_rate_per_second = o.deform_rate;
    config.deform_burst = 2 * o.deform_rate;
    config.journal_snapshot_every = o.snapshot_every;
    config.journal_snapshot_replay_seconds = o.snapshot_replay_seconds;
    config.snapshot_cache_max_lag = o.snapshot_cache_lag;
    config.batch_broadcasts = o.batch_broadcasts;
    config.batch_hash_per_op = o.batch_hash_per_op;
    config.token_secret = std::move(secret);
    return config;
}

void logListening(
    const Options& o,
    const server::Server& srv,
    const server::Authority& authority,
    double load_ms,
    server::LogWriter& log) {
    const WorldSpec& spec = authority.terrain().spec();
    log.info(
        "server.listening", "terrain-server",
        strf(
            "%dx%d map, seq %llu, world hash %016llx, loaded in %.0f ms; listening on %s:%u",
            spec.width, spec.height, static_cast<unsigned long long>(authority.seq()),
            static_cast<unsigned long long>(authority.terrain().worldHash()), load_ms,
            o.bind.c_str(), srv.port()));
    log.info(
        "server.resume_window", "terrain-server",
        strf(
            "clients up to %llu ops behind resume without a snapshot (--op-log %zu, "
            "--outbound-budget %zu: half of it at 64 bytes an op)",
            static_cast<unsigned long long>(srv.resumeWindow()), o.op_log, o.outbound_budget));
    if (o.metrics_port >= 0)
        log.info(
            "server.metrics", "terrain-server",
            strf(
                "probes and metrics on http://%s:%u (/livez, /readyz, /metrics)", o.bind.c_str(),
                srv.metricsPort()));
}

/// Serves until SIGTERM or SIGINT (a drain), or until the server fails (a failed journal: nothing
/// more may be acknowledged), telling Agones when asked; returns the exit code.
int runUntilStopped(
    asio::io_context& io,
    server::Server& srv,
    const Options& o,
    const std::shared_ptr<server::LogWriter>& log) {
    std::optional<server::AgonesSdk> agones;
    if (o.agones) {
        server::AgonesSdk::Options sdk;
        sdk.port = static_cast<std::uint16_t>(o.agones_sdk_port);
        sdk.health_every = std::chrono::milliseconds(o.agones_health_ms);
        agones.emplace(
            io, sdk, [&] { return !srv.failed() && !srv.draining(); }, log);
        agones->start();
    }
    // after the drain, Agones hears Shutdown (the GameServer goes; a fleet replaces it)
    const auto drain = [&] {
        srv.shutdown([&] {
            if (agones)
                agones->shutdown([&] { io.stop(); });
            else
                io.stop();
        });
    };
    asio::signal_set signals(io, SIGTERM, SIGINT);
    signals.async_wait([&](const asio::error_code& ec, int signal) {
        if (ec)
            return;
        log->info("server.draining", "terrain-server", strf("signal %d: draining", signal));
        drain();
    });
    asio::steady_timer watchdog(io);
    std::function<void()> watch = [&] {
        watchdog.expires_after(std::chrono::milliseconds(200));
        watchdog.async_wait([&](const asio::error_code& ec) {
            if (ec)
                return;
            if (srv.failed())
                drain();
            else
                watch();
        });
    };
    watch();
    io.run();
    const server::ServerStats& st = srv.stats();
    log->info(
        "server.stopped", "terrain-server",
        strf(
            "stopped at seq %llu, hash %016llx; %llu ops accepted, %llu refused, %llu commits, "
            "%llu sessions, %llu resyncs, %llu slow disconnects",
            static_cast<unsigned long long>(srv.broadcastSeq()),
            static_cast<unsigned long long>(srv.broadcastHash()),
            static_cast<unsigned long long>(st.ops_accepted),
            static_cast<unsigned long long>(st.ops_refused),
            static_cast<unsigned long long>(st.commits),
            static_cast<unsigned long long>(st.sessions_accepted),
            static_cast<unsigned long long>(st.resyncs),
            static_cast<unsigned long long>(st.slow_disconnects)));
    if (srv.failed()) {
        log->error("server.failed", "terrain-server", strf("failed: %s", srv.failure().c_str()));
        return 1;
    }
    return 0;
}

/// `terrain-server serve`: the secret, the probes while the world loads, the world, the server,
/// then serving until stopped.
int serve(const Options& o) {
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
    const auto log = std::make_shared<server::LogWriter>(
        o.log_format == "json" ? server::LogFormat::kJson : server::LogFormat::kText);
    Result<std::vector<std::uint8_t>> secret = loadSecret(o);
    if (!secret) {
        log->error("config.secret", "terrain-server", secret.error().message);
        return 2;
    }
    // while the journal recovers, the probes say alive and not ready (the Server's own
    // responder takes the port once it exists)
    std::unique_ptr<server::RecoveryStatus> recovering;
    if (o.metrics_port >= 0) {
        auto status =
            server::RecoveryStatus::start(o.bind, static_cast<std::uint16_t>(o.metrics_port));
        if (!status) {
            log->error("server.listen_failed", "terrain-server", status.error().message);
            return 1;
        }
        recovering = std::move(*status);
    }
    // an op's cells and tiles on these threads, the io thread among them (recovery's replay too)
    ThreadPool apply_pool(o.apply_threads);
    const auto t0 = std::chrono::steady_clock::now();
    OpenedWorld world;
    if (const int code = openWorld(o, apply_pool, *log, world); code != 0)
        return code;
    const double load_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    server::Authority authority(std::move(*world.terrain), world.seq, o.op_log, &apply_pool);
    if (world.history)
        restoreRetainedLog(authority, *world.history, *log);

    if (recovering)
        recovering->stop();
    asio::io_context io(1);
    server::Server srv(
        io, transportConfig(o), serverConfig(o, std::move(*secret)), authority,
        world.journal ? &*world.journal : nullptr);
    srv.setLog(log);
    srv.setRecoveryReport(world.recovery);
    if (Status s = srv.start(); !s) {
        log->error("server.listen_failed", "terrain-server", s.error().message);
        return 1;
    }
    logListening(o, srv, authority, load_ms, *log);
    if (!o.port_file.empty())
        std::ofstream(o.port_file) << srv.port() << "\n";
    return runUntilStopped(io, srv, o, log);
}

int mintToken(const Options& o) {
    Result<std::vector<std::uint8_t>> secret = loadSecret(o);
    if (!secret) {
        std::fprintf(stderr, "terrain-server token: %s\n", secret.error().message.c_str());
        return 2;
    }
    Result<server::Role> role = server::parseRole(o.role);
    if (!role) {
        std::fprintf(stderr, "terrain-server token: %s\n", role.error().message.c_str());
        return 2;
    }
    const std::int64_t now = std::chrono::duration_cast<std::chrono::seconds>(
                                 std::chrono::system_clock::now().time_since_epoch())
                                 .count();
    std::printf("%s\n", server::mintToken({o.player, *role, now + o.ttl}, *secret).c_str());
    return 0;
}

/// One HealthRequest over TCP and its reply (`terrain-server health`, a container's
/// HEALTHCHECK): connect, write, read until a frame, one step per member as Asio's examples
/// have it. Any failure stops the loop with its reason in detail().
class HealthProbe {
  public:
    explicit HealthProbe(asio::io_context& io)
        : io_(io), socket_(io), resolver_(io), reader_(1 << 16) {}

    void start(const std::string& host, const std::string& port) {
        pb::Envelope request;
        request.mutable_health_request();
        wire::appendFrame(request, out_);
        // a host or port that does not resolve is a failed probe, not an abort
        asio::error_code rec;
        const auto endpoints = resolver_.resolve(host, port, rec);
        if (rec)
            return fail("cannot resolve " + host + ":" + port + ": " + rec.message());
        asio::async_connect(
            socket_, endpoints, [this](const asio::error_code& ec, const asio::ip::tcp::endpoint&) {
                onConnected(ec);
            });
    }
    /// 0 when the server said it is healthy.
    int result() const { return result_; }
    const std::string& detail() const { return detail_; }

  private:
    void fail(std::string why) {
        detail_ = std::move(why);
        io_.stop();
    }
    void onConnected(const asio::error_code& ec) {
        if (ec)
            return fail("cannot connect: " + ec.message());
        asio::async_write(
            socket_, asio::buffer(out_), [this](const asio::error_code& wec, std::size_t) {
                if (wec)
                    return fail("write: " + wec.message());
                readSome();
            });
    }
    void readSome() {
        auto space = reader_.prepare(4096);
        socket_.async_read_some(
            asio::buffer(space.data(), space.size()),
            [this](const asio::error_code& ec, std::size_t n) { onRead(ec, n); });
    }
    void onRead(const asio::error_code& ec, std::size_t n) {
        if (ec)
            return fail("read: " + ec.message());
        reader_.commit(n);
        auto frame = reader_.next();
        if (!frame || !frame->has_value())
            return readSome(); // not a whole frame yet
        auto env = wire::decodeEnvelope(**frame);
        if (!env || !env->has_health_reply())
            return fail("unexpected reply");
        const pb::HealthReply& h = env->health_reply();
        result_ = h.healthy() ? 0 : 1;
        fail(strf(
            "%s, seq %llu, hash %016llx, %u sessions", h.detail().c_str(),
            static_cast<unsigned long long>(h.seq()),
            static_cast<unsigned long long>(h.world_hash()), h.sessions()));
    }

    asio::io_context& io_;
    asio::ip::tcp::socket socket_;
    asio::ip::tcp::resolver resolver_;
    std::vector<std::uint8_t> out_;
    wire::FrameReader reader_;
    int result_ = 1;
    std::string detail_ = "no reply within 3 s";
};

int healthCheck(const Options& o) {
    const auto colon = o.connect.rfind(':');
    if (colon == std::string::npos) {
        std::fprintf(stderr, "health: --connect must be host:port\n");
        return 2;
    }
    asio::io_context io;
    HealthProbe probe(io);
    probe.start(o.connect.substr(0, colon), o.connect.substr(colon + 1));
    io.run_for(std::chrono::seconds(3));
    std::printf("health: %s: %s\n", probe.result() == 0 ? "ok" : "FAIL", probe.detail().c_str());
    return probe.result();
}

} // namespace

int main(int argc, char** argv) {
    Options o;
    CLI::App app{"terrain-server: authoritative deformable terrain over TCP"};
    // --help shows every option's default (the subcommands inherit this)
    app.option_defaults()->always_capture_default();
    app.add_option(
           "--token-secret", o.secret, "HMAC secret for access tokens (>= 16 bytes, or hex:...)")
        ->envname("TERRAIN_TOKEN_SECRET");
    app.add_option("--token-secret-file", o.secret_file, "file whose first line is the secret")
        ->envname("TERRAIN_TOKEN_SECRET_FILE");

    CLI::App* serve_cmd = app.add_subcommand("serve", "run the server (the default)");
    serve_cmd->add_option("--bind", o.bind, "address to listen on")->envname("TERRAIN_BIND");
    serve_cmd->add_option("--port", o.port, "TCP port (0: any free port)")
        ->envname("TERRAIN_PORT")
        ->check(CLI::Range(0, 65535));
    serve_cmd
        ->add_option(
            "--metrics-port", o.metrics_port,
            "HTTP port for probes and Prometheus (GET /livez, /readyz, /metrics) on the --bind "
            "address; off unless given (0: any free port)")
        ->envname("TERRAIN_METRICS_PORT")
        ->check(CLI::Range(0, 65535));
    serve_cmd
        ->add_option(
            "--log-format", o.log_format,
            "text: a line per event, as people read it; json: JSON Lines (time, level, event, "
            "message; session, peer and the event's fields where it has them)")
        ->envname("TERRAIN_LOG_FORMAT")
        ->check(CLI::IsMember({"text", "json"}));
    serve_cmd
        ->add_flag(
            "--agones", o.agones,
            "call the Agones SDK over its local HTTP gateway: Ready once serving, Health while "
            "healthy, Shutdown after a drain")
        ->envname("TERRAIN_AGONES");
    serve_cmd
        ->add_option(
            "--agones-sdk-port", o.agones_sdk_port,
            "with --agones: the SDK gateway's port on 127.0.0.1 (Agones sets AGONES_SDK_HTTP_PORT)")
        ->envname("AGONES_SDK_HTTP_PORT")
        ->check(CLI::Range(1, 65535));
    serve_cmd
        ->add_option(
            "--agones-health-ms", o.agones_health_ms,
            "with --agones: milliseconds between health pings (below the GameServer's "
            "health.periodSeconds)")
        ->envname("TERRAIN_AGONES_HEALTH_MS")
        ->check(CLI::Range(50, 600000));
    serve_cmd->add_option("--data-dir", o.data_dir, "journal and snapshots directory")
        ->envname("TERRAIN_DATA_DIR");
    serve_cmd->add_flag("--no-journal", o.no_journal, "keep no journal (ops are not durable)")
        ->envname("TERRAIN_NO_JOURNAL");
    serve_cmd
        ->add_option(
            "--durability", o.durability,
            "fsync: fdatasync before an op is acknowledged; write: write() only (survives a server "
            "crash, not an OS crash)")
        ->envname("TERRAIN_DURABILITY");
    serve_cmd->add_option("--dem", o.dem, "genesis map: DEM sidecar JSON (new data dir only)")
        ->envname("TERRAIN_DEM");
    serve_cmd->add_option("--seed", o.seed, "genesis map: procedural seed")
        ->envname("TERRAIN_SEED")
        ->capture_default_str();
    serve_cmd->add_option("--size", o.size, "genesis map: procedural size in vertices")
        ->envname("TERRAIN_SIZE")
        ->check(CLI::Range(65, 8193))
        ->capture_default_str();
    serve_cmd
        ->add_option(
            "--tolerance", o.tolerance,
            "genesis map: patch tolerance in metres (default 1/32 m; a DEM: its spacing / 64, at "
            "least 1/32 m)")
        ->envname("TERRAIN_TOLERANCE")
        ->check(CLI::Range(1.0 / 1024, 10.0));
    serve_cmd->add_option("--max-sessions", o.max_sessions, "player slots (sessions past Hello)")
        ->envname("TERRAIN_MAX_SESSIONS");
    serve_cmd
        ->add_option(
            "--max-pending", o.max_pending,
            "connections waiting to say Hello (health probes among them), their own limit")
        ->envname("TERRAIN_MAX_PENDING")
        ->check(CLI::Range(1, 1 << 20));
    serve_cmd
        ->add_option(
            "--max-pending-per-address", o.max_pending_per_address,
            "connections from one address waiting to say Hello")
        ->envname("TERRAIN_MAX_PENDING_PER_ADDRESS")
        ->check(CLI::Range(1, 1 << 20));
    serve_cmd
        ->add_option(
            "--outbound-budget", o.outbound_budget,
            "bytes of op backlog per session before a snapshot resync")
        ->envname("TERRAIN_OUTBOUND_BUDGET")
        ->check(CLI::Range(4096, 1 << 30));
    serve_cmd->add_option("--op-log", o.op_log, "ops retained for reconnects")
        ->envname("TERRAIN_OP_LOG")
        ->check(CLI::Range(16, 1 << 24));
    serve_cmd->add_option("--deform-rate", o.deform_rate, "deform requests per second per session")
        ->envname("TERRAIN_DEFORM_RATE")
        ->check(CLI::Range(0.1, 100000.0));
    serve_cmd
        ->add_flag(
            "--batch-broadcasts", o.batch_broadcasts,
            "tick batching: the ops of one group commit go out as one OpBatch frame, with the "
            "world hash after the last (about 15 bytes a crater in a burst)")
        ->envname("TERRAIN_BATCH_BROADCASTS");
    serve_cmd
        ->add_flag(
            "--batch-hash-per-op", o.batch_hash_per_op,
            "with --batch-broadcasts: every op's world hash too (8 bytes an op)")
        ->envname("TERRAIN_BATCH_HASH_PER_OP");
    serve_cmd
        ->add_option(
            "--snapshot-cache-lag", o.snapshot_cache_lag,
            "ops a cached join snapshot may be behind (joins replay them); once joins have asked, "
            "it is rebuilt off the network thread every half of this")
        ->envname("TERRAIN_SNAPSHOT_CACHE_LAG")
        ->check(CLI::Range(1, 1 << 24));
    serve_cmd
        ->add_option(
            "--snapshot-replay-seconds", o.snapshot_replay_seconds,
            "journal snapshot once replaying the ops since the last one would take this long "
            "(their measured apply time), so a restart replays about this much; 0: off")
        ->envname("TERRAIN_SNAPSHOT_REPLAY_SECONDS")
        ->check(CLI::Range(0.0, 3600.0))
        ->capture_default_str();
    serve_cmd
        ->add_option(
            "--apply-threads", o.apply_threads,
            "threads an op's cells and tiles are applied on, the network thread among them (the "
            "same bits at any count); default: the CPUs the process may use, at most 8")
        ->envname("TERRAIN_APPLY_THREADS")
        ->check(CLI::Range(1, 256))
        ->capture_default_str();
    serve_cmd
        ->add_option(
            "--snapshot-every", o.snapshot_every,
            "journal snapshot every N ops too, whichever rule comes first; 0: off")
        ->envname("TERRAIN_SNAPSHOT_EVERY")
        ->capture_default_str();
    serve_cmd->add_option("--port-file", o.port_file, "write the bound port to this file")
        ->envname("TERRAIN_PORT_FILE");

    CLI::App* token_cmd = app.add_subcommand("token", "mint an access token");
    token_cmd->add_option("--player", o.player)->required();
    token_cmd->add_option("--role", o.role, "viewer | deformer | admin");
    token_cmd->add_option("--ttl", o.ttl, "seconds until it expires")
        ->check(CLI::Range(1, 100000000));

    CLI::App* health_cmd = app.add_subcommand("health", "exit 0 when the server answers healthy");
    health_cmd->add_option("--connect", o.connect, "host:port")->envname("TERRAIN_HEALTH_CONNECT");
    app.require_subcommand(0, 1);
    CLI11_PARSE(app, argc, argv);

    if (token_cmd->parsed())
        return mintToken(o);
    if (health_cmd->parsed())
        return healthCheck(o);
    if (!serve_cmd->parsed()) {
        // `terrain-server` alone serves with defaults and environment
        serve_cmd->parse(std::vector<std::string>{});
    }
    return serve(o);
}
