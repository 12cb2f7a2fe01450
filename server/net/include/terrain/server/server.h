#pragma once

// The network edge of the authority: an Asio acceptor and one Session per TCP connection, all on
// one io_context thread (single-threaded by contract, ARCHITECTURE.md). Accepted ops are
// journaled (group commit: every op accepted in one pass of the event loop shares one write and
// one fsync), and only then broadcast and acknowledged.

#include <terrain/journal/journal.h>
#include <terrain/server/auth_token.h>
#include <terrain/server/authority.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/snapshot_stream.h>

#include <array>
#include <asio.hpp>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace terrain::server {

class Session;
class WorkerThread;

struct ServerConfig {
    std::string bind_address = "127.0.0.1";
    std::uint16_t port = 0; ///< 0: an ephemeral port (tests); see Server::port()
    /// Inbound frame limit: clients send small requests only.
    std::size_t max_inbound_frame_bytes = 64 << 10;
    /// Per-session backlog of ops and replies; over it the session is resynced by snapshot, and
    /// over it again before the queue drained it is disconnected as a slow consumer.
    std::size_t outbound_budget_bytes = 4 << 20;
    std::size_t max_sessions = 1024;
    /// SO_SNDBUF per session (0: the OS default). Small values bound kernel memory per client.
    int socket_send_buffer_bytes = 0;
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
    /// The journal writes a snapshot every this many ops (0: only on shutdown).
    std::uint64_t journal_snapshot_every = 20000;
    std::vector<std::uint8_t> token_secret;
    /// Tests: runs on the snapshot thread before each of its jobs (join snapshot builds,
    /// journal snapshot files), to hold one.
    std::function<void()> before_snapshot_build;
};

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
    std::uint64_t bytes_queued = 0; ///< all frames handed to sessions
};

class Server {
  public:
    /// `journal` may be null (tests, benchmarks): ops are then acknowledged without durability.
    Server(
        asio::io_context& io, ServerConfig config, Authority& authority, journal::Journal* journal);
    ~Server();
    Server(const Server&) = delete;
    Server& operator=(const Server&) = delete;

    /// Binds and starts accepting. Errors: kIo naming the address and the OS error.
    Status start();
    std::uint16_t port() const { return port_; }

    /// Drains: stops accepting, commits pending ops, writes a journal snapshot, says goodbye to
    /// every session and calls `done` once they are closed (or after the linger time).
    void shutdown(std::function<void()> done);

    /// Set when the journal failed: the server stops serving and the process must exit non-zero.
    bool failed() const { return failed_; }
    const std::string& failure() const { return failure_; }

    const ServerStats& stats() const { return stats_; }
    std::size_t sessionCount() const { return sessions_.size(); }
    std::uint64_t broadcastSeq() const { return broadcast_seq_; }
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
    /// Called on the io thread whenever a batch of ops has been broadcast (benchmarks, logs).
    std::function<void(std::uint64_t seq)> on_broadcast;

  private:
    friend class Session;

    /// What a joining or resyncing session is sent: the whole world, or its difference from
    /// the genesis the session holds.
    enum SnapshotKind : std::size_t { kWholeSnapshot = 0, kGenesisDelta = 1, kSnapshotKinds = 2 };
    struct JoinSnapshot {
        std::shared_ptr<const wire::SnapshotFrames> frames; ///< the cache
        std::vector<std::weak_ptr<Session>> waiters;
        bool wanted = false; ///< asked for once: built with every later build and kept warm
    };

    struct PendingOp {
        Accepted accepted;
        std::weak_ptr<Session> requester;
        std::uint32_t request_id = 0;
    };

