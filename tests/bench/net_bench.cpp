// Network benchmark: a real terrain::server::Server on its own io thread, clients (Replica +
// Connection) on one or more other threads, everything over loopback TCP. Measures
//   1. fan-out: one deformer + N-1 viewers; ops/s until every replica applied and verified the
//      last op, and latency from the deform request to "applied on all clients"; a paced run too;
//   2. wire bytes per crater op (Connection::stats().op_bytes_in), default map and SRTM;
//   3. join on srtm_n44w072 after 5 000 craters: snapshot size, build time, cold and warm joins;
//   4. memory: process RSS (server and clients share the process), terrain and replica sizes.
// Writes one JSON file (--out) and prints a short table. Timings are measured, never asserted.
// Exit status 1 when a replica ends different from the server or a phase hangs.

#include "support/bench_facts.h"
#include "support/loopback.h"

#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/io/dem_import.h>
#include <terrain/journal/journal.h>
#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/server/auth_token.h>
#include <terrain/server/authority.h>
#include <terrain/server/server.h>
#include <terrain/server/server_thread.h>
#include <terrain/wire/snapshot_stream.h>

#include <CLI/CLI.hpp>
#include <malloc.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <type_traits>
#include <unordered_map>
#include <vector>

#ifndef TERRAIN_DEM_DIR
#define TERRAIN_DEM_DIR "../shared/data/dem"
#endif

namespace {

using namespace terrain;
using bench::Clock;
using bench::cpuModel;
using bench::isoNow;
using bench::mib;
using bench::msSince;
using bench::summarize;
using bench::Summary;
using server::Role;

std::int64_t nowNs() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
        .count();
}
// ---------------------------------------------------------------------------------------------
// JSON output: nlohmann::ordered_json (keys keep insertion order) with two helpers

struct Json : nlohmann::ordered_json {
    using nlohmann::ordered_json::basic_json;
    Json(nlohmann::ordered_json j) : nlohmann::ordered_json(std::move(j)) {}
    static Json object() { return Json(nlohmann::ordered_json::object()); }
    static Json array() { return Json(nlohmann::ordered_json::array()); }
    template <typename T> Json& set(const std::string& key, T&& value) {
        (*this)[key] = plain(std::forward<T>(value));
        return *this;
    }
    template <typename T> Json& push(T&& value) {
        push_back(plain(std::forward<T>(value)));
        return *this;
    }

  private:
    // note: a Json must be passed on as its base, or nlohmann takes it for a string-like type
    template <typename T> static nlohmann::ordered_json plain(T&& value) {
        if constexpr (std::is_base_of_v<nlohmann::ordered_json, std::decay_t<T>>)
            return static_cast<const nlohmann::ordered_json&>(value);
        else
            return nlohmann::ordered_json(std::forward<T>(value));
    }
};

Json toJson(const Summary& s) {
    Json j = Json::object();
    j.set("samples", static_cast<std::uint64_t>(s.n));
    j.set("p50", s.p50).set("p99", s.p99).set("max", s.max).set("min", s.min).set("mean", s.mean);
    return j;
}

// ---------------------------------------------------------------------------------------------
// tokens and threads: tests/support/loopback.h (shared with the loopback tests)

using terrain::testing::IoThread;
using terrain::testing::token;

/// server::ServerThread with the test secret, exiting on a start failure, and the peak of the
/// bytes queued in all sessions at broadcasts. `prepare` runs on the authority before the server
/// exists (ops applied there are the server's history, retained in its log).
class ServerThread {
  public:
    ServerThread(
        Terrain terrain,
        server::ServerConfig config,
        const std::function<void(server::Authority&)>& prepare = {},
        journal::Journal* journal = nullptr) {
        config.token_secret = terrain::testing::testSecret();
        server::ServerThreadOptions options;
        options.config = std::move(config);
        options.journal = journal;
        options.prepare = prepare;
        auto started = server::ServerThread::start(std::move(terrain), std::move(options));
        if (!started) {
            std::fprintf(stderr, "net_bench: server start: %s\n", started.error().message.c_str());
            std::exit(2);
        }
        thread_ = std::move(*started);
        call([this] {
            thread_->server().on_broadcast = [this](std::uint64_t) {
                queued_peak_ = std::max(queued_peak_, thread_->server().queuedBytes());
            };
            return 0;
        });
    }
    void stop() { thread_->stop(); }
    template <typename F> auto call(F f) -> decltype(f()) { return thread_->call(std::move(f)); }
    std::uint16_t port() { return thread_->port(); }
    std::uint64_t seq() { return thread_->seq(); }
    std::uint64_t worldHash() { return thread_->worldHash(); }
    server::ServerStats stats() { return thread_->stats(); }
    std::size_t queuedBytes() {
        return call([this] { return thread_->server().queuedBytes(); });
    }
    std::size_t takeQueuedPeak() {
        return call([this] {
            const std::size_t p = queued_peak_;
            queued_peak_ = 0;
            return p;
        });
    }
    // server thread only
    server::Authority& authority() { return thread_->authority(); }
    server::Server& server() { return thread_->server(); }

  private:
    std::size_t queued_peak_ = 0; // server thread only
    std::unique_ptr<server::ServerThread> thread_;
};

/// Something that receives the op stream: a full client or a light viewer. Lives on (and is only
/// touched from) its IoThread, except the atomics.
struct Receiver {
    // per-phase record: time each seq in (base, base + size] was applied
    std::uint64_t base = 0;
    std::vector<std::int64_t> applied_ns;
    std::vector<std::uint32_t> op_frame_bytes; // per op, when recording bytes
    bool record_bytes = false;
    std::uint64_t last_op_bytes_in = 0;
    std::atomic<std::uint64_t> last_seq{0};
    std::atomic<std::int64_t> joined_ns{0}; // first snapshot loaded
    std::int64_t started_ns = 0;
    std::atomic<int> disconnects{0};

    virtual ~Receiver() = default;
    virtual std::uint64_t opBytesIn() const = 0;
    virtual std::uint64_t opsApplied() const = 0;
    /// Holds the server's state at seq (full client: replica; light viewer: last op's hash).
    virtual bool matches(std::uint64_t seq, std::uint64_t hash, std::string* why) const = 0;

    void onApplied(std::uint64_t seq) {
        const std::int64_t t = nowNs();
        if (joined_ns.load(std::memory_order_relaxed) == 0)
            joined_ns.store(t, std::memory_order_release);
        if (seq > base && seq - base <= applied_ns.size())
            applied_ns[seq - base - 1] = t;
        const std::uint64_t in = opBytesIn();
        if (record_bytes && in != last_op_bytes_in)
            op_frame_bytes.push_back(static_cast<std::uint32_t>(in - last_op_bytes_in));
        last_op_bytes_in = in;
        last_seq.store(seq, std::memory_order_release);
    }
    void resetRecord(std::uint64_t from_seq, std::size_t count, bool bytes) {
        base = from_seq;
        applied_ns.assign(count, 0);
        op_frame_bytes.clear();
        record_bytes = bytes;
        last_op_bytes_in = opBytesIn();
    }
};

/// A full client: Replica + Connection, every op applied and its hash verified.
struct BenchClient final : Receiver {
    client::Replica replica;
    std::shared_ptr<client::Connection> connection;
    std::function<void(const client::DeformAnswer&)> on_reply;

    BenchClient(asio::io_context& io, std::uint16_t port, std::string tok) {
        client::ConnectionConfig config;
        config.port = port;
        config.token = std::move(tok);
        config.reconnect = true;
        config.reconnect_delay_seconds = 0.05;
        connection = std::make_shared<client::Connection>(io, config, replica);
        connection->on_applied = [this](std::uint64_t seq) { onApplied(seq); };
        connection->on_deform_reply = [this](const client::DeformAnswer& a) {
            if (on_reply)
                on_reply(a);
        };
        connection->on_disconnect = [this](const std::string& why) {
            ++disconnects;
            std::fprintf(
                stderr, "net_bench: client %" PRIu64 " disconnected: %s\n", connection->playerId(),
                why.c_str());
        };
        started_ns = nowNs();
        connection->start();
    }
    ~BenchClient() override { connection->stop(); }
    std::uint64_t opBytesIn() const override { return connection->stats().op_bytes_in; }
    std::uint64_t opsApplied() const override { return replica.stats().ops_applied; }
    bool matches(std::uint64_t seq, std::uint64_t hash, std::string* why) const override {
        const bool ok = replica.ready() && replica.seq() == seq && replica.worldHash() == hash &&
                        !replica.diverged();
        if (!ok && why) {
            char buf[200];
            std::snprintf(
                buf, sizeof buf,
                "player %" PRIu64 ": ready %d seq %" PRIu64 " hash %016" PRIx64 " diverged %d",
                connection->playerId(), replica.ready() ? 1 : 0, replica.seq(), replica.worldHash(),
                replica.diverged() ? 1 : 0);
            *why = buf;
        }
        return ok;
    }
};

