#include "journal_dir.h"
#include "posix_file.h"

#include <terrain/assert.h>
#include <terrain/journal/journal.h>
#include <terrain/snapshot.h>

#include <fcntl.h>

#include <algorithm>
#include <system_error>
#include <utility>

namespace terrain::journal {

struct Journal::Files {
    detail::FileHandle lock;
    detail::FileHandle segment; // O_APPEND
};

const char* toString(Durability durability) {
    switch (durability) {
    case Durability::kFsync:
        return "fsync";
    case Durability::kWrite:
        return "write";
    }
    return "?";
}

Result<Durability> parseDurability(std::string_view text) {
    if (text == "fsync")
        return Durability::kFsync;
    if (text == "write")
        return Durability::kWrite;
    return makeError(
        ErrorCode::kBadFormat,
        "durability '" + std::string(text) + "' is not one of: fsync, write");
}

Journal::Journal(std::filesystem::path dir, JournalOptions options)
    : dir_(std::move(dir)), options_(options), files_(std::make_unique<Files>()) {}

Journal::Journal(Journal&&) noexcept = default;
Journal& Journal::operator=(Journal&&) noexcept = default;
Journal::~Journal() = default;

Result<Journal> Journal::open(const std::filesystem::path& dir, JournalOptions options) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        return makeError(ErrorCode::kIo, "cannot create " + dir.string() + ": " + ec.message());
    auto lock = detail::lockFile(dir / "LOCK");
    if (!lock)
        return lock.error();
    Journal journal(dir, options);
    journal.files_->lock = std::move(*lock);
    return journal;
}

bool Journal::empty() const {
    auto listing = detail::listJournalDir(dir_);
    return listing && listing->snapshots.empty() && listing->segments.empty();
}

Error Journal::fail(Error error) {
    failure_ = error;
    return error;
}

Status Journal::startSegment(std::uint64_t first_seq) {
    std::vector<std::uint8_t> header;
    appendSegmentHeader(first_seq, header);
    // note: created atomically, so a segment file always has a whole header; a bad header is
    // corruption, never a torn write
    const std::filesystem::path path = dir_ / detail::segmentFileName(first_seq);
    if (auto s = detail::writeFileAtomically(path, header); !s)
        return s;
    if (auto s = continueSegment(path); !s)
        return s;
    segment_first_seq_ = first_seq;
    return Ok{};
}

Status Journal::continueSegment(const std::filesystem::path& path) {
    auto file = detail::openFile(path, O_WRONLY | O_APPEND);
    if (!file)
        return file.error();
    // its records may come from a run under kWrite: made durable now, so that under kFsync
    // every committed record is (closeSegmentAt relies on it)
    if (options_.durability == Durability::kFsync) {
        if (auto s = detail::syncData(file->get(), path); !s)
            return s;
    }
    files_->segment = std::move(*file);
    segment_path_ = path;
    return Ok{};
}

Status Journal::initialize(const Terrain& genesis, std::uint64_t seq) {
    TERRAIN_ASSERT(!ready_);
    if (failure_)
        return *failure_;
    auto listing = detail::listJournalDir(dir_);
    if (!listing)
        return listing.error();
    if (!listing->snapshots.empty() || !listing->segments.empty())
        return makeError(
            ErrorCode::kIo,
            dir_.string() + " already holds a journal (snapshot or segment files); recover() it");
    const auto snapshot = encodeSnapshot(genesis, seq);
    if (auto s = detail::writeFileAtomically(dir_ / detail::snapshotFileName(seq), snapshot); !s)
        return fail(s.error());
    if (auto s = startSegment(seq + 1); !s)
        return fail(s.error());
    ++stats_.snapshots_written;
    last_seq_ = seq;
    appended_seq_ = seq;
    snapshot_seq_ = seq;
    ready_ = true;
    return Ok{};
}