    void accept();
    void remove(Session* session);
    /// Applies a deform request from `session` (already permitted and rate-checked).
    void submit(
        const std::shared_ptr<Session>& session,
        std::uint32_t request_id,
        Result<Accepted> accepted);
    /// Starts a commit of the pending ops once the handlers already ready have run (they join
    /// this group).
    void scheduleCommit();
    /// The commit pipeline: the pending ops' journal records go to the commit thread (write +
    /// fdatasync) as one group while the io thread goes on accepting the next; once durable,
    /// finishCommit() broadcasts and acknowledges them in seq order, then starts the next group.
    /// Without a journal the group is broadcast at once.
    void startCommit();
    struct CommitInFlight;
    /// Io thread. With `go_on`, starts the next group when ops are pending.
    void finishCommit(const std::shared_ptr<CommitInFlight>& flight, bool go_on);
    /// Broadcast + acknowledgement of durable ops, in seq order; then the periodic snapshots.
    void broadcast(std::vector<PendingOp>& ops);
    /// Tick batching: the ops as OpBatch frames (kMaxBatchOps each), then the replies.
    void broadcastBatched(std::vector<PendingOp>& ops);
    /// The requester's DeformReply for an op broadcast.
    void acknowledge(const PendingOp& p);
    /// Synchronous: every accepted op durable and broadcast when it returns (or the server
    /// failed). Joins, repairs, snapshot builds and shutdown need a state with no op that is not
    /// durable; waits for the group on the commit thread, then commits the rest on this one.
    void commitPending();
    void fail(const std::string& why);
    /// fail(), and every session closed, for a journal that could not make ops durable.
    void failJournal(const std::string& why);
    /// The journal's periodic snapshot when it is due (every op before it made durable first).
    void maybeWriteJournalSnapshot();
    /// The cached join snapshot if a session may start from it now: its successors are all
    /// retained, it is not too far behind, and the ops after it fit well inside a session's
    /// budget (a join must not start as a slow consumer); else nullptr.
    const wire::SnapshotFrames* usableSnapshot(SnapshotKind kind) const;
    /// `session` gets a snapshot as soon as a usable one is built (off the io thread).
    void awaitSnapshot(const std::shared_ptr<Session>& session, SnapshotKind kind);
    /// Starts building the wanted kinds of snapshot of the current state on the worker, unless
    /// a build is running.
    void buildSnapshot();
    void
    onSnapshotBuilt(std::array<std::shared_ptr<const wire::SnapshotFrames>, kSnapshotKinds> built);
    /// The journal's periodic snapshot at broadcastSeq(), its file written off the io thread.
    void writeJournalSnapshot();
    /// Upper bound of one OpApplied frame (prefix + envelope), for budget arithmetic.
    static constexpr std::uint64_t kMaxOpFrameBytes = 64;
    /// True when `ops` broadcast frames take at most half a session's budget.
    bool tailFits(std::uint64_t ops) const;
    /// The broadcast frame of op `seq` (retained).
    const wire::Frame& opFrame(std::uint64_t seq) const;

    asio::io_context& io_;
    ServerConfig config_;
    Authority& authority_;
    journal::Journal* journal_;
    asio::ip::tcp::acceptor acceptor_;
    std::uint16_t port_ = 0;
    std::vector<std::shared_ptr<Session>> sessions_;
    std::vector<PendingOp> pending_;    ///< accepted, journaled in memory, not in a group yet
    std::vector<PendingOp> committing_; ///< the group on the commit thread
    std::shared_ptr<CommitInFlight> commit_in_flight_;
    bool commit_scheduled_ = false;
    std::uint64_t broadcast_seq_ = 0;
    std::uint64_t broadcast_hash_ = 0; ///< after op broadcast_seq_
    std::uint64_t last_journal_snapshot_seq_ = 0;
    std::vector<wire::Frame> op_frames_; // ring parallel to the authority's op log
    std::uint64_t genesis_hash_ = 0;
    std::array<JoinSnapshot, kSnapshotKinds> join_snapshots_;
    std::unique_ptr<WorkerThread> snapshot_worker_;
    std::unique_ptr<WorkerThread> commit_worker_;
    bool join_build_in_flight_ = false;
    bool journal_snapshot_in_flight_ = false;
    void scheduleAccept();

    bool shutting_down_ = false;
    bool failed_ = false;
    std::string failure_;
    std::function<void()> shutdown_done_;
    asio::steady_timer shutdown_timer_;
    asio::steady_timer accept_retry_timer_;
    ServerStats stats_;
    std::uint64_t next_session_id_ = 1;
};

} // namespace terrain::server
