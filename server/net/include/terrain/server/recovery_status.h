#pragma once

// The probes while the journal recovers, before the Server exists: on the metrics port, GET
// /livez answers 200 (the process is working), /readyz 503 "recovering" (send no players yet),
// /metrics 503. A long journal takes seconds to replay; an orchestrator that probes then sees a
// live, unready server instead of a refused connection. Its own thread; stop() frees the port
// for the Server.

#include <terrain/result.h>

#include <cstdint>
#include <memory>
#include <string>

namespace terrain::server {

class RecoveryStatus {
  public:
    /// Binds address:port (0: an ephemeral port) and answers on its own thread.
    /// Errors: kIo naming the address and the OS error.
    static Result<std::unique_ptr<RecoveryStatus>>
    start(const std::string& address, std::uint16_t port);
    /// stop().
    ~RecoveryStatus();
    RecoveryStatus(const RecoveryStatus&) = delete;
    RecoveryStatus& operator=(const RecoveryStatus&) = delete;

    std::uint16_t port() const;
    /// Closes the port and joins the thread. Idempotent.
    void stop();

  private:
    struct Impl;
    explicit RecoveryStatus(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace terrain::server
