#pragma once

// The authority's protocol hub, without sockets, threads or clocks: the sessions, the ops
// accepted and not yet durable, group commit -> broadcast -> acknowledgement in seq order, the
// ring of broadcast frames clients resume from, and the join-snapshot cache. Every call runs on
// one thread (the hub's); what must run elsewhere goes through its HubHost. The Asio Server is a
// shell around it; tests and the session fuzzer drive it with a simulated host and link.

#include <terrain/journal/journal.h>
#include <terrain/server/authority.h>
#include <terrain/server/hub_host.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/snapshot_stream.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace terrain::server {

class SessionLink;
class SessionMachine;

/// The protocol's settings: limits, rates, budgets, the journal's rules. Where the server
/// listens is its transport's (server/net's TransportConfig).
struct ServerConfig {
    /// Inbound frame limit: clients send small requests only.
    std::size_t max_inbound_frame_bytes = 64 << 10;
    /// Per-session backlog of ops and replies; over it the session is resynced by snapshot, and
    /// over it again before the queue drained it is disconnected as a slow consumer.
    std::size_t outbound_budget_bytes = 4 << 20;
    std::size_t max_sessions = 1024; ///< player slots: sessions past Hello
    /// Connections that have not said Hello yet, in all and from one address: their own limits,
    /// so that idle sockets never take a player's place (a health probe needs only one of them).
    std::size_t max_pending_sessions = 256;
    std::size_t max_pending_per_address = 32;
    std::size_t op_log_capacity = 8192;
    double deform_rate_per_second = 30.0;
    double deform_burst = 60.0;
    double frame_rate_per_second = 2000.0; ///< any frame; above it the session is flooding
    double frame_burst = 4000.0;
    double repair_rate_per_second = 2.0; ///< repair and snapshot requests
    double repair_burst = 6.0;
    /// Tiles one RepairRequest may name (bounds the work and the reply of one request).
    std::size_t max_repair_tiles = 64;
    double query_rate_per_second = 200.0; ///< height and ray queries
    double query_burst = 400.0;
    double hello_timeout_seconds = 5.0;
    double close_linger_seconds = 2.0; ///< time a closing session gets to read its Disconnect
    std::size_t snapshot_chunk_bytes = wire::kDefaultSnapshotChunkBytes;
    /// The cached join snapshot is rebuilt once it is this many ops behind (joins replay the rest).
    std::uint64_t snapshot_cache_max_lag = 2000;
    /// Tick batching: the ops of one group commit go to every session as one OpBatch frame
    /// (PROTOCOL.md, "OpBatch": about 15 bytes a crater in a burst) instead of an OpApplied
    /// each. Off: one OpApplied per op, each with its world hash.
    bool batch_broadcasts = false;
    /// With batching, every op's world hash travels too (8 bytes an op), not only the last one's.
    bool batch_hash_per_op = false;
    /// Group commits on the commit thread, the io thread going on meanwhile (the pipeline);
    /// false: the io thread writes and syncs each group itself (the old way, for comparison).
    bool pipeline_commits = true;
    /// The journal writes a snapshot once replaying the ops since the last one would take
    /// about this long: the sum of their measured apply times (0: no time rule). Recovery then
    /// replays at most this much plus what arrives while the snapshot is written.
    double journal_snapshot_replay_seconds = 0.5;
    /// ... or every this many ops, whichever comes first (0: no count rule). With neither rule
    /// the journal snapshots only on shutdown and after a recovery that replayed records.
    std::uint64_t journal_snapshot_every = 20000;
    std::vector<std::uint8_t> token_secret;
    /// Tests: runs on the snapshot thread before each of its jobs (join snapshot builds,
    /// journal snapshot files), to hold one.
    std::function<void()> before_snapshot_build;
};

/// Slots for refusal reasons: every wire::pb::Reason value is below it.
inline constexpr std::size_t kReasonSlots = 40;

struct ServerStats {
    std::uint64_t sessions_accepted = 0;
    std::uint64_t sessions_live = 0;
    std::uint64_t ops_accepted = 0;
    std::uint64_t ops_refused = 0;
    std::uint64_t commits = 0;
    std::uint64_t resyncs = 0;
    std::uint64_t slow_disconnects = 0;
    std::uint64_t bad_frames = 0;
    std::uint64_t bad_tokens = 0;
    std::uint64_t snapshots_built = 0;     ///< join snapshots built (either kind)
    std::uint64_t snapshots_sent = 0;      ///< whole snapshots queued to sessions
    std::uint64_t genesis_deltas_sent = 0; ///< genesis deltas queued to sessions
    std::uint64_t repairs_served = 0;
    std::uint64_t bytes_queued = 0;   ///< all frames handed to sessions
    std::uint64_t bytes_received = 0; ///< all bytes read from sessions
    /// Deform requests refused, by wire::pb::Reason value (the sum is ops_refused).
    std::array<std::uint64_t, kReasonSlots> refused_by_reason{};
};

