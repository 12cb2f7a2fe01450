#include <terrain/journal/record_codec.h>

#include <xxhash.h>

#include <cstring>

namespace terrain::journal {
namespace {

constexpr std::uint8_t kSegmentMagic[4] = {'T', 'J', 'S', 'G'};
constexpr std::uint8_t kRecordMagic[4] = {'T', 'J', 'R', '1'};

void putLe(std::vector<std::uint8_t>& out, std::uint64_t v, int bytes) {
    for (int b = 0; b < bytes; ++b)
        out.push_back(static_cast<std::uint8_t>(v >> (8 * b)));
}

std::uint64_t getLe(std::span<const std::uint8_t> bytes, std::size_t at, int n) {
    std::uint64_t v = 0;
    for (int b = 0; b < n; ++b)
        v |= static_cast<std::uint64_t>(bytes[at + static_cast<std::size_t>(b)]) << (8 * b);
    return v;
}

std::uint64_t checksum(std::span<const std::uint8_t> bytes) {
    return XXH3_64bits(bytes.data(), bytes.size());
}

} // namespace

void appendSegmentHeader(std::uint64_t first_seq, std::vector<std::uint8_t>& out) {
    const std::size_t at = out.size();
    out.insert(out.end(), kSegmentMagic, kSegmentMagic + 4);
    putLe(out, kSegmentVersion, 4);
    putLe(out, first_seq, 8);
    putLe(out, checksum(std::span(out).subspan(at, 16)), 8);
}

Result<std::uint64_t> decodeSegmentHeader(std::span<const std::uint8_t> bytes) {
    if (bytes.size() < kSegmentHeaderSize)
        return makeError(ErrorCode::kTruncated, "segment header is shorter than 24 bytes");
    if (std::memcmp(bytes.data(), kSegmentMagic, 4) != 0)
        return makeError(ErrorCode::kBadFormat, "not a journal segment (magic is not TJSG)");
    if (getLe(bytes, 16, 8) != checksum(bytes.first(16)))
        return makeError(ErrorCode::kHashMismatch, "segment header checksum differs");
    if (const std::uint64_t version = getLe(bytes, 4, 4); version != kSegmentVersion)
        return makeError(
            ErrorCode::kUnsupported, "journal segment version " + std::to_string(version) +
                                         " is not supported (this build " + "reads version " +
                                         std::to_string(kSegmentVersion) +
                                         ": v1 journals hold v1 craters)");
    return getLe(bytes, 8, 8);
}

void appendRecord(const JournalRecord& record, std::vector<std::uint8_t>& out) {
    const std::size_t at = out.size();
    out.insert(out.end(), kRecordMagic, kRecordMagic + 4);
    putLe(out, record.seq, 8);
    putLe(out, static_cast<std::uint8_t>(record.op.kind), 1);
    putLe(out, static_cast<std::uint64_t>(record.op.center_x), 8);
    putLe(out, static_cast<std::uint64_t>(record.op.center_y), 8);
    putLe(out, static_cast<std::uint32_t>(record.op.radius), 4);
    putLe(out, static_cast<std::uint32_t>(record.op.height), 4);
    putLe(out, static_cast<std::uint32_t>(record.op.strength), 4);
    putLe(out, record.world_hash, 8);
    putLe(out, checksum(std::span(out).subspan(at, kRecordSize - 8)), 8);
}

Result<JournalRecord> decodeRecord(std::span<const std::uint8_t> bytes) {
    if (bytes.size() < kRecordSize)
        return makeError(ErrorCode::kTruncated, "record is shorter than 57 bytes");
    if (std::memcmp(bytes.data(), kRecordMagic, 4) != 0)
        return makeError(ErrorCode::kBadFormat, "record magic is not TJR1");
    if (getLe(bytes, kRecordSize - 8, 8) != checksum(bytes.first(kRecordSize - 8)))
        return makeError(ErrorCode::kHashMismatch, "record checksum differs");
    JournalRecord r;
    r.seq = getLe(bytes, 4, 8);
    r.op.kind = static_cast<OpKind>(bytes[12]);
    r.op.center_x = static_cast<std::int64_t>(getLe(bytes, 13, 8));
    r.op.center_y = static_cast<std::int64_t>(getLe(bytes, 21, 8));
    r.op.radius = static_cast<std::int32_t>(getLe(bytes, 29, 4));
    r.op.height = static_cast<std::int32_t>(getLe(bytes, 33, 4));
    r.op.strength = static_cast<std::int32_t>(getLe(bytes, 37, 4));
    r.world_hash = getLe(bytes, 41, 8);
    return r;
}

} // namespace terrain::journal