/// A light viewer: a raw socket that says Hello, takes the snapshot frames without decoding them
/// and decodes each OpApplied envelope (seq + hash), applying nothing. Stands in for a remote
/// client with its own CPU, so the fan-out measures the server and the network, not 64 replicas
/// sharing this machine's cores.
struct LightViewer final : Receiver {
    asio::ip::tcp::socket socket;
    wire::FrameReader reader{std::size_t{32} << 20};
    std::vector<std::uint8_t> hello;
    std::uint64_t op_bytes_in = 0;
    std::uint64_t ops = 0;
    std::uint64_t gaps = 0;
    std::uint64_t last_hash = 0;
    std::uint64_t snapshot_seq = 0;
    std::uint64_t snapshot_hash = 0;
    std::uint32_t chunk_count = 0;
    bool live = false;
    std::string closed;

    LightViewer(asio::io_context& io, std::uint16_t port, const std::string& tok) : socket(io) {
        wire::pb::Envelope e;
        e.mutable_hello()->set_protocol_version(wire::kProtocolVersion);
        e.mutable_hello()->set_token(tok);
        e.mutable_hello()->set_client_name("net_bench light viewer");
        wire::appendFrame(e, hello);
        started_ns = nowNs();
        socket.async_connect(
            {asio::ip::make_address("127.0.0.1"), port}, [this](const asio::error_code& ec) {
                if (ec == asio::error::operation_aborted)
                    return;
                if (ec) {
                    fail("connect: " + ec.message());
                    return;
                }
                asio::error_code ignored;
                socket.set_option(asio::ip::tcp::no_delay(true), ignored);
                asio::async_write(
                    socket, asio::buffer(hello), [this](const asio::error_code& wec, std::size_t) {
                        if (wec && wec != asio::error::operation_aborted)
                            fail("write: " + wec.message());
                    });
                read();
            });
    }
    ~LightViewer() override {
        asio::error_code ignored;
        socket.close(ignored);
    }
    void fail(const std::string& why) {
        if (!closed.empty())
            return;
        closed = why;
        ++disconnects;
        std::fprintf(stderr, "net_bench: light viewer: %s\n", why.c_str());
    }
    void read() {
        std::span<std::uint8_t> space = reader.prepare(64 << 10);
        socket.async_read_some(
            asio::buffer(space.data(), space.size()),
            [this](const asio::error_code& ec, std::size_t n) {
                if (ec == asio::error::operation_aborted)
                    return;
                if (ec) {
                    fail("read: " + ec.message());
                    return;
                }
                reader.commit(n);
                for (;;) {
                    auto next = reader.next();
                    if (!next) {
                        fail("bad frame: " + next.error().message);
                        return;
                    }
                    if (!next->has_value())
                        break;
                    const std::size_t frame_bytes =
                        (*next)->size() + wire::framePrefixSize((*next)->size());
                    auto env = wire::decodeEnvelope(**next);
                    if (!env) {
                        fail("bad envelope: " + env.error().message);
                        return;
                    }
                    handle(*env, frame_bytes);
                }
                read();
            });
    }
    void handle(const wire::pb::Envelope& e, std::size_t frame_bytes) {
        if (e.has_op_applied()) {
            op_bytes_in += frame_bytes;
            if (!live)
                return;
            const std::uint64_t seq =
                wire::appliedSeq(e.op_applied(), last_seq.load(std::memory_order_relaxed));
            if (seq != last_seq.load(std::memory_order_relaxed) + 1)
                ++gaps;
            ++ops;
            last_hash = e.op_applied().world_hash();
            onApplied(seq);
        } else if (e.has_snapshot_begin()) {
            snapshot_seq = e.snapshot_begin().seq();
            snapshot_hash = e.snapshot_begin().world_hash();
            chunk_count = e.snapshot_begin().chunk_count();
        } else if (e.has_snapshot_chunk()) {
            if (e.snapshot_chunk().index() + 1 == chunk_count) {
                live = true;
                last_hash = snapshot_hash;
                onApplied(snapshot_seq);
            }
        } else if (e.has_disconnect()) {
            fail(wire::describe(e.disconnect().reason(), e.disconnect().message()));
        }
    }
    std::uint64_t opBytesIn() const override { return op_bytes_in; }
    std::uint64_t opsApplied() const override { return ops; }
    bool matches(std::uint64_t seq, std::uint64_t hash, std::string* why) const override {
        const bool ok =
            live && last_seq.load() == seq && last_hash == hash && gaps == 0 && closed.empty();
        if (!ok && why)
            *why = "light viewer: live " + std::to_string(live) + " seq " +
                   std::to_string(last_seq.load()) + " gaps " + std::to_string(gaps) + " " + closed;
        return ok;
    }
};

/// Receivers spread round-robin over `threads` io threads; receiver 0 (the deformer) is on
/// thread 0.
class ClientPool {
  public:
    explicit ClientPool(int threads) {
        for (int i = 0; i < threads; ++i)
            threads_.push_back(std::make_unique<IoThread>());
    }
    ~ClientPool() { clear(); }
    void clear() {
        for (std::size_t i = 0; i < clients_.size(); ++i)
            if (clients_[i])
                threadOf(i).call([&] {
                    clients_[i].reset();
                    return 0;
                });
        clients_.clear();
        // let the io threads run the handlers cancelled by stop()
        for (auto& t : threads_)
            t->call([] { return 0; });
    }
    BenchClient& add(std::uint16_t port, std::string tok) {
        const std::size_t i = clients_.size();
        clients_.emplace_back();
        IoThread& t = threadOf(i);
        BenchClient* c = nullptr;
        t.call([&] {
            auto made = std::make_unique<BenchClient>(t.io(), port, std::move(tok));
            c = made.get();
            clients_[i] = std::move(made);
            return 0;
        });
        return *c;
    }
    void addLight(std::uint16_t port, const std::string& tok) {
        const std::size_t i = clients_.size();
        clients_.emplace_back();
        IoThread& t = threadOf(i);
        t.call([&] {
            clients_[i] = std::make_unique<LightViewer>(t.io(), port, tok);
            return 0;
        });
    }
    std::size_t size() const { return clients_.size(); }
    Receiver& operator[](std::size_t i) { return *clients_[i]; }
    BenchClient& client(std::size_t i) { return dynamic_cast<BenchClient&>(*clients_[i]); }
    IoThread& threadOf(std::size_t i) { return *threads_[i % threads_.size()]; }
    /// Runs f(receiver) on each receiver's thread.
    template <typename F> void forEach(F f) {
        for (std::size_t i = 0; i < clients_.size(); ++i)
            if (clients_[i])
                threadOf(i).call([&] {
                    f(*clients_[i]);
                    return 0;
                });
    }

  private:
    std::vector<std::unique_ptr<IoThread>> threads_;
    std::vector<std::unique_ptr<Receiver>> clients_;
};

bool waitFor(const std::function<bool()>& done, double timeout_seconds) {
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(timeout_seconds));
    while (!done()) {
        if (Clock::now() > deadline)
            return false;
        std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    return true;
}

// ---------------------------------------------------------------------------------------------
// checks

struct Verification {
    bool all_match = true;
    std::uint64_t server_seq = 0;
    std::uint64_t server_hash = 0;
    int clients_differing = 0;
    std::uint64_t hash_mismatches = 0; // replica stats, summed
    std::uint64_t repair_requests = 0;
    std::uint64_t extra_snapshots = 0; // beyond the join snapshot: resyncs
    std::uint64_t disconnects = 0;
    std::uint64_t stale_ops = 0;
    std::uint64_t full_clients = 0; // with a replica (the rest are light viewers: seq + hash only)
    std::vector<std::string> notes;
};

