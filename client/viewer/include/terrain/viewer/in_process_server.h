#pragma once

// A terrain server inside the viewer, for running without one: the same Authority and Server as
// terrain-server (no journal), on its own thread and io_context, listening on 127.0.0.1 at an
// ephemeral port. The viewer joins it over real TCP like any client, so what the viewer shows
// went through the whole protocol. The token secret is random per run; the viewer gets a
// deformer token minted with it.

#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <memory>
#include <string>

namespace terrain::viewer {

class InProcessServer {
  public:
    /// Takes the world and starts serving it. Errors: the server's (kIo: cannot bind).
    static Result<std::unique_ptr<InProcessServer>> start(Terrain terrain);
    /// Drains (sessions get their goodbye), stops the thread.
    ~InProcessServer();
    InProcessServer(const InProcessServer&) = delete;
    InProcessServer& operator=(const InProcessServer&) = delete;

    std::uint16_t port() const;
    /// A deformer token for this server, valid for a day.
    const std::string& deformerToken() const { return token_; }

    struct State {
        std::uint64_t seq = 0; ///< last op broadcast
        std::uint64_t world_hash = 0;
        std::uint64_t ops_accepted = 0;
        std::uint64_t ops_refused = 0;
    };
    /// The authority's state, read on the server's thread.
    State state();

  private:
    struct Impl;
    explicit InProcessServer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
    std::string token_;
};

} // namespace terrain::viewer
