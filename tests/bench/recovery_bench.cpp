// recovery_bench: kill -9 of a real terrain-server at random moments while one deformer feeds it
// a battle at a steady rate, then a restart on the same data directory, over and over. Measures
// what an operator's fleet sees: restart to listening, restart to the first acknowledged op
// (serving again), what each recovery replayed and the server's own "loaded in"; and checks that
// no acknowledged op was lost (each recovery resumes at or after the last seq acknowledged before
// the kill, and the journal holds each acknowledged op at its seq). Prints one line per restart,
// a summary, and writes JSON (--json). Exit status: 0 when nothing was lost and every restart
// served again; 1 otherwise; 2 on input.

#include "light_deformer.h"

#include <terrain/journal/journal.h>
#include <terrain/op_script.h>
#include <terrain/server/auth_token.h>

#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using terrain::DeformOp;
namespace bench = terrain::bench;

double secondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

struct Options {
    std::string server = "build/release/server/terrain-server";
    std::string ops_path;
    std::string out = "out/bench/recovery";
    std::string json_path;
    std::string server_args;
    double seconds = 60.0;
    double rate = 1000.0;
    double kill_min = 1.0;
    double kill_max = 6.0;
    std::uint64_t seed = 1;
};

/// `terrain-server --token-secret S serve --bind 127.0.0.1 --port 0 --port-file F --data-dir D
/// <extra>`, output to `log`.
pid_t spawnServer(
    const Options& o, const std::string& secret, const fs::path& port_file, const fs::path& log) {
    std::vector<std::string> args = {o.server,        "--token-secret",
                                     secret,          "serve",
                                     "--bind",        "127.0.0.1",
                                     "--port",        "0",
                                     "--port-file",   port_file.string(),
                                     "--data-dir",    (fs::path(o.out) / "data").string(),
                                     "--deform-rate", "100000"};
    std::istringstream extra(o.server_args);
    for (std::string a; extra >> a;)
        args.push_back(a);
    std::vector<char*> argv;
    for (std::string& a : args)
        argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t pid = fork();
    if (pid == 0) {
        const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            ::dup2(fd, 1);
            ::dup2(fd, 2);
        }
        execv(o.server.c_str(), argv.data());
        _exit(127);
    }
    return pid;
}

/// From the server's log: "recovered seq S (snapshot N + R records replayed" and "loaded in X
/// ms".
struct RecoveryLine {
    std::uint64_t seq = 0;
    std::uint64_t snapshot = 0;
    std::uint64_t replayed = 0;
    double loaded_ms = -1.0;
};

RecoveryLine readRecovery(const fs::path& log) {
    RecoveryLine r;
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);) {
        unsigned long long seq = 0, snapshot = 0, replayed = 0;
        if (auto at = line.find("recovered seq ");
            at != std::string::npos &&
            std::sscanf(
                line.c_str() + at, "recovered seq %llu (snapshot %llu + %llu", &seq, &snapshot,
                &replayed) == 3) {
            r.seq = seq;
            r.snapshot = snapshot;
            r.replayed = replayed;
        }
        if (auto at = line.find("loaded in "); at != std::string::npos)
            std::sscanf(line.c_str() + at, "loaded in %lf", &r.loaded_ms);
    }
    return r;
}

struct Restart {
    double listen_s = 0.0;  ///< spawn to the port file (listening)
    double serving_s = 0.0; ///< spawn to the first acknowledged op
    double ran_s = 0.0;     ///< serving to the kill
    std::uint64_t acked_before_kill = 0;
    RecoveryLine recovery; ///< of this start (the previous kill's recovery)
};

struct Summary {
    double p50 = 0, p99 = 0, max = 0;
};