Verification verify(ServerThread& srv, ClientPool& pool) {
    Verification v;
    v.server_seq = srv.seq();
    v.server_hash = srv.worldHash();
    pool.forEach([&](Receiver& r) {
        std::string why;
        if (!r.matches(v.server_seq, v.server_hash, &why)) {
            ++v.clients_differing;
            v.notes.push_back(why);
        }
        v.disconnects += static_cast<std::uint64_t>(r.disconnects.load());
        auto* c = dynamic_cast<BenchClient*>(&r);
        if (!c)
            return;
        ++v.full_clients;
        v.hash_mismatches += c->replica.stats().hash_mismatches;
        v.stale_ops += c->replica.stats().ops_stale;
        v.repair_requests += c->connection->stats().repair_requests;
        v.extra_snapshots +=
            c->connection->stats().snapshots > 0 ? c->connection->stats().snapshots - 1 : 0;
    });
    v.all_match = v.clients_differing == 0;
    return v;
}

Json toJson(const Verification& v) {
    Json j = Json::object();
    j.set("all_replicas_match_server", v.all_match);
    j.set("clients_differing", v.clients_differing);
    j.set("clients_with_replica", v.full_clients);
    j.set("hash_mismatches", v.hash_mismatches);
    j.set("repair_requests", v.repair_requests);
    j.set("resync_snapshots", v.extra_snapshots);
    j.set("disconnects", v.disconnects);
    j.set("server_seq", v.server_seq);
    char hex[20];
    std::snprintf(hex, sizeof hex, "%016" PRIx64, v.server_hash);
    j.set("server_world_hash", std::string(hex));
    return j;
}

// ---------------------------------------------------------------------------------------------
// the deformer

std::vector<OpRequest> grenadeCraters(const WorldSpec& spec, int count, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const double margin = 20.0;
    std::uniform_real_distribution<double> px(margin, spec.extentX() - margin);
    std::uniform_real_distribution<double> py(margin, spec.extentY() - margin);
    std::uniform_real_distribution<double> radius(1.0, 8.0);
    std::uniform_real_distribution<double> depth(0.3, 2.0);
    std::vector<OpRequest> ops;
    for (int i = 0; i < count; ++i) {
        OpRequest r;
        r.kind = OpKind::kCrater;
        r.x = px(rng);
        r.y = py(rng);
        r.radius = radius(rng);
        r.height = std::min(r.radius, depth(rng)); // at most as deep as wide
        r.strength = 0.25;                         // rim ratio
        ops.push_back(r);
    }
    return ops;
}

/// Sends ops from client 0, either keeping `window` requests outstanding or at a fixed rate.
/// Everything runs on client 0's thread; the main thread only reads `answered` and the results
/// after it reached the count.
struct DeformRun {
    std::vector<OpRequest> ops;
    std::size_t window = 32;
    double rate = 0.0; // > 0: paced, ops per second
    std::size_t next = 0;
    std::vector<std::int64_t> send_ns;
    std::vector<std::uint64_t> seq; // 0: refused or not answered
    std::unordered_map<std::uint32_t, std::size_t> index_of_id;
    std::atomic<std::size_t> answered{0};
    std::size_t refused = 0;
    std::string first_refusal;
    std::int64_t last_reply_ns = 0;
    std::unique_ptr<asio::steady_timer> timer;
    Clock::time_point paced_start;

    void sendOne(BenchClient& c) {
        const std::size_t i = next++;
        send_ns[i] = nowNs();
        index_of_id[c.connection->requestDeform(ops[i])] = i;
    }
    void onReply(BenchClient& c, const client::DeformAnswer& a) {
        const auto it = index_of_id.find(a.request_id);
        if (it == index_of_id.end())
            return;
        if (a.accepted)
            seq[it->second] = a.seq;
        else if (refused++ == 0)
            first_refusal = a.reason;
        last_reply_ns = nowNs();
        if (rate <= 0.0 && next < ops.size())
            sendOne(c);
        answered.fetch_add(1, std::memory_order_release);
    }
    void tick(BenchClient& c) {
        // send every op whose time has come, then sleep until the next one
        const double elapsed = std::chrono::duration<double>(Clock::now() - paced_start).count();
        while (next < ops.size() && static_cast<double>(next) / rate <= elapsed)
            sendOne(c);
        if (next >= ops.size())
            return;
        timer->expires_at(
            paced_start + std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double>(static_cast<double>(next) / rate)));
        timer->async_wait([this, &c](const asio::error_code& ec) {
            if (!ec)
                tick(c);
        });
    }
    void start(BenchClient& c, asio::io_context& io) {
        send_ns.assign(ops.size(), 0);
        seq.assign(ops.size(), 0);
        c.on_reply = [this, &c](const client::DeformAnswer& a) { onReply(c, a); };
        if (rate > 0.0) {
            timer = std::make_unique<asio::steady_timer>(io);
            paced_start = Clock::now();
            tick(c);
        } else {
            while (next < ops.size() && next < window)
                sendOne(c);
        }
    }
};

struct FanoutResult {
    bool completed = false;
    std::string failure;
    std::size_t ops = 0;
    std::size_t accepted = 0;
    std::size_t refused = 0;
    std::string first_refusal;
    double seconds = 0.0;            // first send -> last op applied on every client
    double accept_seconds = 0.0;     // first send -> last reply
    Summary latency_ms;              // send -> applied on all clients
    Summary first_client_ms;         // send -> applied on the first client (usually the deformer)
    std::size_t latency_missing = 0; // ops some client never reported applying
    std::vector<std::uint32_t> frame_bytes; // client 1's per-op OpApplied frame bytes
    std::uint64_t op_bytes_in_total = 0;    // over all clients
    std::uint64_t ops_applied_total = 0;
    std::size_t queued_peak = 0;
    Verification check;
};

FanoutResult runDeform(
    ServerThread& srv,
    ClientPool& pool,
    std::vector<OpRequest> ops,
    std::size_t window,
    double rate,
    double timeout_seconds) {
    FanoutResult r;
    r.ops = ops.size();
    const std::uint64_t base = srv.seq();
    srv.takeQueuedPeak();
    std::vector<std::uint64_t> bytes_before(pool.size()), applied_before(pool.size());
    for (std::size_t i = 0; i < pool.size(); ++i)
        pool.threadOf(i).call([&] {
            pool[i].resetRecord(base, ops.size(), i == 1 || pool.size() == 1);
            bytes_before[i] = pool[i].opBytesIn();
            applied_before[i] = pool[i].opsApplied();
            return 0;
        });
    DeformRun run;
    run.ops = std::move(ops);
    run.window = window;
    run.rate = rate;
    BenchClient& deformer = pool.client(0);
    IoThread& t0 = pool.threadOf(0);
    t0.call([&] {
        run.start(deformer, t0.io());
        return 0;
    });
    const std::size_t n = run.ops.size();
    bool ok =
        waitFor([&] { return run.answered.load(std::memory_order_acquire) == n; }, timeout_seconds);
    std::uint64_t final_seq = 0;
    if (!ok) {
        r.failure = "deform replies: " + std::to_string(run.answered.load()) + " of " +
                    std::to_string(n) + " within " + std::to_string(timeout_seconds) + " s";
    } else {
        final_seq = srv.seq();
        ok = waitFor(
            [&] {
                for (std::size_t i = 0; i < pool.size(); ++i)
                    if (pool[i].last_seq.load(std::memory_order_acquire) < final_seq)
                        return false;
                return true;
            },
            timeout_seconds);
        if (!ok)
            r.failure = "not every replica reached seq " + std::to_string(final_seq) + " within " +
                        std::to_string(timeout_seconds) + " s";
    }
    r.completed = ok;
    // collect on the client threads (they own the records)
    t0.call([&] {
        if (run.timer)
            run.timer->cancel();
        deformer.on_reply = nullptr;
        return 0;
    });
    r.refused = run.refused;
    r.first_refusal = run.first_refusal;
    std::vector<std::int64_t> all_ns(n, 0), first_ns(n, std::numeric_limits<std::int64_t>::max());
    std::vector<bool> missing(n, false);
    std::int64_t last_applied = 0;
    for (std::size_t i = 0; i < pool.size(); ++i)
        pool.threadOf(i).call([&] {
            Receiver& c = pool[i];
            for (std::size_t k = 0; k < n; ++k) {
                const std::uint64_t s = run.seq[k];
                if (s == 0)
                    continue;
                const std::int64_t t =
                    s > base && s - base <= c.applied_ns.size() ? c.applied_ns[s - base - 1] : 0;
                if (t == 0) {
                    missing[k] = true;
                    continue;
                }
                all_ns[k] = std::max(all_ns[k], t);
                first_ns[k] = std::min(first_ns[k], t);
                last_applied = std::max(last_applied, t);
            }
            if (c.record_bytes)
                r.frame_bytes = c.op_frame_bytes;
            r.op_bytes_in_total += c.opBytesIn() - bytes_before[i];
            r.ops_applied_total += c.opsApplied() - applied_before[i];
            c.record_bytes = false;
            return 0;
        });
    std::vector<double> lat, first;
    std::int64_t first_send = std::numeric_limits<std::int64_t>::max();
    for (std::size_t k = 0; k < n; ++k) {
        if (run.send_ns[k] != 0)
            first_send = std::min(first_send, run.send_ns[k]);
        if (run.seq[k] == 0)
            continue;
        ++r.accepted;
        if (missing[k]) {
            ++r.latency_missing;
            continue;
        }
        lat.push_back(static_cast<double>(all_ns[k] - run.send_ns[k]) * 1e-6);
        first.push_back(static_cast<double>(first_ns[k] - run.send_ns[k]) * 1e-6);
    }
    r.latency_ms = summarize(lat);
    r.first_client_ms = summarize(first);
    if (first_send != std::numeric_limits<std::int64_t>::max()) {
        r.seconds = static_cast<double>(last_applied - first_send) * 1e-9;
        r.accept_seconds = static_cast<double>(run.last_reply_ns - first_send) * 1e-9;
    }
    r.queued_peak = srv.takeQueuedPeak();
    r.check = verify(srv, pool);
    return r;
}

