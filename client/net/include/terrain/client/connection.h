#pragma once

// The client's link to a terrain server: connect, authenticate, join (snapshot or resume), apply
// ops to the Replica and verify each hash, repair divergence by tile request, reconnect with the
// last verified seq. Runs on the caller's io_context (a game calls io.poll() once per frame);
// single-threaded: every callback runs on that thread.

#include <terrain/client/op_pacing.h>
#include <terrain/client/replica.h>
#include <terrain/deform_op.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/snapshot_stream.h>

#include <asio.hpp>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace terrain::client {

struct ConnectionConfig {
    std::string host = "127.0.0.1";
    std::uint16_t port = 7777;
    std::string token;
    std::string client_name = "terrain-client";
    /// Inbound frame limit (snapshot chunks are 256 KiB; repairs may carry many tiles).
    std::size_t max_frame_bytes = 32 << 20;
    std::size_t max_snapshot_bytes = std::size_t{2} << 30;
    bool reconnect = true;
    double reconnect_delay_seconds = 0.2;
    /// Name the genesis the replica holds in Hello and snapshot requests, so that joins and
    /// resyncs come as genesis deltas (only the tiles that differ from it) when the server's
    /// genesis is the same. Off: always the whole snapshot.
    bool genesis_deltas = true;
    /// Repairs tried before falling back to a snapshot.
    int max_repair_rounds = 3;
    /// Tiles per RepairRequest (the server's limit is 64); more are asked in later rounds.
    std::size_t max_repair_tiles = 64;
    /// Unpaced (the default), ops are applied as they are read; paced, they wait in the inbox
    /// until the frame loop calls applyArrived() (op_pacing.h), so a burst is spread over frames.
    OpPacing pacing;
};

struct ConnectionStats {
    std::uint64_t connects = 0;
    std::uint64_t resumes = 0;        ///< joins that got only the missed ops
    std::uint64_t snapshots = 0;      ///< joins or resyncs by snapshot (either kind)
    std::uint64_t genesis_deltas = 0; ///< of which genesis deltas
    std::uint64_t snapshot_bytes = 0; ///< compressed bytes of both kinds
    std::uint64_t bytes_in = 0;
    std::uint64_t bytes_out = 0;
    std::uint64_t frames_in = 0;
    std::uint64_t op_bytes_in = 0; ///< wire bytes of OpApplied and OpBatch frames, prefixes in
    std::uint64_t op_batches = 0;  ///< OpBatch frames received
    std::uint64_t repair_requests = 0;
    std::uint64_t disconnects = 0;
};

struct HeightAnswer {
    std::uint32_t request_id = 0;
    bool inside = false;
    double height = 0.0;
    double normal[3] = {0.0, 0.0, 1.0};
    std::string refused; ///< non-empty when the query was refused (rate limit)
};

struct RayAnswer {
    std::uint32_t request_id = 0;
    bool hit = false;
    double point[3] = {0.0, 0.0, 0.0};
    double distance = 0.0;
    std::string refused; ///< non-empty when the query was invalid
};

/// The reply to a deform request: accepted with its seq, or refused with the reason.
struct DeformAnswer {
    std::uint32_t request_id = 0;
    bool accepted = false;
    std::uint64_t seq = 0;
    std::string reason; ///< "REASON_RATE_LIMITED: ..." when refused
};

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

    State state() const { return state_; }
    /// True when the replica holds the server's state at the last broadcast it received.
    bool synced() const {
        return state_ == State::kLive && replica_.ready() && !replica_.diverged() && inbox_.empty();
    }

    /// Paced: applies this frame's share of the ops waiting (OpPacer); returns how many.
    /// Call once per frame, after polling the io_context.
    std::size_t applyArrived();
    /// Applies every op waiting (a loop that is not drawing frames, or before a measurement).
    std::size_t applyAllArrived();
    /// Ops received and not applied yet (always 0 unpaced).
    std::size_t opsWaiting() const { return inbox_.size(); }

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

    const ConnectionStats& stats() const { return stats_; }
    /// "REASON_...: message" of the last Disconnect received, or the socket error.
    const std::string& lastDisconnect() const { return last_disconnect_; }
    std::uint64_t playerId() const { return player_id_; }
    const std::string& role() const { return role_; }
    /// Seconds of the last ping round trip (0 before one completes).
    double roundTripSeconds() const { return rtt_; }

  private:
    void connect();
    void onConnected();
    void readMore();
    void handle(const wire::pb::Envelope& envelope);
    void onOpApplied(const wire::pb::OpApplied& op, std::size_t frame_bytes);
    void onOpBatch(const wire::pb::OpBatch& batch, std::size_t frame_bytes);
    /// One arrived op onto the replica: hash check (when it carries a hash), repair or snapshot
    /// request, on_applied.
    void applyOne(std::uint64_t seq, const DeformOp& op, std::optional<std::uint64_t> world_hash);
    std::size_t applyWaiting(std::size_t count);
    void onRepairState(const wire::pb::RepairState& state);
    void requestRepair(std::vector<std::int32_t> tiles, bool want_hashes);
    void requestSnapshot();
    /// The genesis named to the server: the replica's, unless off or refused once (0: none).
    std::uint64_t namedGenesis() const;
    void send(const wire::pb::Envelope& envelope);
    void writeMore();
    /// Closes the socket; reconnects later unless stopped or the reason is final.
    void lost(const std::string& why, bool final_reason);

    asio::io_context& io_;
    ConnectionConfig config_;
    Replica& replica_;
    asio::ip::tcp::socket socket_;
    asio::ip::tcp::resolver resolver_;
    asio::steady_timer timer_;
    State state_ = State::kIdle;
    wire::FrameReader reader_;
    wire::SnapshotAssembler assembler_;
    std::vector<std::uint8_t> out_;     // frames waiting to be written
    std::vector<std::uint8_t> writing_; // frames being written
    bool write_busy_ = false;
    bool awaiting_snapshot_ = false;
    bool genesis_refused_ = false; // a delta on our genesis failed: ask for whole snapshots
    struct Arrived {
        std::uint64_t seq = 0;
        DeformOp op;
        std::optional<std::uint64_t> world_hash; ///< none: inside a batch, checked after it
    };
    /// Paced only: ops read and not applied yet, in seq order. Emptied by a snapshot (which
    /// supersedes them) and by a lost link (the resume asks from the replica's seq again).
    std::deque<Arrived> inbox_;
    OpPacer pacer_;
    bool repair_in_flight_ = false;
    int repair_rounds_ = 0;
    std::size_t repair_tiles_requested_ = 0;
    std::uint32_t next_request_id_ = 1;
    std::uint64_t generation_ = 0; // bumps on each new socket; stale handlers ignore themselves
    std::uint64_t player_id_ = 0;
    std::string role_;
    std::string last_disconnect_;
    double rtt_ = 0.0;
    std::uint64_t ping_sent_ns_ = 0;
    ConnectionStats stats_;
};

} // namespace terrain::client
