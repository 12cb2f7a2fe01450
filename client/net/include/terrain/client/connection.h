#pragma once

// The client's link to a terrain server: the Asio shell of a ClientMachine (which joins,
// applies and checks ops, repairs and falls back to snapshots). The shell resolves, connects,
// reads into the machine, writes what it queues, and reconnects with the last verified seq.
// Runs on the caller's io_context (a game calls io.poll() once per frame); single-threaded:
// every callback runs on that thread.

#include <terrain/client/client_machine.h>

#include <asio.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace terrain::client {

class Connection : public std::enable_shared_from_this<Connection> {
  public:
    enum class State { kIdle, kConnecting, kJoining, kLive, kWaiting, kClosed };

    Connection(asio::io_context& io, ConnectionConfig config, Replica& replica);
    ~Connection();

    /// Starts connecting (asynchronous). Call once.
    void start();
    /// Closes for good: no reconnect.
    void stop();
    /// Drops the TCP connection as if the network failed (tests); reconnects if configured.
    void dropForTesting();

    State state() const;
    /// True when the replica holds the server's state at the last broadcast it received.
    bool synced() const { return state_ == Link::kLinked && machine_.synced(); }

    /// Paced: applies this frame's share of the ops waiting (OpPacer); returns how many.
    /// Call once per frame, after polling the io_context.
    std::size_t applyArrived();
    /// Applies every op waiting (a loop that is not drawing frames, or before a measurement).
    std::size_t applyAllArrived();
    /// Ops received and not applied yet (always 0 unpaced).
    std::size_t opsWaiting() const { return machine_.opsWaiting(); }

    /// Requests return their id, or 0 when nothing was sent because no link is up (connecting,
    /// waiting to reconnect, closed): lastRefusal() says why. The answers come through the
    /// callbacks below; a request sent and then lost with its link gets none.
    std::uint32_t requestDeform(const OpRequest& request);
    std::uint32_t requestDeform(const DeformOp& op);
    std::uint32_t queryHeight(double x, double y);
    std::uint32_t castRay(const double origin[3], const double direction[3], double max_distance);
    void ping();

    std::function<void(const DeformAnswer&)> on_deform_reply;
    std::function<void(const HeightAnswer&)> on_height_reply;
    std::function<void(const RayAnswer&)> on_ray_reply;
    /// After each op applied (seq), and after each snapshot (seq of the snapshot).
    std::function<void(std::uint64_t seq)> on_applied;
    /// The server said goodbye (reason text) or the link dropped.
    std::function<void(const std::string& reason)> on_disconnect;

    const ConnectionStats& stats() const { return machine_.stats(); }
    /// Why the last link was lost ("REASON_...: message" of the server's Disconnect, the socket
    /// error, or "CONNECT_TIMEOUT: ..." when it gave up); "" once a link is live again.
    const std::string& lastDisconnect() const { return last_disconnect_; }
    /// Why the last request returned 0 ("NOT_CONNECTED: ...").
    const std::string& lastRefusal() const { return machine_.refusal(); }
    std::uint64_t playerId() const { return machine_.playerId(); }
    const std::string& role() const { return machine_.role(); }
    /// Seconds of the last ping round trip (0 before one completes).
    double roundTripSeconds() const { return machine_.roundTripSeconds(); }

  private:
    /// The shell's own states; kLinked: the machine's phase says joining or live.
    enum class Link { kIdle, kConnecting, kLinked, kWaiting, kClosed };

    void connect();
    void onConnected();
    void readMore();
    void writeMore();
    /// Acts on what the machine decided (a drop) and writes what it queued.
    void afterMachine();
    /// Closes the socket; reconnects later unless stopped or the reason is final.
    void lost(const std::string& why, bool final_reason);
    /// Closes for good when no link has been live for give_up_seconds; true if it did.
    bool giveUpIfDue(std::chrono::steady_clock::time_point now);

    asio::io_context& io_;
    ConnectionConfig config_;
    ClientMachine machine_;
    asio::ip::tcp::socket socket_;
    asio::ip::tcp::resolver resolver_;
    asio::steady_timer timer_;
    asio::steady_timer attempt_timer_; // the connect timeout of the attempt under way
    Link state_ = Link::kIdle;
    std::vector<std::uint8_t> writing_; // frames being written
    bool write_busy_ = false;
    std::uint64_t generation_ = 0; // bumps on each new socket; stale handlers ignore themselves
    std::string last_disconnect_;
    int failed_attempts_ = 0; // attempts in a row that did not reach live (reconnect backoff)
    std::chrono::steady_clock::time_point down_since_; // start(), or the live link's loss
    bool was_live_ = false; // the machine was live when last looked at (clears last_disconnect_)
};

} // namespace terrain::client