Json fanoutJson(const FanoutResult& r, std::size_t clients, std::size_t window, double rate) {
    Json j = Json::object();
    j.set("clients", static_cast<std::uint64_t>(clients));
    if (rate > 0.0)
        j.set("rate_per_second", rate);
    else
        j.set("window", static_cast<std::uint64_t>(window));
    j.set("completed", r.completed);
    if (!r.failure.empty())
        j.set("failure", r.failure);
    j.set("ops_sent", static_cast<std::uint64_t>(r.ops));
    j.set("ops_accepted", static_cast<std::uint64_t>(r.accepted));
    j.set("ops_refused", static_cast<std::uint64_t>(r.refused));
    if (!r.first_refusal.empty())
        j.set("first_refusal", r.first_refusal);
    j.set("seconds", r.seconds);
    j.set(
        "ops_per_second_fanned_out",
        r.seconds > 0 ? static_cast<double>(r.accepted) / r.seconds : 0.0);
    j.set(
        "ops_per_second_accepted",
        r.accept_seconds > 0 ? static_cast<double>(r.accepted) / r.accept_seconds : 0.0);
    j.set("latency_all_clients_ms", toJson(r.latency_ms));
    j.set("latency_first_client_ms", toJson(r.first_client_ms));
    j.set("latency_missing_ops", static_cast<std::uint64_t>(r.latency_missing));
    j.set("server_queued_bytes_peak", static_cast<std::uint64_t>(r.queued_peak));
    j.set("verification", toJson(r.check));
    return j;
}

Json bytesJson(const FanoutResult& r, Summary* out) {
    std::vector<double> b(r.frame_bytes.begin(), r.frame_bytes.end());
    const Summary s = summarize(b);
    if (out)
        *out = s;
    Json j = Json::object();
    j.set("ops", static_cast<std::uint64_t>(s.n));
    j.set("median", s.p50).set("min", s.min).set("max", s.max).set("mean", s.mean);
    j.set("all_clients_op_bytes_in", r.op_bytes_in_total);
    j.set("all_clients_ops_applied", r.ops_applied_total);
    j.set(
        "all_clients_mean", r.ops_applied_total ? static_cast<double>(r.op_bytes_in_total) /
                                                      static_cast<double>(r.ops_applied_total)
                                                : 0.0);
    return j;
}

// waits until every client has joined (has its Welcome and state), tracking the server's queued
// bytes meanwhile
bool allJoined(ServerThread& srv, ClientPool& pool, std::size_t& queued_peak) {
    return waitFor(
        [&] {
            queued_peak = std::max(queued_peak, srv.queuedBytes());
            for (std::size_t i = 0; i < pool.size(); ++i)
                if (pool[i].joined_ns.load(std::memory_order_acquire) == 0)
                    return false;
            return true;
        },
        120.0);
}

// waits for every client to hold `seq` with the server's hash
bool allSynced(ServerThread& srv, ClientPool& pool, double timeout_seconds) {
    const std::uint64_t seq = srv.seq();
    const std::uint64_t hash = srv.worldHash();
    return waitFor(
        [&] {
            for (std::size_t i = 0; i < pool.size(); ++i)
                if (pool[i].joined_ns.load(std::memory_order_acquire) == 0 ||
                    pool[i].last_seq.load(std::memory_order_acquire) < seq)
                    return false;
            bool ok = true;
            pool.forEach([&](Receiver& r) { ok = ok && r.matches(seq, hash, nullptr); });
            return ok;
        },
        timeout_seconds);
}

// A fresh viewer joins by snapshot on its own io_context and thread (not one of the pool's
// clients, whose records a run owns); returns the time to a loaded replica (ms), or -1.
double joinFresh(std::uint16_t port, std::uint64_t player) {
    asio::io_context io;
    client::Replica replica;
    client::ConnectionConfig config;
    config.port = port;
    config.token = token(player, server::Role::kViewer);
    config.reconnect = false;
    auto connection = std::make_shared<client::Connection>(io, config, replica);
    const auto start = Clock::now();
    connection->start();
    while (!replica.ready() && msSince(start) < 30000.0)
        io.run_for(std::chrono::milliseconds(2));
    const double ms = replica.ready() ? msSince(start) : -1.0;
    connection->stop();
    io.run_for(std::chrono::milliseconds(1));
    return ms;
}

server::ServerConfig benchConfig() {
    server::ServerConfig c;
    c.deform_rate_per_second = 1e6;
    c.deform_burst = 1e6;
    return c;
}

void printLatency(const char* name, const FanoutResult& r) {
    std::printf(
        "%-28s %8.1f ops/s  all-clients latency p50 %7.2f  p99 %7.2f  max %7.2f ms  "
        "(%zu/%zu ops, missing %zu)\n",
        name, r.seconds > 0 ? static_cast<double>(r.accepted) / r.seconds : 0.0, r.latency_ms.p50,
        r.latency_ms.p99, r.latency_ms.max, r.accepted, r.ops, r.latency_missing);
}

/// The command line.
struct BenchOptions {
    std::string out_path = "out/bench/net_bench.json";
    int clients = 64;
    int ops = 500;
    int light_ops = 2000;
    int window = 32;
    int client_threads = 2;
    double paced_rate = 60.0;
    double paced_seconds = 5.0;
    int join_craters = 5000;
    int warm_joins = 5;
    int srtm_ops = 300;
    double load_rate = 40.0;
    double load_seconds = 6.0;
    bool quick = false;
    std::string dem_dir = TERRAIN_DEM_DIR;
    double sync_delay_ms = 0.0;
    /// Ops in each paced run.
    int pacedOps() const { return static_cast<int>(paced_rate * paced_seconds + 0.5); }
};

/// What the phases found: the JSON report and the closing table's figures.
struct BenchReport {
    Clock::time_point start = Clock::now();
    Json root = Json::object();
    Json memory = Json::object();
    Json wire_bytes = Json::object();
    std::size_t rss_start = 0;
    Summary default_bytes;
    Summary srtm_bytes;
    double cold_ms = 0.0;
    double warm_ms = 0.0;
    double build_ms = 0.0;
    std::uint64_t snap_raw = 0;
    std::uint64_t snap_wire = 0;
    bool failed = false;
};

