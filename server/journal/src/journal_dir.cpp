#include "journal_dir.h"

#include "posix_file.h"

#include <algorithm>
#include <charconv>
#include <cinttypes>
#include <cstdio>
#include <string_view>
#include <system_error>

namespace terrain::journal::detail {
namespace {

constexpr std::string_view kSnapshotPrefix = "snapshot-";
constexpr std::string_view kSnapshotSuffix = ".trsn";
constexpr std::string_view kSegmentPrefix = "journal-";
constexpr std::string_view kSegmentSuffix = ".tjl";
constexpr std::size_t kSeqDigits = 20;

std::string numbered(std::string_view prefix, std::uint64_t seq, std::string_view suffix) {
    char digits[32];
    std::snprintf(digits, sizeof digits, "%020" PRIu64, seq);
    return std::string(prefix) + digits + std::string(suffix);
}

/// Parses "<prefix><20 digits><suffix>" exactly; false for any other name.
bool parseNumbered(
    std::string_view name, std::string_view prefix, std::string_view suffix, std::uint64_t& seq) {
    if (name.size() != prefix.size() + kSeqDigits + suffix.size() || !name.starts_with(prefix) ||
        !name.ends_with(suffix))
        return false;
    const std::string_view digits = name.substr(prefix.size(), kSeqDigits);
    if (!std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
        return false;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), seq);
    return ec == std::errc() && end == digits.data() + digits.size();
}

std::string at(const std::filesystem::path& file, std::size_t offset) {
    return file.filename().string() + " offset " + std::to_string(offset) + ": ";
}

} // namespace

std::string snapshotFileName(std::uint64_t seq) {
    return numbered(kSnapshotPrefix, seq, kSnapshotSuffix);
}

std::string segmentFileName(std::uint64_t first_seq) {
    return numbered(kSegmentPrefix, first_seq, kSegmentSuffix);
}

std::string hex64(std::uint64_t value) {
    char text[24];
    std::snprintf(text, sizeof text, "%016" PRIx64, value);
    return text;
}

Result<DirListing> listJournalDir(const std::filesystem::path& dir) {
    DirListing listing;
    std::error_code ec;
    std::filesystem::directory_iterator it(dir, ec);
    if (ec)
        return makeError(ErrorCode::kIo, "cannot list " + dir.string() + ": " + ec.message());
    for (; it != std::filesystem::directory_iterator(); it.increment(ec)) {
        const std::string name = it->path().filename().string();
        std::uint64_t seq = 0;
        if (parseNumbered(name, kSnapshotPrefix, kSnapshotSuffix, seq))
            listing.snapshots.push_back({seq, it->path()});
        else if (parseNumbered(name, kSegmentPrefix, kSegmentSuffix, seq))
            listing.segments.push_back({seq, it->path()});
        else if (name.ends_with(".tmp"))
            listing.temps.push_back(it->path());
    }
    if (ec)
        return makeError(ErrorCode::kIo, "cannot list " + dir.string() + ": " + ec.message());
    auto bySeq = [](const DirFile& a, const DirFile& b) { return a.seq < b.seq; };
    std::sort(listing.snapshots.begin(), listing.snapshots.end(), bySeq);
    std::sort(listing.segments.begin(), listing.segments.end(), bySeq);
    return listing;
}

std::size_t firstSegmentAfter(const std::vector<DirFile>& segments, std::uint64_t base_seq) {
    std::size_t i = 0;
    while (i + 1 < segments.size() && segments[i + 1].seq <= base_seq + 1)
        ++i;
    return i;
}

