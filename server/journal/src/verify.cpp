// verifyJournal(): the offline check behind terrain-replay. Read-only.

#include "journal_dir.h"
#include "posix_file.h"

#include <terrain/journal/journal.h>
#include <terrain/snapshot.h>

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

} // namespace

Result<VerifyReport> verifyJournal(const std::filesystem::path& dir) {
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
    auto replay =
        detail::replaySegments(listing->segments, report.base_seq, terrain, checkSnapshots);
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

} // namespace terrain::journal