namespace {

// The last `retain` records ending at `last_seq`, contiguous, read back from the segments
// (newest first), and the state they start from. See Journal::recover().
RecoveredHistory collectHistory(
    const std::vector<detail::DirFile>& segments,
    std::uint64_t last_seq,
    std::uint64_t last_hash,
    std::uint64_t snapshot_seq,
    std::uint64_t snapshot_hash,
    std::size_t retain,
    std::vector<std::string>& notes) {
    RecoveredHistory history{last_seq, last_hash, {}};
    if (retain == 0)
        return history;
    // newest first: one more record than retained, whose hash is the base state's
    std::vector<JournalRecord> newest_first;
    std::uint64_t expected = last_seq;
    for (auto it = segments.rbegin(); it != segments.rend() && newest_first.size() <= retain;
         ++it) {
        if (it->seq > expected)
            continue; // holds only records past the recovered state (none: the tail was cut)
        auto bytes = detail::readWholeFile(it->path);
        auto scan = bytes ? detail::scanSegment(*bytes, *it, it == segments.rbegin())
                          : Result<detail::SegmentScan>(bytes.error());
        if (!scan) {
            notes.push_back(
                "history stops before " + it->path.filename().string() + ": " +
                scan.error().message);
            break;
        }
        bool chained = true;
        for (auto r = scan->records.rbegin();
             r != scan->records.rend() && newest_first.size() <= retain; ++r) {
            if (r->seq > expected)
                continue;
            if (r->seq != expected) {
                chained = false;
                break;
            }
            if (r->seq == snapshot_seq && r->world_hash != snapshot_hash) {
                notes.push_back(
                    "history stops at seq " + std::to_string(r->seq) +
                    ": the record's hash differs from the snapshot's");
                chained = false;
                break;
            }
            newest_first.push_back(*r);
            if (expected == 0)
                break;
            --expected;
        }
        if (!chained || expected + 1 != it->seq)
            break; // a gap before this segment's first record (pruned or damaged)
    }
    if (newest_first.empty())
        return history;
    // the state before the oldest record: the snapshot's, or an older record's hash
    const std::uint64_t oldest = newest_first.back().seq;
    if (newest_first.size() <= retain && oldest == snapshot_seq + 1) {
        history.base_seq = snapshot_seq;
        history.base_hash = snapshot_hash;
    } else {
        history.base_seq = oldest;
        history.base_hash = newest_first.back().world_hash;
        newest_first.pop_back();
    }
    history.records.assign(newest_first.rbegin(), newest_first.rend());
    return history;
}

} // namespace

Result<RecoveredState> Journal::recover(std::size_t retain_records) {
    TERRAIN_ASSERT(!ready_);
    if (failure_)
        return *failure_;
    auto listing = detail::listJournalDir(dir_);
    if (!listing)
        return listing.error();
    if (listing->snapshots.empty())
        return makeError(ErrorCode::kIo, "no snapshot in " + dir_.string());

    // the newest snapshot that decodes; older ones (and their longer replay) are the fallback
    std::vector<std::string> notes;
    std::optional<Error> newest_error;
    std::optional<DecodedSnapshot> base;
    for (auto it = listing->snapshots.rbegin(); it != listing->snapshots.rend() && !base; ++it) {
        const std::string name = it->path.filename().string();
        auto bytes = detail::readWholeFile(it->path);
        Result<DecodedSnapshot> decoded =
            bytes ? decodeSnapshot(*bytes) : Result<DecodedSnapshot>(bytes.error());
        if (decoded && decoded->sequence != it->seq)
            decoded = makeError(
                ErrorCode::kBadFormat, "holds seq " + std::to_string(decoded->sequence) +
                                           ", its name says " + std::to_string(it->seq));
        if (decoded) {
            base.emplace(std::move(*decoded));
            break;
        }
        notes.push_back(name + " skipped: " + decoded.error().message);
        if (!newest_error)
            newest_error = makeError(
                decoded.error().code, "no snapshot in " + dir_.string() + " can be loaded; " +
                                          name + ": " + decoded.error().message);
    }
    if (!base)
        return *newest_error;

    const std::uint64_t snapshot_seq = base->sequence;
    Terrain terrain = std::move(base->terrain);
    const std::uint64_t snapshot_hash = terrain.worldHash();
    auto replay = detail::replaySegments(
        listing->segments, snapshot_seq, terrain, nullptr, options_.apply_runner);
    if (!replay)
        return replay.error();

    // drop the torn tail so that new records follow the last good one directly
    const std::filesystem::path newest =
        listing->segments.empty() ? std::filesystem::path() : listing->segments.back().path;
    if (replay->torn_bytes > 0) {
        if (auto s = detail::truncateFile(newest, replay->newest_good_bytes); !s)
            return fail(s.error());
        notes.push_back(
            "dropped a torn tail of " + std::to_string(replay->torn_bytes) + " bytes at offset " +
            std::to_string(replay->newest_good_bytes) + " of " + newest.filename().string());
    }
    for (const auto& temp : listing->temps)
        if (auto s = detail::removeFile(temp); !s)
            notes.push_back(s.error().message);

    const std::uint64_t seq = replay->last_seq;
    if (replay->newest_next && *replay->newest_next == seq + 1) {
        if (auto s = continueSegment(newest); !s)
            return fail(s.error());
        segment_first_seq_ = listing->segments.back().seq;
    } else {
        // no segment yet (a crash right after the snapshot), or the newest one ends before it
        if (auto s = startSegment(seq + 1); !s)
            return fail(s.error());
        notes.push_back("started " + detail::segmentFileName(seq + 1));
    }
    last_seq_ = seq;
    appended_seq_ = seq;
    snapshot_seq_ = snapshot_seq;
    ready_ = true;
    RecoveredHistory history = collectHistory(
        listing->segments, seq, terrain.worldHash(), snapshot_seq, snapshot_hash, retain_records,
        notes);
    return RecoveredState{std::move(terrain), seq,
                          snapshot_seq,       replay->replayed,
                          replay->torn_bytes, std::move(notes),
                          std::move(history)};
}