/// The command line into `o`; an exit code when the program should stop (help, a bad option).
std::optional<int> parseOptions(int argc, char** argv, BenchOptions& o) {
    CLI::App app{"net_bench: server fan-out, wire bytes, joins and memory over loopback TCP"};
    app.add_option("--out", o.out_path, "JSON output path");
    auto* clients_opt =
        app.add_option("--clients", o.clients, "clients in the fan-out (1 deformer + viewers)")
            ->check(CLI::Range(2, 1000));
    auto* ops_opt =
        app.add_option("--ops", o.ops, "deform ops in the windowed fan-out run to full clients")
            ->check(CLI::Range(1, 1000000));
    auto* light_ops_opt = app.add_option(
                                 "--light-ops", o.light_ops,
                                 "deform ops in the windowed fan-out run to light viewers")
                              ->check(CLI::Range(1, 1000000));
    app.add_option("--window", o.window, "outstanding deform requests")->check(CLI::Range(1, 4096));
    app.add_option(
           "--sync-delay-ms", o.sync_delay_ms,
           "journaled runs: sleep this long before each fdatasync (a slower disk than this one)")
        ->check(CLI::Range(0.0, 1000.0));
    app.add_option("--client-threads", o.client_threads, "io threads the clients are spread over")
        ->check(CLI::Range(1, 64));
    app.add_option("--paced-rate", o.paced_rate, "ops per second of the paced run")
        ->check(CLI::PositiveNumber);
    auto* paced_opt = app.add_option("--paced-seconds", o.paced_seconds, "length of the paced run")
                          ->check(CLI::NonNegativeNumber);
    app.add_option("--join-craters", o.join_craters, "craters applied to the SRTM map before joins")
        ->check(CLI::Range(0, 1000000));
    app.add_option("--srtm-ops", o.srtm_ops, "crater ops in the SRTM wire-bytes run")
        ->check(CLI::Range(1, 1000000));
    app.add_option("--dem-dir", o.dem_dir, "folder holding srtm_n44w072/");
    app.add_option(
           "--join-load-rate", o.load_rate,
           "ops per second of the SRTM paced runs with and without a join every second")
        ->check(CLI::PositiveNumber);
    auto* load_seconds_opt =
        app.add_option("--join-load-seconds", o.load_seconds, "length of each of those runs")
            ->check(CLI::PositiveNumber);
    app.add_flag(
        "--quick", o.quick,
        "smoke test: 16 clients, 100 ops (300 light), 2 s paced runs, 100 SRTM ops");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    if (o.quick) {
        if (clients_opt->count() == 0)
            o.clients = 16;
        if (ops_opt->count() == 0)
            o.ops = 100;
        if (light_ops_opt->count() == 0)
            o.light_ops = 300;
        if (paced_opt->count() == 0)
            o.paced_seconds = 2.0;
        o.srtm_ops = std::min(o.srtm_ops, 100);
        if (load_seconds_opt->count() == 0)
            o.load_seconds = 3.0;
    }

    return std::nullopt;
}

/// The report's head: the machine and the settings.
void startReport(const BenchOptions& o, BenchReport& report) {
    report.root.set("bench", "net_bench");
    report.root.set("date", isoNow());
    {
        Json machine = Json::object();
        machine.set("cpu", cpuModel());
        machine.set(
            "hardware_threads", static_cast<std::uint64_t>(std::thread::hardware_concurrency()));
        report.root.set("machine", std::move(machine));
        Json cfg = Json::object();
        cfg.set("quick", o.quick);
        cfg.set("clients", o.clients);
        cfg.set("ops", o.ops);
        cfg.set("light_ops", o.light_ops);
        cfg.set("window", o.window);
        cfg.set("client_threads", o.client_threads);
        cfg.set("paced_rate", o.paced_rate);
        cfg.set("paced_seconds", o.paced_seconds);
        cfg.set("join_craters", o.join_craters);
        cfg.set("warm_joins", o.warm_joins);
        cfg.set("srtm_ops", o.srtm_ops);
        cfg.set("join_load_rate", o.load_rate);
        cfg.set("join_load_seconds", o.load_seconds);
        cfg.set("threads", "server: 1 io thread; clients: client_threads io threads; same process");
        report.root.set("config", std::move(cfg));
    }

    std::printf(
        "net_bench: %d clients (%d threads), %d ops to full clients, %d to light viewers, "
        "window %d\n",
        o.clients, o.client_threads, o.ops, o.light_ops, o.window);
    report.rss_start = bench::residentBytes();
}

/// 1a: fan-out to light viewers (the server's side of it).
void lightFanout(const BenchOptions& o, BenchReport& report) {
    Terrain map = std::move(*makeProceduralMap(ProceduralMapOptions{}));
    const WorldSpec spec = map.spec();
    malloc_trim(0);
    ServerThread srv(std::move(map), benchConfig());
    const std::size_t rss_server = bench::residentBytes();
    ClientPool pool(o.client_threads);
    const std::uint16_t port = srv.port();
    const auto connect_start = Clock::now();
    std::size_t queued_peak_connect = 0;
    pool.add(port, token(100, Role::kDeformer));
    for (int i = 1; i < o.clients; ++i)
        pool.addLight(port, token(static_cast<std::uint64_t>(100 + i), Role::kViewer));
    const bool joined = allJoined(srv, pool, queued_peak_connect);
    const double connect_ms = msSince(connect_start);
    if (!joined || !allSynced(srv, pool, 30.0)) {
        std::fprintf(stderr, "net_bench: FAIL: not every light viewer joined\n");
        report.failed = true;
    }
    const std::size_t rss_clients = bench::residentBytes();
    FanoutResult fan = runDeform(
        srv, pool, grenadeCraters(spec, o.light_ops, 11), static_cast<std::size_t>(o.window), 0.0,
        120.0);
    printLatency("light fan-out (windowed)", fan);
    FanoutResult paced;
    if (o.pacedOps() > 0) {
        paced = runDeform(srv, pool, grenadeCraters(spec, o.pacedOps(), 12), 0, o.paced_rate, 60.0);
        printLatency("light fan-out (paced)", paced);
    }
    for (const FanoutResult* r : {&fan, &paced})
        if (r->ops > 0 && (!r->completed || !r->check.all_match)) {
            std::fprintf(
                stderr, "net_bench: FAIL light fan-out: %s; %d receivers differ\n",
                r->failure.c_str(), r->check.clients_differing);
            for (const auto& n : r->check.notes)
                std::fprintf(stderr, "  %s\n", n.c_str());
            report.failed = true;
        }
    Json f = fanoutJson(fan, pool.size(), static_cast<std::size_t>(o.window), 0.0);
    f.set(
        "receivers", "1 full client (the deformer, with a replica) + light viewers (raw socket, "
                     "decode each OpApplied, check seq order and the last hash; apply nothing)");
    f.set("join_all_ms", connect_ms);
    f.set("server_queued_bytes_peak_join", static_cast<std::uint64_t>(queued_peak_connect));
    f.set("rss_server_only_bytes", static_cast<std::uint64_t>(rss_server));
    f.set("rss_with_light_viewers_bytes", static_cast<std::uint64_t>(rss_clients));
    report.root.set("fanout_light", std::move(f));
    if (o.pacedOps() > 0) {
        Json p = fanoutJson(paced, pool.size(), 0, o.paced_rate);
        p.set("duration_s", o.paced_seconds);
        report.root.set("fanout_light_paced", std::move(p));
    }
    pool.clear();
    srv.stop();
}