class ServerHub {
  public:
    /// `journal` may be null (tests, benchmarks): ops are then acknowledged without durability.
    ServerHub(HubHost& host, ServerConfig config, Authority& authority, journal::Journal* journal);
    ~ServerHub();
    ServerHub(const ServerHub&) = delete;
    ServerHub& operator=(const ServerHub&) = delete;

    /// A new connection (`peer`, "address:port", names it in logs) at time `now`, carried by
    /// `link`: its machine, in the hub's list until it finishes. Past the limits on connections
    /// waiting for their Hello (max_pending_sessions, max_pending_per_address) it is closed at
    /// once with REASON_SERVER_FULL; player slots (max_sessions) are taken at Hello.
    std::shared_ptr<SessionMachine> addSession(std::string peer, double now, SessionLink* link);

    /// Once the host is up: a recovered state that replayed records goes into a journal
    /// snapshot at once (off this thread), so a crash before the next one does not replay them
    /// again.
    void start();

    /// Drains: commits pending ops, writes a journal snapshot (unless the newest durable one is
    /// at the last seq already), says goodbye to every session
    /// and calls `done` once they are closed (or when drainTimedOut() is called).
    void shutdown(std::function<void()> done);
    /// The linger time is over: `done` runs now if it has not.
    void drainTimedOut();

    bool failed() const { return failed_; }
    const std::string& failure() const { return failure_; }
    bool shuttingDown() const { return shutting_down_; }
    const ServerConfig& config() const { return config_; }
    const ServerStats& stats() const { return stats_; }
    std::size_t sessionCount() const { return sessions_.size(); }
    /// To the host's log (sessions log through here).
    void log(LogEvent event);
    /// The sessions by state, and the live ones by role (metrics).
    struct SessionCounts {
        std::size_t awaiting_hello = 0;
        std::size_t viewers = 0;
        std::size_t deformers = 0;
        std::size_t admins = 0;
        std::size_t ending = 0; ///< closing, saying goodbye
    };
    SessionCounts sessionCounts() const;
    std::uint64_t broadcastSeq() const { return broadcast_seq_; }
    /// The measured apply time of the durable ops after the last journal snapshot begun: about
    /// what a recovery would replay now (metrics; the snapshot rule).
    double replaySecondsSinceSnapshot() const { return replay_seconds_since_snapshot_; }
    /// The world hash after op broadcastSeq(): the state clients see. The authority's own
    /// terrain may be ahead of it by ops not yet committed.
    std::uint64_t broadcastHash() const { return broadcast_hash_; }
    /// The world's genesis (Terrain::genesisHash): clients that hold it join by a delta.
    std::uint64_t genesisHash() const { return genesis_hash_; }
    /// How many ops behind a client may be and still resume: the retained log's length, or
    /// what half a session's outbound budget holds (kMaxOpFrameBytes an op), whichever is less.
    std::uint64_t resumeWindow() const;
    /// Bytes queued in all sessions (shared frames counted per session).
    std::size_t queuedBytes() const;
    Authority& authority() { return authority_; }
    const Authority& authority() const { return authority_; }
    /// Called whenever a batch of ops has been broadcast (benchmarks, logs).
    std::function<void(std::uint64_t seq)> on_broadcast;

    // What sessions ask of the hub.

    /// What a joining or resyncing session is sent: the whole world, or its difference from
    /// the genesis the session holds.
    enum SnapshotKind : std::size_t { kWholeSnapshot = 0, kGenesisDelta = 1, kSnapshotKinds = 2 };
    /// Seconds since the Unix epoch, from the host (token expiry).
    std::int64_t unixSeconds() const { return host_.unixSeconds(); }
    /// The counters sessions bump.
    ServerStats& counters() { return stats_; }
    /// An op the authority accepted from `session`: journaled now, broadcast and acknowledged
    /// (DeformReply with `request_id`) once its group commit is durable.
    /// `apply_seconds`: what the authority's apply took (a replay after a crash costs about as
    /// much: the journal's snapshot rule).
    void submit(
        const std::shared_ptr<SessionMachine>& session,
        std::uint32_t request_id,
        Accepted accepted,
        double received_at,
        double apply_seconds);
    /// The host's monotonic clock, and where the hub's timings go (HubHost).
    double clock() const { return host_.monotonicSeconds(); }
    void observe(HubTiming timing, double seconds) { host_.observe(timing, seconds); }
    /// Synchronous: every accepted op durable and broadcast when it returns (or the hub
    /// failed). Joins, repairs, snapshot builds and shutdown need a state with no op that is not
    /// durable; waits for the group on the commit thread, then commits the rest on this one.
    void commitPending();
    /// True when `ops` broadcast frames take at most half a session's budget.
    bool tailFits(std::uint64_t ops) const;
    /// The broadcast frame of op `seq` (retained).
    const wire::Frame& opFrame(std::uint64_t seq) const;
    /// The cached join snapshot if a session may start from it now: its successors are all
    /// retained, it is not too far behind, and the ops after it fit well inside a session's
    /// budget (a join must not start as a slow consumer); else nullptr.
    const wire::SnapshotFrames* usableSnapshot(SnapshotKind kind) const;
    /// `session` gets a snapshot as soon as a usable one is built (off the hub's thread).
    void awaitSnapshot(const std::shared_ptr<SessionMachine>& session, SnapshotKind kind);
    /// A finished session leaves the list (deferred: it may finish while the hub walks it).
    void remove(const SessionMachine* session);
    /// Upper bound of one OpApplied frame (prefix + envelope), for budget arithmetic.
    static constexpr std::uint64_t kMaxOpFrameBytes = 64;

