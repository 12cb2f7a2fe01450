#pragma once

// An Authority and a Server on a thread and io_context of their own: the one in-process server
// that tests, benchmarks and the viewer start (terrain-server runs the same two on its main
// thread). call() runs a function on the server's thread and waits for its result; everything
// else about the server is read or changed that way.

#include <terrain/journal/journal.h>
#include <terrain/result.h>
#include <terrain/server/authority.h>
#include <terrain/server/server.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <vector>

namespace terrain::server {

struct ServerThreadOptions {
    TransportConfig transport; ///< 127.0.0.1, an ephemeral port, no metrics unless set
    ServerConfig config;
    std::uint64_t seq = 0;               ///< the terrain's seq (a recovered world's)
    journal::Journal* journal = nullptr; ///< null: ops are acknowledged without durability
    /// Runs on the authority before the server exists: ops applied there are the server's
    /// history, retained in its log (benchmarks grow worlds this way).
    std::function<void(Authority&)> prepare;
    /// Where the server logs; null: text lines on stdout (Server's default).
    std::shared_ptr<LogSink> log;
};

/// A token secret for an in-process server that no outside client joins (the viewer's, a
/// replay's): 32 bytes from the OS's entropy, unguessable for this run only.
std::vector<std::uint8_t> randomTokenSecret();

class ServerThread {
  public:
    /// Binds, then starts the thread. Errors: the server's (kIo: cannot listen).
    static Result<std::unique_ptr<ServerThread>>
    start(Terrain terrain, ServerThreadOptions options);
    /// stop().
    ~ServerThread();
    ServerThread(const ServerThread&) = delete;
    ServerThread& operator=(const ServerThread&) = delete;

    /// Drains (sessions get their goodbye; the journal its shutdown snapshot), waits for the
    /// sessions to close, at most `max_wait_seconds` (negative: the linger time and a second;
    /// tests whose clients are not reading pass a short wait), then joins the thread.
    /// Idempotent.
    void stop(double max_wait_seconds = -1.0);
    bool running() const;

    std::uint16_t port() const { return port_; }
    template <typename F> auto call(F f) -> decltype(f()) {
        std::packaged_task<decltype(f())()> task(std::move(f));
        auto result = task.get_future();
        post([&task] { task(); });
        return result.get();
    }
    std::uint64_t seq();       ///< last op broadcast
    std::uint64_t worldHash(); ///< the authority's (may be ahead of seq() by uncommitted ops)
    ServerStats stats();

    // on the server's thread only (inside call())
    Authority& authority();
    Server& server();

  private:
    struct Impl;
    explicit ServerThread(std::unique_ptr<Impl> impl);
    void post(std::function<void()> f);
    std::unique_ptr<Impl> impl_;
    std::uint16_t port_ = 0;
};

} // namespace terrain::server