/// 1c: the same light fan-out with the journal on (group commit), each durability.
void journaledFanout(const BenchOptions& o, BenchReport& report) {
    Json durability_json = Json::object();
    struct JournalRun {
        journal::Durability d;
        bool pipelined;
    };
    for (const JournalRun run :
         {JournalRun{journal::Durability::kWrite, true},
          JournalRun{journal::Durability::kFsync, true},
          JournalRun{journal::Durability::kFsync, false}}) {
        const journal::Durability d = run.d;
        const std::string key =
            std::string(journal::toString(d)) + (run.pipelined ? "" : "_synchronous");
        const std::filesystem::path dir =
            std::filesystem::temp_directory_path() /
            ("net_bench_journal_" + key + "_" + std::to_string(::getpid()));
        std::filesystem::remove_all(dir);
        Terrain map = std::move(*makeProceduralMap(ProceduralMapOptions{}));
        const WorldSpec spec = map.spec();
        journal::JournalOptions jo{d, 2};
        if (o.sync_delay_ms > 0.0) // a slower disk than this one
            jo.before_sync = [ms = o.sync_delay_ms] {
                std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(ms));
            };
        auto opened = journal::Journal::open(dir, jo);
        if (!opened || !opened->initialize(map, 0)) {
            std::fprintf(stderr, "net_bench: cannot open a journal in %s\n", dir.c_str());
            report.failed = true;
            continue;
        }
        journal::Journal j = std::move(*opened);
        server::ServerConfig jconfig = benchConfig();
        jconfig.pipeline_commits = run.pipelined;
        ServerThread srv(std::move(map), jconfig, {}, &j);
        ClientPool pool(o.client_threads);
        pool.add(srv.port(), token(300, Role::kDeformer));
        for (int i = 1; i < o.clients; ++i)
            pool.addLight(srv.port(), token(static_cast<std::uint64_t>(300 + i), Role::kViewer));
        if (!allSynced(srv, pool, 120.0)) {
            std::fprintf(stderr, "net_bench: FAIL: journaled run did not join\n");
            report.failed = true;
        }
        const std::string name = "journal " + key;
        FanoutResult fan = runDeform(
            srv, pool, grenadeCraters(spec, o.light_ops / 2, 21),
            static_cast<std::size_t>(o.window), 0.0, 120.0);
        printLatency((name + " (windowed)").c_str(), fan);
        FanoutResult paced;
        if (o.pacedOps() > 0) {
            paced =
                runDeform(srv, pool, grenadeCraters(spec, o.pacedOps(), 22), 0, o.paced_rate, 60.0);
            printLatency((name + " (paced)").c_str(), paced);
        }
        for (const FanoutResult* r : {&fan, &paced})
            if (r->ops > 0 && (!r->completed || !r->check.all_match)) {
                std::fprintf(stderr, "net_bench: FAIL %s: %s\n", name.c_str(), r->failure.c_str());
                report.failed = true;
            }
        Json one = Json::object();
        one.set("windowed", fanoutJson(fan, pool.size(), static_cast<std::size_t>(o.window), 0.0));
        if (o.pacedOps() > 0)
            one.set("paced", fanoutJson(paced, pool.size(), 0, o.paced_rate));
        pool.clear();
        srv.stop();
        one.set("commits", static_cast<std::uint64_t>(j.stats().commits));
        one.set("fsyncs", static_cast<std::uint64_t>(j.stats().fsyncs));
        one.set("records", static_cast<std::uint64_t>(j.stats().records_written));
        one.set("pipelined_commits", run.pipelined);
        one.set("sync_delay_ms_added", o.sync_delay_ms);
        durability_json.set(key, std::move(one));
        std::filesystem::remove_all(dir);
    }
    report.root.set("fanout_light_journaled", std::move(durability_json));
}

/// 1b, 2, 4: fan-out to full clients, bytes per op, memory.
void fullFanout(const BenchOptions& o, BenchReport& report) {
    const auto gen_start = Clock::now();
    Terrain map = std::move(*makeProceduralMap(ProceduralMapOptions{}));
    const double gen_ms = msSince(gen_start);
    const WorldSpec spec = map.spec();
    malloc_trim(0);
    const std::size_t rss_map = bench::residentBytes();
    ServerThread srv(std::move(map), benchConfig());
    const std::size_t rss_server = bench::residentBytes();
    const std::size_t terrain_bytes_before =
        srv.call([&] { return srv.authority().terrain().memoryUsage().total(); });

    ClientPool pool(o.client_threads);
    const std::uint16_t port = srv.port();
    const auto connect_start = Clock::now();
    std::size_t queued_peak_connect = 0;
    for (int i = 0; i < o.clients; ++i)
        pool.add(
            port,
            token(static_cast<std::uint64_t>(100 + i), i == 0 ? Role::kDeformer : Role::kViewer));
    const bool joined = allJoined(srv, pool, queued_peak_connect);
    const double connect_ms = msSince(connect_start);
    if (!joined || !allSynced(srv, pool, 30.0)) {
        std::fprintf(stderr, "net_bench: FAIL: not every client joined the default map\n");
        report.failed = true;
    }
    std::vector<double> join_ms;
    for (std::size_t i = 0; i < pool.size(); ++i)
        join_ms.push_back(
            static_cast<double>(pool[i].joined_ns.load() - pool[i].started_ns) * 1e-6);
    const Summary joins = summarize(join_ms);
    const std::size_t rss_clients = bench::residentBytes();
    std::size_t replica_bytes = 0;
    pool.forEach([&](Receiver& r) {
        if (auto* c = dynamic_cast<BenchClient*>(&r); c && c->replica.ready())
            replica_bytes += c->replica.terrain().memoryUsage().total();
    });
    const std::size_t snapshot_cache_bytes = srv.call([&] {
        // the cached join snapshot the server holds (built on the first join)
        return wire::buildSnapshotFrames(srv.authority().terrain(), srv.server().broadcastSeq())
            .totalBytes();
    });
    std::printf(
        "joined %d clients on %dx%d in %.0f ms (per client p50 %.0f ms, max %.0f ms)\n", o.clients,
        spec.width, spec.height, connect_ms, joins.p50, joins.max);

    // 1. windowed fan-out
    FanoutResult fan = runDeform(
        srv, pool, grenadeCraters(spec, o.ops, 1), static_cast<std::size_t>(o.window), 0.0, 120.0);
    printLatency("full fan-out (windowed)", fan);
    if (!fan.completed || !fan.check.all_match || fan.check.hash_mismatches != 0) {
        std::fprintf(
            stderr, "net_bench: FAIL fan-out: %s; %d clients differ, %" PRIu64 " hash mismatches\n",
            fan.failure.c_str(), fan.check.clients_differing, fan.check.hash_mismatches);
        for (const auto& n : fan.check.notes)
            std::fprintf(stderr, "  %s\n", n.c_str());
        report.failed = true;
    }
    const std::size_t rss_after_ops = bench::residentBytes();
    const std::size_t terrain_bytes_after =
        srv.call([&] { return srv.authority().terrain().memoryUsage().total(); });

    // paced run
    FanoutResult paced;
    if (o.pacedOps() > 0) {
        paced = runDeform(srv, pool, grenadeCraters(spec, o.pacedOps(), 2), 0, o.paced_rate, 60.0);
        printLatency("full fan-out (paced)", paced);
        if (!paced.completed || !paced.check.all_match || paced.check.hash_mismatches != 0) {
            std::fprintf(stderr, "net_bench: FAIL paced: %s\n", paced.failure.c_str());
            report.failed = true;
        }
    }

    Json f = fanoutJson(fan, pool.size(), static_cast<std::size_t>(o.window), 0.0);
    {
        Json m = Json::object();
        m.set("size", std::to_string(spec.width) + "x" + std::to_string(spec.height));
        m.set("spacing_m", spec.spacingMetres());
        m.set("generate_ms", gen_ms);
        f.set("map", std::move(m));
        Json c = Json::object();
        c.set("radius_m", "1-8").set("depth_m", "0.3-2").set("rim_ratio", 0.25);
        f.set("craters", std::move(c));
        Json j = Json::object();
        j.set("all_clients_ms", connect_ms);
        j.set("per_client_ms", toJson(joins));
        j.set("server_queued_bytes_peak", static_cast<std::uint64_t>(queued_peak_connect));
        f.set("initial_join", std::move(j));
    }
    report.root.set("fanout", std::move(f));
    if (o.pacedOps() > 0) {
        Json p = fanoutJson(paced, pool.size(), 0, o.paced_rate);
        p.set("duration_s", o.paced_seconds);
        report.root.set("fanout_paced", std::move(p));
    }
    Json d = bytesJson(fan, &report.default_bytes);
    d.set("map", "procedural 1025x1025, 1 m; craters R 1-8 m");
    d.set(
        "note", "OpApplied frames as received by one viewer: varint prefix + Envelope (seq, "
                "op, world hash)");
    report.wire_bytes.set("default_1m", std::move(d));

    report.memory.set("rss_start_bytes", static_cast<std::uint64_t>(report.rss_start));
    report.memory.set("rss_after_map_bytes", static_cast<std::uint64_t>(rss_map));
    report.memory.set("rss_server_only_bytes", static_cast<std::uint64_t>(rss_server));
    report.memory.set("rss_with_clients_bytes", static_cast<std::uint64_t>(rss_clients));
    report.memory.set("rss_after_fanout_bytes", static_cast<std::uint64_t>(rss_after_ops));
    report.memory.set(
        "rss_clients_delta_bytes", static_cast<std::uint64_t>(rss_clients - rss_server));
    report.memory.set("clients", o.clients);
    report.memory.set(
        "rss_per_client_bytes",
        static_cast<double>(rss_clients - rss_server) / static_cast<double>(o.clients));
    report.memory.set("replicas_terrain_bytes", static_cast<std::uint64_t>(replica_bytes));
    report.memory.set(
        "server_terrain_bytes_before_ops", static_cast<std::uint64_t>(terrain_bytes_before));
    report.memory.set(
        "server_terrain_bytes_after_ops", static_cast<std::uint64_t>(terrain_bytes_after));
    report.memory.set(
        "server_join_snapshot_frames_bytes", static_cast<std::uint64_t>(snapshot_cache_bytes));
    report.memory.set(
        "server_queued_bytes_peak_join", static_cast<std::uint64_t>(queued_peak_connect));
    report.memory.set(
        "server_queued_bytes_peak_fanout", static_cast<std::uint64_t>(fan.queued_peak));
    report.memory.set(
        "note",
        "server and clients share one process: rss_server_only is map + server before any "
        "client; rss_clients_delta is the 64 replicas, their connections and the server's "
        "sessions and snapshot cache together; replicas_terrain_bytes is Terrain::memoryUsage "
        "summed over replicas");
    std::printf(
        "memory: RSS %.1f MiB server-only, %.1f MiB with %d clients (+%.2f MiB/client); "
        "terrain %.1f MiB -> %.1f MiB after ops; replicas %.1f MiB total; queued peak "
        "%.2f MiB (join) %.3f MiB (ops)\n",
        mib(rss_server), mib(rss_clients), o.clients, mib(rss_clients - rss_server) / o.clients,
        mib(terrain_bytes_before), mib(terrain_bytes_after), mib(replica_bytes),
        mib(queued_peak_connect), mib(fan.queued_peak));
    pool.clear();
    srv.stop();
    report.root.set("memory", std::move(report.memory));
}