  private:
    struct JoinSnapshot {
        std::shared_ptr<const wire::SnapshotFrames> frames; ///< the cache
        std::vector<std::weak_ptr<SessionMachine>> waiters;
        bool wanted = false; ///< asked for once: built with every later build and kept warm
    };

    struct PendingOp {
        Accepted accepted;
        std::weak_ptr<SessionMachine> requester;
        std::uint32_t request_id = 0;
        double received_at = 0.0;   ///< when the request was read (the host's clock)
        double apply_seconds = 0.0; ///< the authority's apply
    };

    /// Starts a commit of the pending ops once the handlers already ready have run (they join
    /// this group).
    void scheduleCommit();
    /// The commit pipeline: the pending ops' journal records go to the commit thread (write +
    /// fdatasync) as one group while this thread goes on accepting the next; once durable,
    /// finishCommit() broadcasts and acknowledges them in seq order, then starts the next group.
    /// Without a journal the group is broadcast at once.
    void startCommit();
    struct CommitInFlight;
    /// With `go_on`, starts the next group when ops are pending.
    void finishCommit(const std::shared_ptr<CommitInFlight>& flight, bool go_on);
    /// Broadcast + acknowledgement of durable ops, in seq order; then the periodic snapshots.
    void broadcast(std::vector<PendingOp>& ops);
    /// Tick batching: the ops as OpBatch frames (kMaxBatchOps each), then the replies.
    void broadcastBatched(std::vector<PendingOp>& ops);
    /// The requester's DeformReply for an op broadcast.
    void acknowledge(const PendingOp& p);
    void fail(const std::string& why);
    /// fail(), and every session closed, for a journal that could not make ops durable.
    void failJournal(const std::string& why);
    /// The journal's periodic snapshot when it is due (every op before it made durable first).
    void maybeWriteJournalSnapshot();
    /// Starts building the wanted kinds of snapshot of the current state on the snapshot
    /// thread, unless a build is running.
    void buildSnapshot();
    void
    onSnapshotBuilt(std::array<std::shared_ptr<const wire::SnapshotFrames>, kSnapshotKinds> built);
    /// The journal's periodic snapshot at broadcastSeq(), its file written off this thread.
    void writeJournalSnapshot();
    /// `kept`, made equal to the authority's world, for the snapshot thread to read.
    std::shared_ptr<const Terrain> followTerrain(std::shared_ptr<Terrain>& kept) const;
    void finishDrain();

    HubHost& host_;
    ServerConfig config_;
    Authority& authority_;
    journal::Journal* journal_;
    std::vector<std::shared_ptr<SessionMachine>> sessions_;
    std::vector<PendingOp> pending_;    ///< accepted, journaled in memory, not in a group yet
    std::vector<PendingOp> committing_; ///< the group on the commit thread
    std::shared_ptr<CommitInFlight> commit_in_flight_;
    bool commit_scheduled_ = false;
    std::uint64_t broadcast_seq_ = 0;
    std::uint64_t broadcast_hash_ = 0;            ///< after op broadcast_seq_
    std::uint64_t last_journal_snapshot_seq_ = 0; ///< the last begun (or the recovered one)
    double replay_seconds_since_snapshot_ = 0.0;
    // copies of the world kept for the snapshot thread (journal snapshots, join snapshots):
    // followTerrain() brings one up to date with the changed tiles only
    std::shared_ptr<Terrain> journal_copy_;
    std::shared_ptr<Terrain> join_copy_;
    std::vector<wire::Frame> op_frames_; // ring parallel to the authority's op log
    std::uint64_t genesis_hash_ = 0;
    std::array<JoinSnapshot, kSnapshotKinds> join_snapshots_;
    bool join_build_in_flight_ = false;
    bool journal_snapshot_in_flight_ = false;
    bool shutting_down_ = false;
    bool failed_ = false;
    std::string failure_;
    std::function<void()> shutdown_done_;
    ServerStats stats_;
    std::uint64_t next_session_id_ = 1;
    /// Handlers posted to the host check it: they do nothing once the hub is gone.
    std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
};

} // namespace terrain::server