void Journal::append(const JournalRecord& record) {
    TERRAIN_ASSERT(ready_);
    TERRAIN_ASSERT(record.seq == appended_seq_ + 1);
    appendRecord(record, pending_bytes_);
    appended_seq_ = record.seq;
    ++pending_records_;
}

Status Journal::commit() {
    if (failure_)
        return *failure_;
    TERRAIN_ASSERT(!batch_out_);
    std::optional<CommitBatch> batch = takeBatch();
    if (!batch)
        return Ok{};
    const Status written = writeBatch(*batch);
    Status s = batchWritten(*batch, written);
    // the buffer keeps its capacity for the next group
    if (pending_records_ == 0 && pending_bytes_.capacity() < batch->bytes.capacity()) {
        batch->bytes.clear();
        pending_bytes_.swap(batch->bytes);
    }
    return s;
}

std::optional<CommitBatch> Journal::takeBatch() {
    if (failure_ || pending_records_ == 0)
        return std::nullopt;
    TERRAIN_ASSERT(ready_ && !batch_out_);
    CommitBatch batch;
    batch.bytes.swap(pending_bytes_);
    batch.records = pending_records_;
    batch.last_seq = appended_seq_;
    batch.fd = files_->segment.get();
    batch.path = segment_path_;
    batch.sync = options_.durability == Durability::kFsync;
    batch.before_sync = options_.before_sync;
    pending_records_ = 0;
    batch_out_ = true;
    return batch;
}

Status writeBatch(const CommitBatch& batch) {
    if (auto s = detail::writeAll(batch.fd, batch.bytes, batch.path); !s)
        return s;
    if (batch.sync) {
        if (batch.before_sync)
            batch.before_sync();
        if (auto s = detail::syncData(batch.fd, batch.path); !s)
            return s;
    }
    return Ok{};
}

Status Journal::batchWritten(const CommitBatch& batch, const Status& written) {
    TERRAIN_ASSERT(batch_out_);
    batch_out_ = false;
    if (failure_)
        return *failure_;
    if (!written)
        return fail(written.error());
    if (batch.sync)
        ++stats_.fsyncs;
    ++stats_.commits;
    stats_.records_written += batch.records;
    stats_.bytes_written += batch.bytes.size();
    last_seq_ = batch.last_seq;
    return Ok{};
}

