#pragma once

// The server's durable op log: periodic snapshots plus append-only segments of fixed-size,
// checksummed records, with group commit under a stated durability policy. On start the server
// recovers the newest snapshot, replays the later records and checks every world hash.
// Layout on disk: server/journal/FORMAT.md. I/O is POSIX (open, write, fdatasync, rename); no
// clocks, no threads.

#include <terrain/journal/record_codec.h>
#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace terrain::journal {

/// When commit() may return.
enum class Durability : std::uint8_t {
    /// after write() and fdatasync(): committed records survive power loss and OS crashes.
    kFsync,
    /// after write() to the OS: committed records survive a kill -9 of the server, not an OS
    /// crash or power loss (the newest segment may then lose its tail, which recovery drops).
    kWrite,
};

/// "fsync" or "write".
const char* toString(Durability durability);

/// Parses "fsync" or "write" (exact, lowercase). Errors: kBadFormat naming the accepted values.
Result<Durability> parseDurability(std::string_view text);

struct JournalOptions {
    Durability durability = Durability::kFsync;
    /// Snapshots kept by writeSnapshot() (values below 1 count as 1). With 2 or more, recovery
    /// can fall back to an older snapshot when the newest one is damaged.
    std::size_t keep_snapshots = 2;
    /// Segments holding any of the last this many records before the newest snapshot are kept
    /// too, so that recover(retain_records) finds them after a clean stop (the server passes
    /// its retained log's capacity).
    std::size_t history_records = 0;
    /// 0: every snapshot starts a new segment (journal-<seq + 1>). N: a snapshot starts one only
    /// once the current segment holds N records or more, so that a snapshot under `kFsync`
    /// costs the journal's thread no syscall (recovery replays from the middle of a segment).
    std::size_t segment_records = 0;
    /// Tests and benchmarks: runs before each group commit's fdatasync (on the thread that
    /// syncs), to hold a commit or to stand for a slower disk.
    std::function<void()> before_sync = nullptr;
    /// recover() replays through Terrain::apply on this runner (the server's apply threads);
    /// null: serially. The bits are the same either way.
    TaskRunner* apply_runner = nullptr;
};

/// The last durable ops before a recovered state, for a server's retained log: a client a few
/// ops behind resumes after a restart instead of downloading a snapshot.
struct RecoveredHistory {
    std::uint64_t base_seq = 0;         ///< the state the records start from
    std::uint64_t base_hash = 0;        ///< its world hash
    std::vector<JournalRecord> records; ///< seq base_seq + 1 ... RecoveredState::seq, in order
};

/// What recover() rebuilt.
struct RecoveredState {
    Terrain terrain;                    ///< the state after record `seq`
    std::uint64_t seq = 0;              ///< last durable seq (the snapshot's if no record after)
    std::uint64_t snapshot_seq = 0;     ///< seq of the snapshot replay started from
    std::size_t replayed_records = 0;   ///< records applied after the snapshot
    std::size_t torn_bytes_dropped = 0; ///< torn tail removed from the newest segment
    std::vector<std::string> notes;     ///< things worth a log line (skipped snapshot, torn tail)
    RecoveredHistory history;           ///< at most recover()'s retain_records
};

/// Counters since open().
struct JournalStats {
    std::uint64_t records_written = 0;
    std::uint64_t bytes_written = 0; ///< records only (headers and snapshots not counted)
    std::uint64_t commits = 0;       ///< commit() calls that wrote something
    std::uint64_t fsyncs = 0;        ///< fdatasync calls made by commit()
    std::uint64_t snapshots_written = 0;
};

/// A group of records taken out of a Journal by takeBatch(), to be written and synced on another
/// thread (writeBatch()) while the journal's owner goes on appending the next group.
struct CommitBatch {
    std::vector<std::uint8_t> bytes;
    std::size_t records = 0;
    std::uint64_t last_seq = 0;
    int fd = -1;                ///< the current segment's descriptor (the Journal owns it)
    std::filesystem::path path; ///< the segment, for error messages
    bool sync = true;           ///< fdatasync after the write (Durability::kFsync)
    std::function<void()> before_sync = nullptr; ///< JournalOptions::before_sync
};

/// write() of a batch (retried for EINTR and short writes), then fdatasync() when it asks for
/// one. Touches no Journal: safe on another thread, one batch at a time. Errors: kIo.
Status writeBatch(const CommitBatch& batch);

/// A journal directory opened for writing: either initialize() a new one or recover() an
/// existing one, then append() + commit() accepted ops and writeSnapshot() now and then.
/// Holds an exclusive flock on `<dir>/LOCK` while alive, so two servers cannot share a directory.
/// Move-only.
/// @note Not thread safe; owned and used by one thread (the server's tick thread).
class Journal {
  public:
    /// Opens `dir`, creating it (and its parents) if needed, and takes its lock. Reads no state.
    /// Errors: kIo (cannot create, or the directory is locked by another Journal or process).
    static Result<Journal> open(const std::filesystem::path& dir, JournalOptions options = {});

    /// True when the directory holds no snapshot and no segment yet (initialize() it). Reads the
    /// directory; an unreadable one counts as not empty, so initialize() refuses it.
    bool empty() const;

