#include <terrain/replay/live_replay.h>

#include <algorithm>

namespace terrain::replay {

bool replayAgreed(const journal::JournalHistory& history, const LiveRunResult& result) {
    const std::uint64_t ops = history.records.size();
    if (result.timed_out || result.refused() > 0 || result.ops_renumbered > 0 ||
        result.first_divergence || result.ops_accepted != ops)
        return false;
    return std::all_of(result.clients.begin(), result.clients.end(), [&](const ClientTally& c) {
        return c.checked == ops && c.mismatches == 0 && c.final_seq == history.base_seq + ops;
    });
}

Result<Terrain> stateAt(const journal::JournalHistory& history, std::uint64_t seq) {
    if (seq < history.base_seq || seq > history.base_seq + history.records.size())
        return makeError(
            ErrorCode::kOutOfRange, "seq " + std::to_string(seq) + " is outside the journal (" +
                                        std::to_string(history.base_seq) + ".." +
                                        std::to_string(history.base_seq + history.records.size()) +
                                        ")");
    Terrain state = history.base;
    for (const journal::JournalRecord& record : history.records) {
        if (record.seq > seq)
            break;
        if (auto applied = state.apply(record.op); !applied)
            return applied.error();
    }
    return state;
}

Result<LiveRunResult>
runLiveReplay(const journal::JournalHistory& history, const LiveRunOptions& options) {
    const auto record = [&history](std::uint64_t seq) -> const journal::JournalRecord* {
        if (seq <= history.base_seq || seq > history.base_seq + history.records.size())
            return nullptr;
        return &history.records[seq - history.base_seq - 1];
    };
    std::size_t next = 0;
    LiveRunInput input;
    input.base = &history.base;
    input.base_seq = history.base_seq;
    input.next = [&](const client::Replica&) -> std::optional<FeedRequest> {
        if (next == history.records.size())
            return std::nullopt;
        return history.records[next++].op;
    };
    input.expected_hash = [&](std::uint64_t seq) -> std::optional<std::uint64_t> {
        const journal::JournalRecord* r = record(seq);
        return r ? std::optional(r->world_hash) : std::nullopt;
    };
    input.expected_op = [&](std::uint64_t seq) -> std::optional<DeformOp> {
        const journal::JournalRecord* r = record(seq);
        return r ? std::optional(r->op) : std::nullopt;
    };
    input.stop_on_refusal = true;
    return runLive(input, options);
}

} // namespace terrain::replay