/// 3: joins on SRTM (and its bytes per op), and joins under load; 2 if the DEM cannot be read.
int srtmJoins(const BenchOptions& o, BenchReport& report) {
    const std::filesystem::path dem_json =
        std::filesystem::path(o.dem_dir) / "srtm_n44w072" / "srtm_n44w072.json";
    Json join = Json::object();
    Json srtm_fanout = Json::object();
    bool has_srtm_fanout = false;
    double copy_ms = 0.0;
    if (!std::filesystem::exists(dem_json)) {
        const std::string why =
            "skipped: " + dem_json.string() + " not found (../shared/data/dem absent)";
        std::printf("join: %s\n", why.c_str());
        join.set("skipped", why);
    } else {
        auto dem = io::importDem(dem_json, {});
        if (!dem) {
            std::fprintf(
                stderr, "net_bench: cannot import %s: %s\n", dem_json.c_str(),
                dem.error().message.c_str());
            return 2;
        }
        const WorldSpec spec = dem->terrain.spec();
        CraterSeries series;
        series.seed = 7;
        series.count = o.join_craters;
        series.min_radius = 50.0;
        series.max_radius = 400.0;
        const std::vector<OpRequest> history = randomCraters(spec, series);
        std::size_t history_refused = 0;
        double history_ms = 0.0;
        server::ServerConfig config = benchConfig();
        // the join cache at most a second of the loaded run's ops old: each join a second there
        // needs a snapshot of its own (or one rebuilt ahead of it)
        config.snapshot_cache_max_lag = static_cast<std::uint64_t>(o.load_rate);
        ServerThread srv(std::move(dem->terrain), config, [&](server::Authority& a) {
            const auto start = Clock::now();
            for (const OpRequest& r : history)
                if (!a.apply(r))
                    ++history_refused;
            history_ms = msSince(start);
        });
        const std::uint64_t seq = srv.seq();
        const std::uint64_t hash = srv.worldHash();
        const std::size_t patches =
            srv.call([&] { return srv.authority().terrain().patchCount(); });
        const std::size_t terrain_bytes =
            srv.call([&] { return srv.authority().terrain().memoryUsage().total(); });
        // snapshot build alone (the function the server calls on a cold join), median of 3
        std::vector<double> builds;
        wire::SnapshotFrames frames;
        for (int i = 0; i < 3; ++i)
            srv.call([&] {
                const auto start = Clock::now();
                frames = wire::buildSnapshotFrames(
                    srv.authority().terrain(), seq, config.snapshot_chunk_bytes);
                builds.push_back(msSince(start));
                return 0;
            });
        report.build_ms = summarize(builds).p50;
        // what the io thread itself pays for a build since snapshots are built on their own
        // thread: a copy of the terrain (freed on that thread), median of 3
        std::vector<double> copies;
        for (int i = 0; i < 3; ++i) {
            std::optional<Terrain> copy;
            srv.call([&] {
                const auto start = Clock::now();
                copy.emplace(srv.authority().terrain());
                copies.push_back(msSince(start));
                return 0;
            });
        }
        copy_ms = summarize(copies).p50;
        report.snap_raw = frames.raw_bytes;
        report.snap_wire = frames.totalBytes();

        ClientPool pool(1);
        const std::uint16_t port = srv.port();
        auto joinOnce = [&](std::uint64_t player, Role role, double* ms) {
            BenchClient& c = pool.add(port, token(player, role));
            const bool ok =
                waitFor([&] { return c.joined_ns.load(std::memory_order_acquire) != 0; }, 60.0);
            bool verified = false;
            pool.threadOf(pool.size() - 1).call([&] {
                verified =
                    c.replica.ready() && c.replica.seq() == seq && c.replica.worldHash() == hash;
                return 0;
            });
            *ms = static_cast<double>(c.joined_ns.load() - c.started_ns) * 1e-6;
            return ok && verified;
        };
        const std::uint64_t built_before = srv.stats().snapshots_built;
        bool joins_ok = joinOnce(1, Role::kDeformer, &report.cold_ms);
        const std::uint64_t built_cold = srv.stats().snapshots_built;
        std::vector<double> warm;
        for (int i = 0; i < o.warm_joins; ++i) {
            double ms = 0.0;
            joins_ok = joinOnce(static_cast<std::uint64_t>(2 + i), Role::kViewer, &ms) && joins_ok;
            warm.push_back(ms);
        }
        const std::uint64_t built_warm = srv.stats().snapshots_built;
        const Summary warm_s = summarize(warm);
        report.warm_ms = warm_s.p50;
        std::uint64_t client_snapshot_bytes = 0;
        pool.threadOf(0).call([&] {
            client_snapshot_bytes = pool.client(0).connection->stats().snapshot_bytes;
            return 0;
        });
        if (!joins_ok) {
            std::fprintf(
                stderr,
                "net_bench: FAIL: an SRTM join did not reach seq %" PRIu64
                " with the server hash\n",
                seq);
            report.failed = true;
        }
        std::printf(
            "srtm %dx%d, %.1f m, %zu craters (%zu refused, %.0f ms), %zu patches: snapshot "
            "%.1f MB raw -> %.1f MB wire, build %.0f ms (io thread's share: a %.0f ms copy); join "
            "cold %.0f ms, warm p50 %.0f ms\n",
            spec.width, spec.height, spec.spacingMetres(), history.size(), history_refused,
            history_ms, patches, static_cast<double>(report.snap_raw) * 1e-6,
            static_cast<double>(report.snap_wire) * 1e-6, report.build_ms, copy_ms, report.cold_ms,
            report.warm_ms);

        join.set("map", "srtm_n44w072");
        join.set("size", std::to_string(spec.width) + "x" + std::to_string(spec.height));
        join.set("spacing_m", spec.spacingMetres());
        join.set("craters_applied", static_cast<std::uint64_t>(history.size() - history_refused));
        join.set("craters_refused", static_cast<std::uint64_t>(history_refused));
        join.set("crater_radius_m", "50-400");
        join.set("history_apply_ms", history_ms);
        join.set("seq", seq);
        join.set("patches", static_cast<std::uint64_t>(patches));
        join.set("terrain_bytes", static_cast<std::uint64_t>(terrain_bytes));
        join.set("snapshot_raw_bytes", report.snap_raw);
        join.set("snapshot_compressed_bytes", frames.compressed_bytes);
        join.set("snapshot_wire_bytes", report.snap_wire);
        join.set("snapshot_frames", static_cast<std::uint64_t>(frames.frames.size()));
        join.set("client_snapshot_bytes_received", client_snapshot_bytes);
        join.set("snapshot_build_ms_median_of_3", report.build_ms);
        join.set("terrain_copy_ms_median_of_3", copy_ms);
        join.set("join_cold_ms", report.cold_ms);
        join.set("join_warm_ms", toJson(warm_s));
        join.set("warm_joins", o.warm_joins);
        join.set("snapshots_built_cold", built_cold - built_before);
        join.set("snapshots_built_warm", built_warm - built_cold);
        join.set("joins_verified", joins_ok);
        join.set(
            "note",
            "join = Connection::start() to the replica holding the snapshot at the server's seq "
            "with its hash (loopback; client decode + validation + rehash included); "
            "cold builds the server's snapshot cache, warm reuses it");

        // SRTM bytes per op: the joined clients watch a short windowed run
        if (joins_ok) {
            FanoutResult s = runDeform(
                srv, pool,
                randomCraters(
                    spec,
                    [&] {
                        CraterSeries c = series;
                        c.seed = 8;
                        c.count = o.srtm_ops;
                        return c;
                    }()),
                static_cast<std::size_t>(o.window), 0.0, 120.0);
            printLatency("srtm fan-out (windowed)", s);
            if (!s.completed || !s.check.all_match || s.check.hash_mismatches != 0) {
                std::fprintf(stderr, "net_bench: FAIL srtm fan-out: %s\n", s.failure.c_str());
                report.failed = true;
            }
            Json b = bytesJson(s, &report.srtm_bytes);
            b.set("map", "srtm_n44w072 1201x1201, 66 m; craters R 50-400 m");
            report.wire_bytes.set("srtm_66m", std::move(b));
            srtm_fanout = fanoutJson(s, pool.size(), static_cast<std::size_t>(o.window), 0.0);
            has_srtm_fanout = true;
        }
        // joins under load: a paced run alone, then the same with a fresh viewer joining by
        // snapshot every second; what a join costs every other session (request -> applied on
        // all of the pool's clients)
        if (joins_ok) {
            const auto loadOps = [&](std::uint64_t seed) {
                CraterSeries c = series;
                c.seed = seed;
                c.count = static_cast<int>(o.load_rate * o.load_seconds + 0.5);
                return randomCraters(spec, c);
            };
            const FanoutResult quiet = runDeform(
                srv, pool, loadOps(9), static_cast<std::size_t>(o.window), o.load_rate, 120.0);
            std::atomic<bool> stop_joins{false};
            std::vector<double> join_times;
            std::thread joiner([&] {
                for (std::uint64_t player = 500; !stop_joins.load(); ++player) {
                    const auto next = Clock::now() + std::chrono::seconds(1);
                    join_times.push_back(joinFresh(port, player));
                    std::this_thread::sleep_until(next);
                }
            });
            const FanoutResult loaded = runDeform(
                srv, pool, loadOps(10), static_cast<std::size_t>(o.window), o.load_rate, 120.0);
            stop_joins = true;
            joiner.join();
            printLatency("srtm paced, no joins", quiet);
            printLatency("srtm paced, a join a second", loaded);
            const Summary joins = summarize(join_times);
            std::printf(
                "  %zu joins during the loaded run: p50 %.0f ms, max %.0f ms; p99 ratio %.2fx\n",
                join_times.size(), joins.p50, joins.max,
                quiet.latency_ms.p99 > 0 ? loaded.latency_ms.p99 / quiet.latency_ms.p99 : 0.0);
            for (const FanoutResult* r : {&quiet, &loaded})
                if (!r->completed || !r->check.all_match || r->check.hash_mismatches != 0) {
                    std::fprintf(
                        stderr, "net_bench: FAIL srtm joins under load: %s\n", r->failure.c_str());
                    report.failed = true;
                }
            Json load = Json::object();
            load.set("rate_per_second", o.load_rate);
            load.set("seconds", o.load_seconds);
            load.set("clients", static_cast<std::uint64_t>(pool.size()));
            load.set("no_joins_latency_ms", toJson(quiet.latency_ms));
            load.set("joins_latency_ms", toJson(loaded.latency_ms));
            load.set("join_ms", toJson(joins));
            load.set(
                "p99_ratio",
                quiet.latency_ms.p99 > 0 ? loaded.latency_ms.p99 / quiet.latency_ms.p99 : 0.0);
            load.set(
                "note", "request -> applied on every pool client, paced; a fresh viewer joins by "
                        "snapshot every second during the second run; the join cache is kept at "
                        "most rate ops old");
            join.set("joins_under_load", std::move(load));
        }
        pool.clear();
        srv.stop();
    }
    report.root.set("wire_bytes_per_op", std::move(report.wire_bytes));
    report.root.set("join_srtm", std::move(join));
    if (has_srtm_fanout)
        report.root.set("srtm_fanout", std::move(srtm_fanout));
    return 0;
}