    /// Starts a new journal: writes snapshot-<seq> of `genesis` and an empty segment for seq + 1,
    /// both durably; afterwards lastSeq() == seq and append() may follow.
    /// Errors: kIo (the directory is not empty(), or I/O failed).
    Status initialize(const Terrain& genesis, std::uint64_t seq = 0);

    /// Rebuilds the state: loads the newest snapshot that decodes (older ones are the fallback),
    /// replays every later record through Terrain::apply and checks each record's world hash.
    /// A torn tail of the newest segment (a partial or corrupt last write, with no valid record
    /// after it) is dropped and truncated; a bad record anywhere else is refused, since it would
    /// lose acknowledged ops. Afterwards the journal appends after the last good record.
    /// Errors (each naming file, offset or seq, and the rule):
    /// - kIo: no snapshot in the directory, or I/O failed;
    /// - the snapshot's decode error, when no snapshot decodes;
    /// - kBadFormat: a bad record followed by valid data or in an older segment, a seq gap or
    ///   repeat (inside or between segments), a bad segment header;
    /// - kHashMismatch: a record's world hash differs from the replayed one ("seq N");
    /// - apply()'s code: a record whose op the terrain refuses.
    /// With retain_records > 0, history holds up to that many of the last records, read back
    /// from the segments still on disk, those before the snapshot included (a clean stop writes
    /// a snapshot, and replays nothing). Records after the snapshot were hash-checked by the
    /// replay; older ones by their checksums, and the one at the snapshot's seq against the
    /// snapshot. An older segment that cannot be read or does not chain only shortens the history
    /// (a note says so); it never fails recovery.
    Result<RecoveredState> recover(std::size_t retain_records = 0);

    /// Buffers one record in memory; makes no syscall. Nothing is durable before commit().
    /// Precondition: initialize() or recover() succeeded, and record.seq is one more than the
    /// previous record's (or than lastSeq() when nothing is pending).
    void append(const JournalRecord& record);

    /// Records appended and not yet committed.
    std::size_t pending() const { return pending_records_; }

    /// Group commit: one write() of every pending record (retried for EINTR and short writes),
    /// then one fdatasync() under Durability::kFsync. When it returns ok, every appended record
    /// is durable per the policy and lastSeq() is the last of them. With nothing pending it does
    /// nothing and returns ok.
    /// Errors: kIo. IMPORTANT: after an error the journal is failed for good (a failed fdatasync
    /// cannot be retried safely): this and every later commit() or writeSnapshot() return the
    /// same error, and the server must stop; the next start recovers what reached the disk.
    Status commit();

    /// commit() in three steps, for a server that syncs on another thread (a commit pipeline):
    /// takeBatch() moves every pending record into a batch (nullopt when none, or when the
    /// journal failed); writeBatch(batch) runs anywhere; batchWritten(batch, status) back on
    /// the journal's thread makes its records committed (lastSeq() moves to the batch's last
    /// seq), or, for an error, fails the journal like commit(). Records appended meanwhile go
    /// to the next batch. At most one batch may be out at a time, and none across
    /// writeSnapshot(), beginSnapshot() or commit().
    std::optional<CommitBatch> takeBatch();
    Status batchWritten(const CommitBatch& batch, const Status& written);
    /// True between takeBatch() and batchWritten().
    bool batchOut() const { return batch_out_; }
    /// Writes snapshot-<seq> atomically (temp file, fdatasync, rename, fsync of the directory),
    /// then starts segment journal-<seq + 1>, then deletes all but the newest keep_snapshots
    /// snapshots and every segment holding only records older than the oldest kept snapshot
    /// and than the last history_records records before the newest one.
    /// The current segment is made durable first (an fdatasync under `kWrite`; under `kFsync`
    /// every committed record already is), so a closed segment is always whole. With
    /// `segment_records`, the current segment goes on until it holds that many records.
    /// `terrain` must be the state after record `seq`.
    /// Precondition: pending() == 0 and seq == lastSeq() (else kOutOfRange, nothing written).
    /// Errors: kOutOfRange; kIo (a failure before the new segment is in place fails the journal
    /// like commit(); a failure to delete old files is returned but leaves the journal usable).
    Status writeSnapshot(const Terrain& terrain, std::uint64_t seq);

    /// writeSnapshot() in two halves, for a server that writes the snapshot file on another
    /// thread (writeSnapshotFile()) while it goes on appending:
    /// - beginSnapshot(seq) makes the current segment durable and starts journal-<seq + 1>
    ///   (or, under `segment_records`, keeps the current one), and records after seq go there.
    ///   Same preconditions and errors as writeSnapshot(); an error fails the journal.
    /// - snapshotWritten(status), once writeSnapshotFile() returned `status`: prunes like
    ///   writeSnapshot() when it succeeded; returns `status` otherwise, and the journal stays
    ///   usable (its segments hold every record; recovery uses the older snapshot).
    /// A crash in between leaves at most a temp file, which recovery deletes.
    Status beginSnapshot(std::uint64_t seq);
    Status snapshotWritten(const Status& written);

