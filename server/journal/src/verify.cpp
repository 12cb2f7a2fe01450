// verifyJournal(): the offline check behind terrain-replay. Read-only.

#include "journal_dir.h"
#include "posix_file.h"

#include <terrain/journal/journal.h>
#include <terrain/snapshot.h>

#include <functional>
#include <optional>

namespace terrain::journal {
namespace {

/// Reads and decodes a snapshot file, checking that its seq matches its name.
Result<DecodedSnapshot> loadSnapshot(const detail::DirFile& file) {
    const std::string name = file.path.filename().string();
    auto bytes = detail::readWholeFile(file.path);
    if (!bytes)
        return bytes.error();
    auto decoded = decodeSnapshot(*bytes);
    if (!decoded)
        return makeError(decoded.error().code, name + ": " + decoded.error().message);
    if (decoded->sequence != file.seq)
        return makeError(
            ErrorCode::kBadFormat, name + ": holds seq " + std::to_string(decoded->sequence) +
                                       ", its name says " + std::to_string(file.seq));
    return decoded;
}

/// Called with the base state (record null), then after each record with the state after it.
using Visit = std::function<void(const Terrain& state, const JournalRecord* record)>;

Result<VerifyReport> replayAll(const std::filesystem::path& dir, const Visit& visit) {
    auto listing = detail::listJournalDir(dir);
    if (!listing)
        return listing.error();
    const auto& snapshots = listing->snapshots;
    if (snapshots.empty())
        return makeError(ErrorCode::kIo, "no snapshot in " + dir.string());

    auto base = loadSnapshot(snapshots.front());
    if (!base)
        return base.error();
    VerifyReport report;
    report.base_seq = base->sequence;
    report.snapshots_checked = 1;
    Terrain terrain = std::move(base->terrain);
    if (visit)
        visit(terrain, nullptr);

    // every later snapshot must equal the replayed state at its seq
    std::size_t next_snapshot = 1;
    auto checkSnapshots = [&](std::uint64_t seq, const Terrain& state) -> Status {
        for (; next_snapshot < snapshots.size() && snapshots[next_snapshot].seq == seq;
             ++next_snapshot) {
            auto later = loadSnapshot(snapshots[next_snapshot]);
            if (!later)
                return later.error();
            if (later->terrain.worldHash() != state.worldHash())
                return makeError(
                    ErrorCode::kHashMismatch,
                    snapshots[next_snapshot].path.filename().string() + ": world hash " +
                        detail::hex64(later->terrain.worldHash()) + ", but replay reached " +
                        detail::hex64(state.worldHash()) + " at seq " + std::to_string(seq));
            ++report.snapshots_checked;
        }
        return Ok{};
    };
    auto replay = detail::replaySegments(
        listing->segments, report.base_seq, terrain,
        [&](const JournalRecord& record, const Terrain& state) {
            if (visit)
                visit(state, &record);
            return checkSnapshots(record.seq, state);
        });
    if (!replay)
        return replay.error();
    if (next_snapshot < snapshots.size())
        return makeError(
            ErrorCode::kBadFormat, snapshots[next_snapshot].path.filename().string() +
                                       " is not reached by the journal, which ends at seq " +
                                       std::to_string(replay->last_seq));
    report.last_seq = replay->last_seq;
    report.records_checked = replay->replayed;
    report.segments_checked = replay->segments;
    report.final_hash = terrain.worldHash();
    report.torn_bytes = replay->torn_bytes;
    return report;
}

} // namespace

Result<VerifyReport> verifyJournal(const std::filesystem::path& dir) {
    return replayAll(dir, nullptr);
}

Result<JournalHistory> readJournal(const std::filesystem::path& dir) {
    std::optional<Terrain> base;
    std::vector<JournalRecord> records;
    auto report = replayAll(dir, [&](const Terrain& state, const JournalRecord* record) {
        if (!record)
            base.emplace(state);
        else
            records.push_back(*record);
    });
    if (!report)
        return report.error();
    return JournalHistory{std::move(*base), report->base_seq, std::move(records), *report};
}

} // namespace terrain::journal
