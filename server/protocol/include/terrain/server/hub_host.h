#pragma once

// What the server hub asks of the edge it runs in: its own thread's queue, and two threads for
// the work that must not stall it. The Asio server gives it an io_context and two
// WorkerThreads; a simulation gives it a queue it runs when it chooses (tests, fuzzing).

#include <terrain/server/log_event.h>

#include <cstdint>
#include <functional>

namespace terrain::server {

class HubHost {
  public:
    /// Runs elsewhere; returns what then runs on the hub's thread.
    using Job = std::function<std::function<void()>()>;

    virtual ~HubHost() = default;
    /// Runs `fn` on the hub's thread after the handlers that are already ready (a group commit
    /// gathers the ops they accept).
    virtual void post(std::function<void()> fn) = 0;
    /// Runs `job` on the commit thread (write + fdatasync), jobs in order.
    virtual void runCommit(Job job) = 0;
    /// Runs `job` on the snapshot thread (join snapshots, journal snapshot files), in order.
    virtual void runSnapshot(Job job) = 0;
    /// The hub failed or is draining: accept no more connections.
    virtual void stopAccepting() = 0;
    /// Seconds since the Unix epoch (token expiry).
    virtual std::int64_t unixSeconds() const = 0;
    /// The server's log: joins, closes, failures.
    virtual void log(const LogEvent& event) = 0;
};

} // namespace terrain::server
