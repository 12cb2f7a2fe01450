#pragma once

// The game client's network on a thread of its own (ClientOptions::network_thread): the
// connection, and the replica it checks every op against, live on that thread, so the link is
// read, answered and kept alive however long the game's frames take (a loading screen, a
// debugger stop), and a join's snapshot is decoded and every op applied and its hash checked
// off the frame thread. The frame thread's copy of the world follows the checked one by the
// tiles each change touched (ReplicaSync: no op is applied twice); requests are handed over
// without waiting.

#include <terrain/client/client_machine.h>
#include <terrain/client/replica.h>
#include <terrain/client/replica_sync.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace terrain::game::detail {

/// What the network thread has done since the frame thread last looked.
struct NetworkNews {
    /// What the network's replica changed (verified), in the order taken: the frame's copy
    /// follows each (Replica::follow).
    std::vector<client::ReplicaSync> syncs;
    std::vector<client::DeformAnswer> answers; ///< ids as requestDeform() returned them
    bool live = false;
    bool synced = false;         ///< the network's replica holds the server's state
    bool closed = false;         ///< the connection closed itself (a final refusal, a give up)
    std::string last_disconnect; ///< why the link was lost or closed ("" once live again)
    client::ReplicaStats stats;  ///< the network's replica's
    std::uint64_t seq = 0;       ///< the network's replica's
};

class NetworkThread {
  public:
    /// Starts the thread and the connection on it.
    explicit NetworkThread(client::ConnectionConfig config);
    /// stop().
    ~NetworkThread();
    NetworkThread(const NetworkThread&) = delete;
    NetworkThread& operator=(const NetworkThread&) = delete;

    /// Frame thread: what happened since the last call (taken under a lock held for a move).
    NetworkNews take();
    /// Frame thread: queues a deformation for the network thread and returns its id at once;
    /// the answer comes through take() (refused there, NOT_CONNECTED, if the link dropped before
    /// the network thread sent it; none, as with pump(), if it drops after).
    std::uint32_t requestDeform(const OpRequest& request);
    /// Closes the connection for good and joins the thread.
    void stop();
    /// Tests: makes the network thread throw `what` from inside its loop, as a bug or an
    /// allocation failure there would (the client must close by name, not end the process).
    void throwOnTheThreadForTesting(std::string what);

  private:
    struct State;
    std::unique_ptr<State> state_;
};

} // namespace terrain::game::detail