Result<SegmentScan>
scanSegment(std::span<const std::uint8_t> bytes, const DirFile& file, bool newest) {
    auto first = decodeSegmentHeader(bytes);
    if (!first)
        return makeError(first.error().code, at(file.path, 0) + first.error().message);
    if (*first != file.seq)
        return makeError(
            ErrorCode::kBadFormat, at(file.path, 8) + "header says first seq " +
                                       std::to_string(*first) + ", the file name " +
                                       std::to_string(file.seq));
    SegmentScan scan;
    scan.first_seq = *first;
    std::size_t offset = kSegmentHeaderSize;
    while (offset < bytes.size()) {
        auto record = decodeRecord(bytes.subspan(offset));
        if (record) {
            const std::uint64_t expected = scan.first_seq + scan.records.size();
            if (record->seq != expected)
                return makeError(
                    ErrorCode::kBadFormat,
                    at(file.path, offset) + "record seq " + std::to_string(record->seq) +
                        ", expected " + std::to_string(expected) +
                        " (seqs must increase by one, with no gap or repeat)");
            scan.records.push_back(*record);
            offset += kRecordSize;
            continue;
        }
        // a bad record: a torn write only if it is in the newest segment and no valid record
        // starts anywhere after it (one group commit may have been torn anywhere inside its
        // records; a valid record later means the damage is not at the end)
        if (!newest)
            return makeError(
                ErrorCode::kBadFormat, at(file.path, offset) + record.error().message +
                                           ", in a segment that is not the newest (only the "
                                           "newest segment may end in a torn write)");
        // note: every byte offset is tried, not only record boundaries, so that inserted or
        // lost bytes cannot hide later records; decodeRecord() rejects on the magic first
        for (std::size_t later = offset + 1; later + kRecordSize <= bytes.size(); ++later) {
            if (auto valid = decodeRecord(bytes.subspan(later)))
                return makeError(
                    ErrorCode::kBadFormat,
                    at(file.path, offset) + record.error().message +
                        ", followed by a valid record at offset " + std::to_string(later) +
                        " (seq " + std::to_string(valid->seq) +
                        "): corruption, not a torn write; refusing to drop acknowledged records");
        }
        scan.torn_bytes = bytes.size() - offset;
        break;
    }
    scan.good_bytes = offset;
    return scan;
}

namespace {

Status replayRecord(
    Terrain& terrain,
    const JournalRecord& record,
    const std::filesystem::path& file,
    std::size_t offset,
    TaskRunner* runner) {
    auto effect = terrain.apply(record.op, runner);
    if (!effect)
        return makeError(
            effect.error().code, at(file, offset) + "seq " + std::to_string(record.seq) +
                                     ": op refused on replay: " + effect.error().message);
    if (terrain.worldHash() != record.world_hash)
        return makeError(
            ErrorCode::kHashMismatch, at(file, offset) + "seq " + std::to_string(record.seq) +
                                          ": world hash after replay is " +
                                          hex64(terrain.worldHash()) + ", the record says " +
                                          hex64(record.world_hash));
    return Ok{};
}

} // namespace

Result<ReplayResult> replaySegments(
    const std::vector<DirFile>& segments,
    std::uint64_t base_seq,
    Terrain& terrain,
    const AfterRecord& after,
    TaskRunner* runner) {
    ReplayResult result;
    result.last_seq = base_seq;
    const std::size_t first = firstSegmentAfter(segments, base_seq);
    if (first == segments.size())
        return result;
    if (segments[first].seq > base_seq + 1)
        return makeError(
            ErrorCode::kBadFormat, segments[first].path.filename().string() + ": starts at seq " +
                                       std::to_string(segments[first].seq) +
                                       ", but the snapshot is at seq " + std::to_string(base_seq) +
                                       " (records in between are missing)");
    std::uint64_t next = segments[first].seq;
    for (std::size_t i = first; i < segments.size(); ++i) {
        const DirFile& file = segments[i];
        const bool newest = i + 1 == segments.size();
        if (file.seq != next)
            return makeError(
                ErrorCode::kBadFormat,
                file.path.filename().string() + ": starts at seq " + std::to_string(file.seq) +
                    ", but the previous segment ends at seq " + std::to_string(next - 1) +
                    " (a gap or repeat between segments)");
        auto bytes = readWholeFile(file.path);
        if (!bytes)
            return bytes.error();
        auto scan = scanSegment(*bytes, file, newest);
        if (!scan)
            return scan.error();
        ++result.segments;
        for (std::size_t k = 0; k < scan->records.size(); ++k) {
            const JournalRecord& record = scan->records[k];
            const std::size_t offset = kSegmentHeaderSize + k * kRecordSize;
            if (record.seq < base_seq)
                continue; // already in the snapshot
            if (record.seq == base_seq) {
                if (record.world_hash != terrain.worldHash())
                    return makeError(
                        ErrorCode::kHashMismatch,
                        at(file.path, offset) + "seq " + std::to_string(record.seq) +
                            ": the record's world hash " + hex64(record.world_hash) +
                            " differs from the snapshot's " + hex64(terrain.worldHash()));
                continue;
            }
            if (auto s = replayRecord(terrain, record, file.path, offset, runner); !s)
                return s.error();
            result.last_seq = record.seq;
            ++result.replayed;
            if (after) {
                if (auto s = after(record, terrain); !s)
                    return s.error();
            }
        }
        next = scan->first_seq + scan->records.size();
        if (newest) {
            result.torn_bytes = scan->torn_bytes;
            result.newest_good_bytes = scan->good_bytes;
            result.newest_next = next;
        }
    }
    return result;
}

} // namespace terrain::journal::detail
