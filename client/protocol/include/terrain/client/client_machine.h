#pragma once

// The client's side of the protocol, without a socket: join (snapshot, genesis delta or resume),
// ops onto the Replica with every hash checked, repair rounds, the snapshot fallback, pacing.
// Bytes and time in; frames to write and link decisions out. Connection is its Asio shell; tests
// drive it back to back with the server's machines over a simulated link.

#include <terrain/client/op_pacing.h>
#include <terrain/client/replica.h>
#include <terrain/deform_op.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/snapshot_stream.h>

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <span>
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
    /// Each attempt in a row that does not reach live (a full or draining server, one that is
    /// down) doubles the delay, up to this; a join that goes live resets it. A refused client
    /// does not hammer a busy server.
    double reconnect_max_delay_seconds = 5.0;
    /// An attempt whose TCP connect has not completed after this long is abandoned and counts as
    /// a failed attempt (a host that drops packets would otherwise hold it for minutes). 0: the
    /// system's own timeout.
    double connect_timeout_seconds = 5.0;
    /// Give up: when no link has gone live for this long (since start(), or since the live link
    /// was lost), the connection closes for good and says so (CONNECT_TIMEOUT). 0: keep trying.
    double give_up_seconds = 0.0;
    /// Name the genesis the replica holds in Hello and snapshot requests, so that joins and
    /// resyncs come as genesis deltas (only the tiles that differ from it) when the server's
    /// genesis is the same. Off: always the whole snapshot.
    bool genesis_deltas = true;
    /// A resume that would replay more ops than this is turned into a snapshot (a genesis delta
    /// when the replica holds the genesis) right after the Welcome: replaying thousands of
    /// craters costs a client seconds, which a fast link downloads in less. 0: no limit (the
    /// server's rule alone: it resumes whenever the missed ops fit its budget).
    std::uint64_t max_replay_ops = 0;
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

class ClientMachine {
  public:
    enum class Phase { kOffline, kJoining, kLive };
    /// Why the machine wants its link closed, and whether reconnecting can help.
    struct Drop {
        std::string why;
        bool final = false;
    };

    ClientMachine(ConnectionConfig config, Replica& replica);

    // The link.
    /// A new link is up: queues Hello (a resume when the replica holds a state).
    void linkUp();
    /// The link is gone (dropped by either side): what was read and not applied is forgotten;
    /// the next linkUp() resumes from the replica's seq.
    void linkDown();
    /// Room for up to `n` bytes from the server; then received() with how many arrived.
    std::span<std::uint8_t> readBuffer(std::size_t n) { return reader_.prepare(n); }
    /// `now_ns`: nanoseconds on any monotonic clock (ping round trips).
    void received(std::size_t n, std::uint64_t now_ns);
    /// The same for bytes held elsewhere (copied).
    void receive(std::span<const std::uint8_t> bytes, std::uint64_t now_ns);
    /// Set when the link must be closed; cleared by linkDown().
    const std::optional<Drop>& drop() const { return drop_; }
    /// Frames waiting to be written: the shell moves them out (swap) and writes them.
    std::vector<std::uint8_t>& output() { return out_; }

    Phase phase() const { return phase_; }
    /// True when the replica holds the server's state at the last broadcast it received.
    bool synced() const {
        return phase_ == Phase::kLive && replica_.ready() && !replica_.diverged() && inbox_.empty();
    }

    /// Paced: applies this frame's share of the ops waiting (OpPacer); returns how many.
    std::size_t applyArrived();
    /// Applies every op waiting.
    std::size_t applyAllArrived();
    /// Ops received and not applied yet (always 0 unpaced).
    std::size_t opsWaiting() const { return inbox_.size(); }

    // Requests: each returns its id (its answer comes through the callbacks below), or 0 when
    // nothing was sent because no link is up (offline, or closing): refusal() then says why.
    std::uint32_t requestDeform(const OpRequest& request);
    std::uint32_t requestDeform(const DeformOp& op);
    std::uint32_t queryHeight(double x, double y);
    std::uint32_t castRay(const double origin[3], const double direction[3], double max_distance);
    void ping(std::uint64_t now_ns);

    std::function<void(const DeformAnswer&)> on_deform_reply;
    std::function<void(const HeightAnswer&)> on_height_reply;
    std::function<void(const RayAnswer&)> on_ray_reply;
    /// After each op applied (seq), and after each snapshot (seq of the snapshot).
    std::function<void(std::uint64_t seq)> on_applied;

    const ConnectionStats& stats() const { return stats_; }
    /// The shell counts its part (connects, bytes, disconnects) here too.
    ConnectionStats& counters() { return stats_; }
    /// Why the last request returned 0 ("NOT_CONNECTED: ..."); "" until one did.
    const std::string& refusal() const { return refusal_; }
    /// "REASON_...: message" of the last Disconnect received ("" until one).
    const std::string& lastDisconnect() const { return last_disconnect_; }
    std::uint64_t playerId() const { return player_id_; }
    const std::string& role() const { return role_; }
    /// Seconds of the last ping round trip (0 before one completes).
    double roundTripSeconds() const { return rtt_; }

  private:
    void drainFrames(std::uint64_t now_ns);
    void handle(const wire::pb::Envelope& envelope, std::uint64_t now_ns);
    void onWelcome(const wire::pb::Welcome& welcome);
    void onSnapshotChunk(const wire::pb::SnapshotChunk& chunk);
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
    /// False, with refusal() set, when no link is up to carry a request.
    bool canSend();
    void send(const wire::pb::Envelope& envelope);
    /// Asks the shell to close the link; frames after this one are not read.
    void lose(std::string why, bool final_reason);

    ConnectionConfig config_;
    Replica& replica_;
    Phase phase_ = Phase::kOffline;
    std::optional<Drop> drop_;
    wire::FrameReader reader_;
    wire::SnapshotAssembler assembler_;
    std::vector<std::uint8_t> out_; // frames waiting to be written
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
    std::string refusal_;
    std::uint64_t player_id_ = 0;
    std::string role_;
    std::string last_disconnect_;
    double rtt_ = 0.0;
    std::uint64_t ping_sent_ns_ = 0;
    ConnectionStats stats_;
};

} // namespace terrain::client
