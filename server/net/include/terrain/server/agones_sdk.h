#pragma once

// The Agones SDK's lifecycle calls over its local HTTP gateway (the sidecar in the game server's
// pod, http://localhost:$AGONES_SDK_HTTP_PORT): POST /ready once the server serves, /health
// every interval while it is healthy, /shutdown after it drained. Plain HTTP/1.1 with a JSON
// empty message as every body, one connection per call, on the server's io thread. The sidecar
// may start after us: /ready is retried until it answers 200. No Agones library: the gateway is
// documented REST, and three calls do not need gRPC.

#include <terrain/server/log_event.h>

#include <asio.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace terrain::server {

class AgonesSdk {
  public:
    struct Options {
        std::string host = "127.0.0.1";
        std::uint16_t port = 9358; ///< Agones' default AGONES_SDK_HTTP_PORT
        /// Below the GameServer's health.periodSeconds (5 s in docker/agones), so one late ping
        /// is not a missed period.
        std::chrono::milliseconds health_every{2000};
        std::chrono::milliseconds ready_retry_every{1000};
        std::chrono::milliseconds call_timeout{2000};
    };

    /// `healthy` is asked before each ping: false (draining, journal failed) sends none, and
    /// Agones marks the server Unhealthy after its failure threshold.
    AgonesSdk(
        asio::io_context& io,
        Options options,
        std::function<bool()> healthy,
        std::shared_ptr<LogSink> log);
    ~AgonesSdk();
    AgonesSdk(const AgonesSdk&) = delete;
    AgonesSdk& operator=(const AgonesSdk&) = delete;

    /// Io thread: Ready (retried until acknowledged), then Health pings.
    void start();
    /// Io thread: stops the pings, calls Shutdown once (success or not), then `done`.
    void shutdown(std::function<void()> done);

    std::uint64_t healthPingsAcknowledged() const { return health_acks_; }
    bool readyAcknowledged() const { return ready_; }

  private:
    struct Call;
    /// POSTs "{}" to `path`; `then(ok)` with ok = the gateway answered 2xx within the timeout.
    void post(const std::string& path, std::function<void(bool ok)> then);
    void sendReady();
    void schedulePing();
    void log(LogLevel level, const std::string& event, const std::string& message);

    asio::io_context& io_;
    Options options_;
    std::function<bool()> healthy_;
    std::shared_ptr<LogSink> log_;
    asio::steady_timer timer_;
    bool ready_ = false;
    bool stopping_ = false;
    bool health_failing_ = false;
    std::uint64_t health_acks_ = 0;
    /// Outstanding calls see it expire when the SDK object goes, and stop there.
    std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
};

} // namespace terrain::server
