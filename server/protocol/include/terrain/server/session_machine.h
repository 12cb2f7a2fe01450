#pragma once

// One client's session, without a socket: bytes and time in, frames and link actions out. States
// (awaiting Hello, live, closing, closed), the request handlers, the rate limits, the outbound
// queue and its budget (resync by snapshot, then slow-consumer close). Its transport, a
// SessionLink (the Asio session, or a simulated link), writes what it queues and tells it when
// the writing is done. Runs on the hub's thread.

#include <terrain/server/auth_token.h>
#include <terrain/server/log_event.h>
#include <terrain/server/outbound_queue.h>
#include <terrain/server/rate_limiter.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/snapshot_stream.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>

namespace terrain::server {

class ServerHub;

/// What a session machine asks of its transport. Calls come from inside the machine's own
/// calls and from the hub's (a broadcast queues frames on every session).
class SessionLink {
  public:
    virtual ~SessionLink() = default;
    /// Frames were queued: write them when the transport can (SessionMachine::beginWrite).
    virtual void framesQueued() = 0;
    /// Call SessionMachine::tick() at `at` (seconds on the machine's clock; infinity: never).
    virtual void setDeadline(double at) = 0;
    /// The session is closing: read no more (its Disconnect is being written).
    virtual void stopReading() = 0;
    /// The session is over: close the transport.
    virtual void closeLink() = 0;
};

class SessionMachine : public std::enable_shared_from_this<SessionMachine> {
  public:
    static constexpr double kNever = std::numeric_limits<double>::infinity();

    /// Made by ServerHub::addSession. `now`: seconds on any monotonic clock, the same for
    /// every later call.
    SessionMachine(ServerHub& hub, std::uint64_t id, std::string peer, double now);

    /// The transport (nullptr: detached; the machine then only queues).
    void attach(SessionLink* link);

    // Input.
    /// Room for up to `n` bytes read from the peer; then received() with how many arrived.
    std::span<std::uint8_t> readBuffer(std::size_t n) { return reader_.prepare(n); }
    void received(std::size_t n, double now);
    /// The same for bytes held elsewhere (copied).
    void receive(std::span<const std::uint8_t> bytes, double now);
    /// A deadline set through setDeadline() has come.
    void tick(double now);
    /// The peer left or the transport failed: nothing more can be said to it.
    void linkLost();
    /// The hub is going away: closes the transport without a word and detaches from it.
    void abandon();

    // Output.
    /// The frames the transport writes next are outbound().at(0 .. n-1): at least one when any
    /// is queued, then more up to `max_bytes`. 0 while a write is in progress or when nothing
    /// is queued, or once closed.
    std::size_t beginWrite(std::size_t max_bytes);
    /// Those frames are written (`ok`), or the transport failed.
    void endWrite(bool ok);
    const OutboundQueue& outbound() const { return queue_; }

    // What the hub does to it.
    /// Queues a broadcast op unless this session already has it (snapshot at or after seq).
    void sendOp(std::uint64_t seq, const wire::Frame& frame);
    /// Queues the OpBatch frame of ops first..last; the ones after what this session already
    /// has one by one when a snapshot covered part of them.
    void sendOps(std::uint64_t first, std::uint64_t last, const wire::Frame& batch);
    void sendControl(const wire::pb::Envelope& envelope);
    /// Queues a Disconnect with the reason, stops reading, and finishes once it is written (or
    /// after the linger time).
    void close(wire::pb::Reason reason, const std::string& message);
    /// Waiting for a join or resync snapshot (ops are not queued meanwhile: the retained ones
    /// follow the snapshot).
    bool awaitingSnapshot() const { return awaiting_snapshot_ && state_ == State::kLive; }
    /// True when this session holds the hub's genesis: it is sent genesis deltas.
    bool holdsGenesis() const;
    /// Queues `snapshot` and the retained ops after it.
    void deliverSnapshot(const wire::SnapshotFrames& snapshot);

    bool live() const { return state_ == State::kLive; }
    /// Connected, no Hello yet (a pending connection, or a health probe).
    bool awaitingHello() const { return state_ == State::kAwaitHello; }
    /// The role its token gave it (meaningful once live).
    Role role() const { return claims_.role; }
    bool closed() const { return state_ == State::kClosed; }
    /// Closing or closed.
    bool ending() const { return state_ == State::kClosing || state_ == State::kClosed; }
    std::uint64_t id() const { return id_; }
    const std::string& peer() const { return peer_; }
    std::size_t queuedBytes() const { return queue_.totalBytes(); }

  private:
    enum class State { kAwaitHello, kLive, kClosing, kClosed };

    /// A log event of this session (its id and peer filled in).
    LogEvent sessionEvent(std::string name) const;

    /// Decodes and handles every complete frame read.
    void drainFrames(double now);
    /// false when the session was closed by this frame.
    bool handleFrame(const wire::pb::Envelope& envelope, double now);
    void onHello(const wire::pb::Hello& hello);
    void onDeform(const wire::pb::DeformRequest& request, double now);
    /// Counts a refused deform request under its reason (ServerStats::refused_by_reason).
    void countRefusal(int reason);
    void onHeightQuery(const wire::pb::HeightQuery& query, double now);
    void onRayQuery(const wire::pb::RayQuery& query, double now);
    void onRepairRequest(const wire::pb::RepairRequest& request, double now);
    void onSnapshotRequest(const wire::pb::SnapshotRequest& request, double now);
    void onHealthRequest();
    /// Queues the join snapshot and the retained ops after it, now if the cached one is usable,
    /// else once the hub has built one.
    void sendSnapshotAndTail();
    void sendTail(std::uint64_t after_seq);
    void overBudget();
    void enqueue(wire::Frame frame, FrameClass cls);
    void finish();
    void setDeadline(double at);

    ServerHub& hub_;
    SessionLink* link_ = nullptr;
    std::uint64_t id_;
    std::string peer_;
    State state_ = State::kAwaitHello;
    double now_ = 0.0;           ///< the latest time a call brought
    double join_started_ = -1.0; ///< the host's clock at Hello until the join is queued
    double deadline_ = kNever;
    wire::FrameReader reader_;
    OutboundQueue queue_;
    std::size_t in_flight_ = 0; // frames of the queue's front being written
    bool writing_ = false;
    bool resynced_since_drain_ = false;
    bool awaiting_snapshot_ = false;
    std::uint64_t genesis_hash_ = 0; // the genesis the client says it holds (Hello, requests)
    std::uint64_t sent_through_ = 0; // last op seq queued (or covered by a queued snapshot)
    TokenClaims claims_{};
    RateLimiter deform_limiter_;
    RateLimiter frame_limiter_;
    RateLimiter repair_limiter_;
    RateLimiter query_limiter_;
};

} // namespace terrain::server