Summary summarize(std::vector<double> v) {
    Summary s;
    if (v.empty())
        return s;
    std::sort(v.begin(), v.end());
    const auto rank = [&](double q) {
        return v[std::min(
            v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
    };
    s.p50 = rank(0.5);
    s.p99 = rank(0.99);
    s.max = v.back();
    return s;
}

/// Parses the command line into `o`; an exit status when main should stop (help, bad input).
std::optional<int> parseOptions(int argc, char** argv, Options& o) {
    CLI::App app{"recovery_bench: kill -9 a terrain-server under a steady battle, restart, repeat"};
    app.add_option("--server", o.server, "terrain-server binary")->capture_default_str();
    app.add_option("--ops", o.ops_path, "canonical ops (battle_bench --ops), sent in a cycle")
        ->required();
    app.add_option("--out", o.out, "working folder (emptied): data directory, server logs")
        ->capture_default_str();
    app.add_option("--json", o.json_path, "JSON output path");
    app.add_option("--seconds", o.seconds, "length of the run")->capture_default_str();
    app.add_option("--rate", o.rate, "ops per second sent")->check(CLI::PositiveNumber);
    app.add_option("--kill-min", o.kill_min, "seconds of serving before a kill, at least");
    app.add_option("--kill-max", o.kill_max, "... and at most (uniform)");
    app.add_option("--seed", o.seed, "kill moments");
    app.add_option("--server-args", o.server_args, "more serve arguments, space-separated");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    if (o.kill_max < o.kill_min) {
        std::fprintf(stderr, "recovery_bench: --kill-max must be at least --kill-min\n");
        return 2;
    }
    return std::nullopt;
}

/// The ops to send in a cycle (at least one), or nullopt with a message.
std::optional<std::vector<DeformOp>> readOps(const std::string& path) {
    std::ifstream file(path);
    std::stringstream text;
    text << file.rdbuf();
    terrain::Result<std::vector<DeformOp>> ops = terrain::parseCanonicalOps(text.str());
    if (!file || !ops || ops->empty()) {
        std::fprintf(
            stderr, "recovery_bench: %s: %s\n", path.c_str(),
            !ops ? ops.error().message.c_str() : "cannot read, or no ops");
        return std::nullopt;
    }
    return std::move(*ops);
}

/// A deformer's token for the server's secret, valid for a day; nullopt with a message if the
/// secret is refused.
std::optional<std::string> deformerToken(const std::string& secret) {
    using namespace terrain;
    const auto key = server::parseSecret(secret);
    if (!key) {
        std::fprintf(stderr, "recovery_bench: %s\n", key.error().message.c_str());
        return std::nullopt;
    }
    server::TokenClaims claims;
    claims.player_id = 1;
    claims.role = server::Role::kDeformer;
    claims.expires_unix = std::chrono::duration_cast<std::chrono::seconds>(
                              std::chrono::system_clock::now().time_since_epoch())
                              .count() +
                          24 * 3600;
    return server::mintToken(claims, *key);
}

/// Waits (up to a minute) for the server to write its port; 0 if it did not.
std::uint16_t awaitListening(const fs::path& port_file, Clock::time_point spawned) {
    std::uint16_t port = 0;
    while (port == 0 && secondsSince(spawned) < 60.0) {
        std::ifstream in(port_file);
        int p = 0;
        if (in >> p)
            port = static_cast<std::uint16_t>(p);
        else
            std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    return port;
}

/// The kill loop: starts, feeds and kills servers on one data directory until the run's time
/// is up, then starts one more and stops it cleanly. Keeps every acknowledged op by seq.
class KillLoop {
  public:
    KillLoop(
        const Options& o, const std::vector<DeformOp>& ops, std::string secret, std::string token)
        : o_(o), ops_(ops), secret_(std::move(secret)), token_(std::move(token)), rng_(o.seed),
          kill_after_(o.kill_min, o.kill_max) {}

    /// Runs the loop from `run_start` (the run's clock, which goes on past the loop).
    void run(Clock::time_point run_start) {
        for (int n = 0; !failed_; ++n)
            if (!start(n, secondsSince(run_start) >= o_.seconds))
                break;
    }

    const std::vector<Restart>& restarts() const { return restarts_; }
    const std::map<std::uint64_t, std::size_t>& acked() const { return acked_; }
    std::size_t refused() const { return refused_; }
    std::uint64_t lost() const { return lost_; }
    bool failed() const { return failed_; }

  private:
    /// Start n: spawn, check its recovery, then (unless `last`) feed it until its kill; false
    /// once the loop ends.
    bool start(int n, bool last) {
        const fs::path port_file = fs::path(o_.out) / "port";
        const fs::path log = fs::path(o_.out) / ("server-" + std::to_string(n) + ".log");
        fs::remove(port_file);
        Restart r;
        const auto spawned = Clock::now();
        const pid_t pid = spawnServer(o_, secret_, port_file, log);
        const std::uint16_t port = awaitListening(port_file, spawned);
        if (port == 0) {
            std::fprintf(
                stderr, "recovery_bench: start %d did not listen; see %s\n", n, log.c_str());
            failed_ = true;
            ::kill(pid, SIGKILL);
            waitpid(pid, nullptr, 0);
            return false;
        }
        r.listen_s = secondsSince(spawned);
        r.recovery = readRecovery(log);
        checkRecovery(n, r.recovery);
        if (last) { // the final start: recovery checked above; a clean stop, then the journal
            ::kill(pid, SIGTERM);
            waitpid(pid, nullptr, 0);
            restarts_.push_back(r);
            return false;
        }
        const std::optional<Clock::time_point> serving = feedUntilKill(port, spawned, pid);
        if (!serving) {
            std::fprintf(stderr, "recovery_bench: start %d never acknowledged an op\n", n);
            failed_ = true;
        } else {
            r.serving_s = std::chrono::duration<double>(*serving - spawned).count();
            r.ran_s = secondsSince(*serving);
        }
        r.acked_before_kill = acked_.empty() ? 0 : acked_.rbegin()->first;
        restarts_.push_back(r);
        if (n > 0)
            std::printf(
                "restart %3d: listening %.3f s, serving %.3f s (snapshot %llu + %llu records, "
                "loaded in %.0f ms); killed %.1f s later at seq %llu\n",
                n, r.listen_s, r.serving_s, static_cast<unsigned long long>(r.recovery.snapshot),
                static_cast<unsigned long long>(r.recovery.replayed), r.recovery.loaded_ms, r.ran_s,
                static_cast<unsigned long long>(r.acked_before_kill));
        std::fflush(stdout);
        return true;
    }

    /// A recovery must resume at or after the last seq acknowledged before the kill.
    void checkRecovery(int n, const RecoveryLine& recovery) {
        const std::uint64_t acked_max_before = acked_.empty() ? 0 : acked_.rbegin()->first;
        if (n > 0 && recovery.seq < acked_max_before) {
            std::fprintf(
                stderr, "recovery_bench: LOST: start %d recovered seq %llu, %llu acknowledged\n", n,
                static_cast<unsigned long long>(recovery.seq),
                static_cast<unsigned long long>(acked_max_before));
            lost_ += acked_max_before - recovery.seq;
        }
    }

    /// Joins the server at `port` and sends ops at the rate until the kill moment (a random
    /// time after the first acknowledgement), kills it (-9) and takes the replies already on
    /// the wire; when the first op was acknowledged, if one was.
    std::optional<Clock::time_point>
    feedUntilKill(std::uint16_t port, Clock::time_point spawned, pid_t pid) {
        deformers_.push_back(std::make_unique<bench::LightDeformer>(
            io_, "127.0.0.1", port, token_, "recovery_bench", true));
        bench::LightDeformer& d = *deformers_.back();
        std::map<std::uint32_t, std::size_t> op_of_request;
        std::optional<Clock::time_point> serving;
        d.on_reply = [&](const terrain::client::DeformAnswer& a) {
            const auto it = op_of_request.find(a.request_id);
            if (it == op_of_request.end())
                return;
            if (a.accepted) {
                acked_[a.seq] = it->second;
                if (!serving)
                    serving = Clock::now();
            } else {
                ++refused_;
            }
            op_of_request.erase(it);
        };
        std::optional<Clock::time_point> kill_at;
        Clock::time_point paced_from{};
        std::size_t sent_here = 0;
        io_.restart(); // the last start's work ran out: the context stopped
        while (!d.failed()) {
            io_.run_for(std::chrono::microseconds(500));
            if (!d.joined()) {
                if (secondsSince(spawned) > 60.0)
                    break;
                continue;
            }
            if (sent_here == 0)
                paced_from = Clock::now();
            const auto due = static_cast<std::size_t>(secondsSince(paced_from) * o_.rate) + 1;
            while (sent_here < due && op_of_request.size() < 4096) {
                op_of_request[d.request(ops_[next_op_ % ops_.size()])] = next_op_ % ops_.size();
                ++next_op_;
                ++sent_here;
            }
            if (serving && !kill_at)
                kill_at = *serving + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(kill_after_(rng_)));
            if (kill_at && Clock::now() >= *kill_at)
                break;
        }
        ::kill(pid, SIGKILL);
        waitpid(pid, nullptr, 0);
        io_.restart();
        io_.run_for(std::chrono::milliseconds(20)); // replies already on the wire
        d.on_reply = nullptr;                       // it refers to this call's locals
        return serving;
    }

    const Options& o_;
    const std::vector<DeformOp>& ops_;
    std::string secret_;
    std::string token_;
    asio::io_context io_;
    std::mt19937_64 rng_;
    std::uniform_real_distribution<double> kill_after_;
    std::vector<Restart> restarts_;
    std::map<std::uint64_t, std::size_t> acked_; // seq -> index of the op sent
    std::size_t next_op_ = 0;
    std::size_t refused_ = 0;
    std::uint64_t lost_ = 0;
    bool failed_ = false;
    std::vector<std::unique_ptr<bench::LightDeformer>> deformers_; // kept: callbacks may be due
};

/// The journal must hold every acknowledged op still within its segments, at its seq; adds what
/// it lacks to `lost`. How many it checked; nullopt if it cannot be read.
std::optional<std::uint64_t> checkJournal(
    const fs::path& data_dir,
    const std::vector<DeformOp>& ops,
    const std::map<std::uint64_t, std::size_t>& acked,
    std::uint64_t& lost) {
    auto history = terrain::journal::readJournal(data_dir);
    if (!history) {
        std::fprintf(stderr, "recovery_bench: journal: %s\n", history.error().message.c_str());
        return std::nullopt;
    }
    std::uint64_t checked = 0;
    for (const terrain::journal::JournalRecord& rec : history->records) {
        const auto it = acked.find(rec.seq);
        if (it == acked.end())
            continue;
        ++checked;
        if (!(rec.op == ops[it->second])) {
            std::fprintf(
                stderr, "recovery_bench: seq %llu holds another op than was acknowledged\n",
                static_cast<unsigned long long>(rec.seq));
            ++lost;
        }
    }
    if (!acked.empty() && history->report.last_seq < acked.rbegin()->first)
        lost += acked.rbegin()->first - history->report.last_seq;
    return checked;
}

/// The restarts after a kill (the first start made the world): their times and what they
/// replayed.
struct RestartFigures {
    std::size_t restarts = 0;
    Summary listening;
    Summary serving;
    Summary loaded;
    Summary replayed;
};

RestartFigures restartFigures(const std::vector<Restart>& restarts) {
    std::vector<double> listen, serving, loaded, replayed;
    for (std::size_t i = 1; i < restarts.size(); ++i) {
        listen.push_back(restarts[i].listen_s);
        if (i + 1 < restarts.size() || restarts[i].serving_s > 0)
            serving.push_back(restarts[i].serving_s);
        loaded.push_back(restarts[i].recovery.loaded_ms / 1000.0);
        replayed.push_back(static_cast<double>(restarts[i].recovery.replayed));
    }
    if (!serving.empty() && restarts.back().serving_s == 0)
        serving.pop_back(); // the final start was stopped, not fed
    return {
        listen.size(), summarize(listen), summarize(serving), summarize(loaded),
        summarize(replayed)};
}

void writeJson(
    const std::string& path,
    const Options& o,
    const RestartFigures& f,
    double seconds,
    std::size_t acknowledged,
    std::size_t refused,
    std::uint64_t checked,
    std::uint64_t lost) {
    nlohmann::json j;
    j["restarts"] = f.restarts;
    j["seconds"] = seconds;
    j["rate"] = o.rate;
    j["server_args"] = o.server_args;
    const auto put = [&](const char* name, const Summary& s) {
        j[name] = {{"p50", s.p50}, {"p99", s.p99}, {"max", s.max}};
    };
    put("listening_s", f.listening);
    put("serving_s", f.serving);
    put("server_load_s", f.loaded);
    put("records_replayed", f.replayed);
    j["acknowledged"] = acknowledged;
    j["refused"] = refused;
    j["journal_checked"] = checked;
    j["lost"] = lost;
    std::ofstream(path) << j.dump(2) << "\n";
}

} // namespace

int main(int argc, char** argv) {
    Options o;
    if (const std::optional<int> stop = parseOptions(argc, argv, o))
        return *stop;
    const std::optional<std::vector<DeformOp>> ops = readOps(o.ops_path);
    if (!ops)
        return 2;
    fs::remove_all(o.out);
    fs::create_directories(o.out);
    const std::string secret = "recovery-bench-" + std::to_string(getpid());
    std::optional<std::string> token = deformerToken(secret);
    if (!token)
        return 2;

    KillLoop loop(o, *ops, secret, std::move(*token));
    const auto run_start = Clock::now();
    loop.run(run_start);
    std::uint64_t lost = loop.lost();
    const std::optional<std::uint64_t> checked =
        checkJournal(fs::path(o.out) / "data", *ops, loop.acked(), lost);
    const bool failed = loop.failed() || !checked;
    const RestartFigures f = restartFigures(loop.restarts());
    const double seconds = secondsSince(run_start); // the journal's check included, as before
    const std::size_t acknowledged = loop.acked().size();
    std::printf(
        "recovery_bench: %zu restarts in %.0f s; restart -> listening p50 %.3f, p99 %.3f, max "
        "%.3f s; -> first op acknowledged p50 %.3f, p99 %.3f, max %.3f s; server load p50 %.3f, "
        "max %.3f s; records replayed p50 %.0f, max %.0f; %zu ops acknowledged (%.0f ops/s), %zu "
        "refused, %llu in the journal checked, %llu LOST\n",
        f.restarts, seconds, f.listening.p50, f.listening.p99, f.listening.max, f.serving.p50,
        f.serving.p99, f.serving.max, f.loaded.p50, f.loaded.max, f.replayed.p50, f.replayed.max,
        acknowledged, static_cast<double>(acknowledged) / seconds, loop.refused(),
        static_cast<unsigned long long>(checked.value_or(0)),
        static_cast<unsigned long long>(lost));
    if (!o.json_path.empty())
        writeJson(
            o.json_path, o, f, seconds, acknowledged, loop.refused(), checked.value_or(0), lost);
    return failed || lost > 0 ? 1 : 0;
}
