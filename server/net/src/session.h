#pragma once

// One client connection: handshake, request handling, and a bounded outbound queue. Lives on
// the server's io thread; owned by the Server's session list (shared_ptr keeps it alive while an
// async operation is in flight).

#include <terrain/server/auth_token.h>
#include <terrain/server/outbound_queue.h>
#include <terrain/server/rate_limiter.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/snapshot_stream.h>

#include <asio.hpp>
#include <cstdint>
#include <memory>
#include <string>

namespace terrain::server {

class Server;

class Session : public std::enable_shared_from_this<Session> {
  public:
    Session(Server& server, asio::ip::tcp::socket socket, std::uint64_t id);

    void start();
    /// Queues a broadcast op unless this session already has it (snapshot at or after seq).
    void sendOp(std::uint64_t seq, const wire::Frame& frame);
    /// Queues the OpBatch frame of ops first..last; the ones after what this session already
    /// has one by one when a snapshot covered part of them.
    void sendOps(std::uint64_t first, std::uint64_t last, const wire::Frame& batch);
    void sendControl(const wire::pb::Envelope& envelope);
    /// Queues a Disconnect with the reason, stops reading, and closes once it is written (or
    /// after the linger time).
    void close(wire::pb::Reason reason, const std::string& message);

    /// Waiting for a join or resync snapshot (ops are not queued meanwhile: the retained ones
    /// follow the snapshot).
    bool awaitingSnapshot() const { return awaiting_snapshot_ && state_ == State::kLive; }
    /// True when this session holds the server's genesis: it is sent genesis deltas.
    bool holdsGenesis() const;
    /// Queues `snapshot` and the retained ops after it.
    void deliverSnapshot(const wire::SnapshotFrames& snapshot);

    bool live() const { return state_ == State::kLive; }
    std::uint64_t id() const { return id_; }
    std::size_t queuedBytes() const { return queue_.totalBytes(); }

  private:
    enum class State { kAwaitHello, kLive, kClosing, kClosed };

    void readMore();
    void onRead(const asio::error_code& ec, std::size_t n);
    /// false when the session was closed by this frame.
    bool handleFrame(const wire::pb::Envelope& envelope);
    void onHello(const wire::pb::Hello& hello);
    void onDeform(const wire::pb::DeformRequest& request);
    void onHeightQuery(const wire::pb::HeightQuery& query);
    void onRayQuery(const wire::pb::RayQuery& query);
    void onRepairRequest(const wire::pb::RepairRequest& request);
    void onSnapshotRequest(const wire::pb::SnapshotRequest& request);
    void onHealthRequest();
    /// Queues the join snapshot and the retained ops after it, now if the cached one is usable,
    /// else once the server has built one.
    void sendSnapshotAndTail();
    void sendTail(std::uint64_t after_seq);
    void overBudget();
    void enqueue(wire::Frame frame, FrameClass cls);
    void writeMore();
    void finish();
    double now() const;

    Server& server_;
    asio::ip::tcp::socket socket_;
    std::uint64_t id_;
    std::string peer_;
    State state_ = State::kAwaitHello;
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
    asio::steady_timer timer_; // hello timeout, then close linger
    std::vector<asio::const_buffer> gather_;
};

} // namespace terrain::server
