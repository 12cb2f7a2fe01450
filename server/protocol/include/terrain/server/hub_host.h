#pragma once

// What the server hub asks of the edge it runs in: its own thread's queue, and two threads for
// the work that must not stall it. The Asio server gives it an io_context and two
// WorkerThreads; a simulation gives it a queue it runs when it chooses (tests, fuzzing).

#include <terrain/server/log_event.h>

#include <cstdint>
#include <functional>

namespace terrain::server {

/// What the hub times with its host's clock and hands back, for the host's metrics.
enum class HubTiming : std::uint8_t {
    kApply,     ///< an accepted op's validation and apply to the authority's terrain
    kBroadcast, ///< a deform request's arrival to its op's broadcast (commit included)
    kJoin,      ///< a Hello to the join's frames queued (snapshot build waits included)
};

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
    /// Seconds on the monotonic clock the sessions' `now` comes from. A host without one (the
    /// simulation) keeps 0, and its timings mean nothing.
    virtual double monotonicSeconds() const { return 0.0; }
    /// A duration the hub measured (HubTiming).
    virtual void observe(HubTiming /*timing*/, double /*seconds*/) {}
};

} // namespace terrain::server