    /// Last committed (durable) seq.
    std::uint64_t lastSeq() const { return last_seq_; }

    /// Seq of the newest snapshot known to be durable: initialize()'s, the one recover() started
    /// from, or the last that writeSnapshot() or a successful snapshotWritten() made. A recovery
    /// from it replays lastSeq() - snapshotSeq() records; a clean stop makes them equal.
    std::uint64_t snapshotSeq() const { return snapshot_seq_; }

    /// The error that failed the journal, or nullptr while it is usable.
    const Error* failure() const { return failure_ ? &*failure_ : nullptr; }

    const JournalStats& stats() const { return stats_; }
    const std::filesystem::path& directory() const { return dir_; }
    const JournalOptions& options() const { return options_; }

    Journal(Journal&&) noexcept;
    Journal& operator=(Journal&&) noexcept;
    Journal(const Journal&) = delete;
    Journal& operator=(const Journal&) = delete;
    ~Journal();

  private:
    struct Files; // descriptors of the lock and the current segment (posix_file.h)

    Journal(std::filesystem::path dir, JournalOptions options);
    /// Creates journal-<first_seq> durably and makes it the current segment.
    Status startSegment(std::uint64_t first_seq);
    /// Opens an existing segment for appending and makes it the current one.
    Status continueSegment(const std::filesystem::path& path);
    Status prune();
    /// The checks and first step of a snapshot at `seq` (named after `caller` in the error):
    /// nothing pending, seq == lastSeq(), the current segment made durable.
    Status closeSegmentAt(const char* caller, std::uint64_t seq);
    /// Starts journal-<seq + 1> unless the current segment is it, or is to go on
    /// (`segment_records`).
    Status startSegmentAfter(std::uint64_t seq);
    /// Marks the journal failed for good and returns `error`.
    Error fail(Error error);

    std::filesystem::path dir_;
    JournalOptions options_;
    std::unique_ptr<Files> files_;
    bool ready_ = false;           // initialize() or recover() succeeded
    std::optional<Error> failure_; // set once; the journal is then failed for good
    std::filesystem::path segment_path_;
    std::uint64_t segment_first_seq_ = 0;
    std::uint64_t last_seq_ = 0;           // committed
    std::uint64_t appended_seq_ = 0;       // last appended (== last_seq_ when nothing is pending)
    std::uint64_t snapshot_seq_ = 0;       // newest durable snapshot
    std::uint64_t snapshot_begun_seq_ = 0; // beginSnapshot()'s, until snapshotWritten()
    std::vector<std::uint8_t> pending_bytes_;
    std::size_t pending_records_ = 0;
    bool batch_out_ = false;
    JournalStats stats_;
};

/// Writes `dir`/snapshot-<seq> of `terrain` atomically (encode, temp file, fdatasync, rename,
/// fsync of the directory). Touches no Journal: safe on another thread than the journal's, for
/// the half between beginSnapshot() and snapshotWritten(), and beside a writeSnapshot() of the
/// same seq (each writer has a temp file of its own; both rename the same bytes). Errors: kIo.
Status
writeSnapshotFile(const std::filesystem::path& dir, const Terrain& terrain, std::uint64_t seq);

/// What verifyJournal() checked.
struct VerifyReport {
    std::uint64_t base_seq = 0;      ///< seq of the oldest snapshot, where replay started
    std::uint64_t last_seq = 0;      ///< seq after the last valid record
    std::size_t records_checked = 0; ///< records base_seq + 1 ... last_seq
    std::size_t segments_checked = 0;
    std::size_t snapshots_checked = 0; ///< snapshots decoded, the base included
    std::uint64_t final_hash = 0;      ///< world hash at last_seq
    std::size_t torn_bytes = 0;        ///< torn tail at the end of the newest segment (kept)
};

/// Offline check of a whole directory, read-only (usable while a server runs, or on a copy):
/// starting from the OLDEST snapshot, replays every record of every later segment in order,
/// recomputes each world hash and compares it with the record's, checks seq continuity (no gap,
/// no repeat, inside and between segments), and checks that every later snapshot decodes and
/// its world hash equals the replayed hash at its seq. A torn tail of the newest segment is
/// reported, not refused (recovery would drop it).
/// Errors: the first broken rule, naming the file and the offset or seq: kIo (no snapshot,
/// unreadable file), the snapshot's decode error, kBadFormat (record corruption, gap or repeat,
/// a snapshot beyond the last record), kHashMismatch (record or snapshot hash), apply()'s code.
Result<VerifyReport> verifyJournal(const std::filesystem::path& dir);

/// A journal's history, verified as verifyJournal() does: the state at its oldest snapshot and
/// every record after it, in seq order.
struct JournalHistory {
    Terrain base;
    std::uint64_t base_seq = 0;
    std::vector<JournalRecord> records; ///< base_seq + 1 ... report.last_seq
    VerifyReport report;
};

/// verifyJournal(), keeping the base state and the records (for replays through a server).
/// Errors: verifyJournal()'s.
Result<JournalHistory> readJournal(const std::filesystem::path& dir);

} // namespace terrain::journal
