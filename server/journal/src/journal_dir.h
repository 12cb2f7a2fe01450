#pragma once

// What a journal directory holds and how its segments are read; shared by Journal::recover() and
// verifyJournal(). Private to terrain_journal.

#include <terrain/journal/record_codec.h>
#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace terrain::journal::detail {

/// "snapshot-<seq, 20 digits>.trsn" and "journal-<first seq, 20 digits>.tjl".
std::string snapshotFileName(std::uint64_t seq);
std::string segmentFileName(std::uint64_t first_seq);

struct DirFile {
    std::uint64_t seq = 0; ///< snapshot seq, or a segment's first seq
    std::filesystem::path path;
};

/// The journal files of a directory, each list in ascending seq. Other names are ignored.
struct DirListing {
    std::vector<DirFile> snapshots;
    std::vector<DirFile> segments;
    std::vector<std::filesystem::path> temps; ///< "*.tmp" left by an interrupted atomic write
};

/// Errors: kIo (missing or unreadable directory).
Result<DirListing> listJournalDir(const std::filesystem::path& dir);

/// Index of the first segment that can hold a record after `base_seq`: segment i covers
/// [first_i, first_{i+1} - 1], so every segment before it holds only records <= base_seq.
/// Returns segments.size() when there is none.
std::size_t firstSegmentAfter(const std::vector<DirFile>& segments, std::uint64_t base_seq);

/// A segment's valid records and where its valid bytes end.
struct SegmentScan {
    std::uint64_t first_seq = 0;
    std::vector<JournalRecord> records; ///< seq first_seq, first_seq + 1, ...
    std::size_t good_bytes = 0;         ///< header + records
    std::size_t torn_bytes = 0;         ///< bytes after them (only in the newest segment)
};

/// Checks a segment: header (and its seq against the file name), each record's checksum, and
/// seq continuity inside the segment (record i has seq first_seq + i). In the newest segment a
/// torn tail (bad or partial records up to the end of the file, with no valid record starting
/// at any byte offset after the first bad one) is reported in torn_bytes; anywhere else a bad
/// record is refused. Errors (message "<file> offset <n>: <rule>"): the header's code, kBadFormat
/// otherwise.
Result<SegmentScan>
scanSegment(std::span<const std::uint8_t> bytes, const DirFile& file, bool newest);

/// What replaySegments() did.
struct ReplayResult {
    std::uint64_t last_seq = 0;               ///< seq of the state `terrain` is in now
    std::size_t replayed = 0;                 ///< records applied (those after base_seq)
    std::size_t segments = 0;                 ///< segments read
    std::size_t torn_bytes = 0;               ///< torn tail of the newest segment
    std::size_t newest_good_bytes = 0;        ///< where the newest segment's valid bytes end
    std::optional<std::uint64_t> newest_next; ///< seq the newest segment expects next, if read
};

/// Called after each replayed record with the record and the state after it.
using AfterRecord = std::function<Status(const JournalRecord& record, const Terrain& terrain)>;

/// Replays, on `terrain` (the state at `base_seq`), every record after base_seq found in
/// `segments` (ascending; the last is the newest). Checks continuity between segments, skips
/// (but still checks) records <= base_seq, compares the record at base_seq with terrain's hash,
/// and applies and hash-checks every later record. Reads files; writes nothing.
/// Errors: scanSegment()'s; kBadFormat for a gap or repeat (between the snapshot and the first
/// segment, or between segments); apply()'s code; kHashMismatch; kIo; `after`'s error.
Result<ReplayResult> replaySegments(
    const std::vector<DirFile>& segments,
    std::uint64_t base_seq,
    Terrain& terrain,
    const AfterRecord& after,
    TaskRunner* runner = nullptr);

/// "1a2b..." (16 hex digits).
std::string hex64(std::uint64_t value);

} // namespace terrain::journal::detail