Status Journal::closeSegmentAt(const char* caller, std::uint64_t seq) {
    if (failure_)
        return *failure_;
    TERRAIN_ASSERT(ready_ && !batch_out_);
    if (pending_records_ != 0 || seq != last_seq_)
        return makeError(
            ErrorCode::kOutOfRange, std::string(caller) + "(seq " + std::to_string(seq) +
                                        ") needs seq == lastSeq() (" + std::to_string(last_seq_) +
                                        ") and nothing pending (" +
                                        std::to_string(pending_records_) + " records)");
    // the segment being closed becomes durable first: pruning may delete the older snapshots
    // that could otherwise have rebuilt its records (under kFsync, commit() synced them all)
    if (options_.durability != Durability::kFsync) {
        if (auto s = detail::syncData(files_->segment.get(), segment_path_); !s)
            return fail(s.error());
    }
    return Ok{};
}

Status Journal::startSegmentAfter(std::uint64_t seq) {
    // an empty current segment already starts at seq + 1 (a second snapshot at the same seq)
    const std::uint64_t held = seq + 1 - segment_first_seq_;
    const bool goes_on = options_.segment_records != 0 && held < options_.segment_records;
    if (segment_first_seq_ != seq + 1 && !goes_on) {
        if (auto s = startSegment(seq + 1); !s)
            return fail(s.error());
    }
    return Ok{};
}

Status Journal::writeSnapshot(const Terrain& terrain, std::uint64_t seq) {
    if (auto s = closeSegmentAt("writeSnapshot", seq); !s)
        return s;
    if (auto s = writeSnapshotFile(dir_, terrain, seq); !s)
        return fail(s.error());
    ++stats_.snapshots_written;
    snapshot_seq_ = std::max(snapshot_seq_, seq);
    if (auto s = startSegmentAfter(seq); !s)
        return s;
    return prune();
}

Status Journal::beginSnapshot(std::uint64_t seq) {
    if (auto s = closeSegmentAt("beginSnapshot", seq); !s)
        return s;
    snapshot_begun_seq_ = seq;
    return startSegmentAfter(seq);
}

Status Journal::snapshotWritten(const Status& written) {
    if (!written)
        return written;
    ++stats_.snapshots_written;
    snapshot_seq_ = std::max(snapshot_seq_, snapshot_begun_seq_);
    if (failure_)
        return *failure_;
    return prune();
}

Status
writeSnapshotFile(const std::filesystem::path& dir, const Terrain& terrain, std::uint64_t seq) {
    // streamed: a piece at a time to the disk, never the whole (tens of MB) in memory
    auto writer = detail::AtomicFileWriter::create(dir / detail::snapshotFileName(seq));
    if (!writer)
        return writer.error();
    encodeSnapshotTo(terrain, seq, [&](std::span<const std::uint8_t> piece) {
        (void)writer->append(piece); // a failure is kept and returned by commit()
    });
    return writer->commit();
}

Status Journal::prune() {
    auto listing = detail::listJournalDir(dir_);
    if (!listing)
        return listing.error();
    const std::size_t keep = std::max<std::size_t>(options_.keep_snapshots, 1);
    const auto& snapshots = listing->snapshots;
    const std::size_t drop = snapshots.size() > keep ? snapshots.size() - keep : 0;
    if (snapshots.empty())
        return Ok{};
    const std::uint64_t oldest_kept = snapshots[drop].seq;
    std::optional<Error> first_error;
    auto remove = [&](const std::filesystem::path& path) {
        if (auto s = detail::removeFile(path); !s && !first_error)
            first_error = s.error();
    };
    for (std::size_t i = 0; i < drop; ++i)
        remove(snapshots[i].path);
    // note: firstSegmentAfter() never returns past the newest segment, so the current one stays
    const std::uint64_t newest = snapshots.back().seq;
    const std::uint64_t history_from =
        newest > options_.history_records ? newest - options_.history_records : 0;
    const std::size_t first_needed =
        detail::firstSegmentAfter(listing->segments, std::min(oldest_kept, history_from));
    for (std::size_t i = 0; i < first_needed; ++i)
        remove(listing->segments[i].path);
    if (first_error)
        return *first_error;
    return Ok{};
}

} // namespace terrain::journal