/// The closing table and the JSON file; the exit code.
int writeReport(const BenchOptions& o, BenchReport& report) {
    report.root.set("total_seconds", msSince(report.start) * 1e-3);
    report.root.set("ok", !report.failed);

    std::printf("\n%-34s %s\n", "what", "value");
    std::printf(
        "%-34s %.0f B median (min %.0f, max %.0f)\n", "wire bytes/op, 1 m map",
        report.default_bytes.p50, report.default_bytes.min, report.default_bytes.max);
    if (report.srtm_bytes.n)
        std::printf(
            "%-34s %.0f B median (min %.0f, max %.0f)\n", "wire bytes/op, srtm",
            report.srtm_bytes.p50, report.srtm_bytes.min, report.srtm_bytes.max);
    if (report.snap_raw)
        std::printf(
            "%-34s %.1f MB raw, %.1f MB wire, build %.0f ms, join cold %.0f / warm %.0f ms\n",
            "srtm snapshot + join", static_cast<double>(report.snap_raw) * 1e-6,
            static_cast<double>(report.snap_wire) * 1e-6, report.build_ms, report.cold_ms,
            report.warm_ms);
    std::printf("%-34s %.1f s\n", "total", msSince(report.start) * 1e-3);

    std::error_code ec;
    const std::filesystem::path out(o.out_path);
    if (out.has_parent_path())
        std::filesystem::create_directories(out.parent_path(), ec);
    std::ofstream file(o.out_path);
    file << report.root.dump(2) << "\n";
    if (!file) {
        std::fprintf(stderr, "net_bench: cannot write %s\n", o.out_path.c_str());
        return 2;
    }
    std::printf("wrote %s%s\n", o.out_path.c_str(), report.failed ? " (with FAILURES)" : "");
    return report.failed ? 1 : 0;
}

} // namespace

int main(int argc, char** argv) {
    BenchOptions o;
    if (const std::optional<int> stop = parseOptions(argc, argv, o))
        return *stop;
    BenchReport report;
    startReport(o, report);
    // each phase's server and clients are gone before the next: their memory goes back first
    lightFanout(o, report);
    malloc_trim(0);
    journaledFanout(o, report);
    malloc_trim(0);
    fullFanout(o, report);
    if (const int code = srtmJoins(o, report); code != 0)
        return code;
    return writeReport(o, report);
}
