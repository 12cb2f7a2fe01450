#pragma once

// The network edge of the authority: an Asio acceptor and one Session shell per TCP connection
// around the protocol (ServerHub, SessionMachine), all on one io_context thread (single-threaded
// by contract, ARCHITECTURE.md), with two worker threads for group commits and snapshots.

#include <terrain/journal/journal.h>
#include <terrain/server/authority.h>
#include <terrain/server/log_writer.h>
#include <terrain/server/server_hub.h>
#include <terrain/server/transport_config.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/snapshot_stream.h>

#include <array>
#include <asio.hpp>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace terrain::server {

class WorkerThread;
class ServerMetrics;
class StatusHttp;
struct HttpResponse;

/// What the start-up recovery did, for the metrics (terrain_recovery_*).
struct RecoveryReport {
    double seconds = 0.0;           ///< journal open to state rebuilt (snapshot load + replay)
    std::uint64_t snapshot_seq = 0; ///< the snapshot it started from
    std::uint64_t replayed_records = 0;
};

class Server : private HubHost {
  public:
    /// Listens as `transport` says and runs the protocol as `config` says. `journal` may be null
    /// (tests, benchmarks): ops are then acknowledged without durability.
    Server(
        asio::io_context& io,
        TransportConfig transport,
        ServerConfig config,
        Authority& authority,
        journal::Journal* journal);
    ~Server() override;
    Server(const Server&) = delete;
    Server& operator=(const Server&) = delete;

    /// Binds and starts accepting. Errors: kIo naming the address and the OS error.
    Status start();
    std::uint16_t port() const { return port_; }
    /// The probes' and metrics' HTTP port (TransportConfig::metrics_port), 0 when off.
    std::uint16_t metricsPort() const;

    /// Drains: stops accepting, commits pending ops, writes a journal snapshot, says goodbye to
    /// every session and calls `done` once they are closed (or after the linger time).
    void shutdown(std::function<void()> done);

    /// Set when the journal failed: the server stops serving and the process must exit non-zero.
    bool failed() const { return hub_.failed(); }
    /// True from shutdown() on: readiness is false, new connections are refused.
    bool draining() const { return hub_.shuttingDown(); }
    const std::string& failure() const { return hub_.failure(); }

    const ServerStats& stats() const { return hub_.stats(); }
    std::size_t sessionCount() const { return hub_.sessionCount(); }
    std::uint64_t broadcastSeq() const { return hub_.broadcastSeq(); }
    /// The world hash after op broadcastSeq() (ServerHub::broadcastHash).
    std::uint64_t broadcastHash() const { return hub_.broadcastHash(); }
    std::uint64_t genesisHash() const { return hub_.genesisHash(); }
    /// ServerHub::resumeWindow.
    std::uint64_t resumeWindow() const { return hub_.resumeWindow(); }
    std::size_t queuedBytes() const { return hub_.queuedBytes(); }
    /// Called on the io thread whenever a batch of ops has been broadcast (benchmarks, logs).
    std::function<void(std::uint64_t seq)> on_broadcast;
    ServerHub& hub() { return hub_; }
    /// Published as terrain_recovery_seconds, _replayed_records and _snapshot_seq.
    void setRecoveryReport(const RecoveryReport& report);
    /// Where the server logs (default: text lines on stdout). Set before start().
    void setLog(std::shared_ptr<LogSink> log) { log_ = std::move(log); }

  private:
    void post(std::function<void()> fn) override;
    void runCommit(Job job) override;
    void runSnapshot(Job job) override;
    void stopAccepting() override;
    std::int64_t unixSeconds() const override;
    void log(const LogEvent& event) override;
    double monotonicSeconds() const override;
    void observe(HubTiming timing, double seconds) override;

    void accept();
    void scheduleAccept();
    HttpResponse statusPage(std::string_view path);

    asio::io_context& io_;
    asio::ip::tcp::acceptor acceptor_;
    std::uint16_t port_ = 0;
    std::shared_ptr<LogSink> log_;
    // the workers' jobs record into the metrics, which outlive them
    std::unique_ptr<ServerMetrics> metrics_;
    std::unique_ptr<StatusHttp> status_http_;
    // the workers outlive the hub: a job in progress holds none of its state
    std::unique_ptr<WorkerThread> snapshot_worker_;
    std::unique_ptr<WorkerThread> commit_worker_;
    TransportConfig transport_;
    ServerHub hub_;
    asio::steady_timer shutdown_timer_;
    asio::steady_timer accept_retry_timer_;
};

} // namespace terrain::server
