#pragma once

// Byte layout of the journal's segment files (see server/journal/FORMAT.md). Pure: no I/O, no
// globals; entry points: appendSegmentHeader(), decodeSegmentHeader(), appendRecord(),
// decodeRecord().
//
// Segment header, 24 bytes, little-endian:
//   "TJSG" u32 version (kSegmentVersion, 2) u64 first_seq u64 XXH3-64 of the 16 bytes before it
// Record, kRecordSize = 57 bytes, little-endian:
//   "TJR1" u64 seq u8 kind i64 center_x i64 center_y i32 radius i32 height i32 strength
//   u64 world_hash (after applying the op) u64 XXH3-64 of the 49 bytes before it

#include <terrain/deform_op.h>
#include <terrain/result.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::journal {

/// 2 since the v2 crater model (the record layout is unchanged; the ops mean something else).
inline constexpr std::uint32_t kSegmentVersion = 2;
inline constexpr std::size_t kSegmentHeaderSize = 24;
inline constexpr std::size_t kRecordSize = 57;

/// One accepted op: the server's sequence number, the canonical op, and the world hash the
/// authority reached after applying it.
struct JournalRecord {
    std::uint64_t seq = 0;
    DeformOp op;
    std::uint64_t world_hash = 0;

    friend bool operator==(const JournalRecord&, const JournalRecord&) = default;
};

/// Appends the 24-byte header of a segment whose first record will have seq `first_seq`.
void appendSegmentHeader(std::uint64_t first_seq, std::vector<std::uint8_t>& out);

/// Decodes a segment header from the first kSegmentHeaderSize bytes of `bytes` (extra bytes are
/// ignored). Untrusted input: never asserts.
/// Returns the first seq, or kTruncated (fewer than 24 bytes), kBadFormat (magic),
/// kUnsupported (version), kHashMismatch (checksum).
Result<std::uint64_t> decodeSegmentHeader(std::span<const std::uint8_t> bytes);

/// Appends the kRecordSize bytes of `record`, checksum included. The op is not validated here:
/// replay validates it through Terrain::apply().
void appendRecord(const JournalRecord& record, std::vector<std::uint8_t>& out);

/// Decodes one record from the first kRecordSize bytes of `bytes` (extra bytes are ignored).
/// Untrusted input: never asserts; the op kind and ranges are not checked (apply() does).
/// Returns the record, or kTruncated (fewer than kRecordSize bytes), kBadFormat (magic),
/// kHashMismatch (checksum).
Result<JournalRecord> decodeRecord(std::span<const std::uint8_t> bytes);

} // namespace terrain::journal
