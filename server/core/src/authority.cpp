#include <terrain/server/authority.h>

#include <string>
#include <utility>

namespace terrain::server {

Authority::Authority(
    Terrain terrain, std::uint64_t seq, std::size_t log_capacity, TaskRunner* runner)
    : terrain_(std::move(terrain)), seq_(seq), log_(log_capacity, seq, terrain_.worldHash()),
      runner_(runner) {}

Result<Accepted> Authority::apply(const OpRequest& request) {
    Result<DeformOp> op = quantizeOp(request, terrain_.spec());
    if (!op)
        return op.error();
    return apply(*op);
}

Result<Accepted> Authority::apply(const DeformOp& op) {
    Result<OpEffect> effect =
        terrain_.apply(op, runner_); // validates first; refusals change nothing
    if (!effect)
        return effect.error();
    ++seq_;
    Accepted accepted{seq_, terrain_.worldHash(), op, std::move(*effect)};
    log_.push(LoggedOp{seq_, op, accepted.world_hash});
    return accepted;
}

Status Authority::restoreLog(
    std::uint64_t base_seq, std::uint64_t base_hash, std::span<const LoggedOp> ops) {
    if (base_seq + ops.size() != seq_)
        return makeError(
            ErrorCode::kOutOfRange, "history from seq " + std::to_string(base_seq) + " with " +
                                        std::to_string(ops.size()) + " ops does not end at seq " +
                                        std::to_string(seq_));
    for (std::size_t i = 0; i < ops.size(); ++i)
        if (ops[i].seq != base_seq + 1 + i)
            return makeError(
                ErrorCode::kOutOfRange, "history op " + std::to_string(i) + " has seq " +
                                            std::to_string(ops[i].seq) + ", not " +
                                            std::to_string(base_seq + 1 + i));
    const std::uint64_t last_hash = ops.empty() ? base_hash : ops.back().world_hash;
    if (last_hash != terrain_.worldHash())
        return makeError(
            ErrorCode::kHashMismatch,
            "history ends at a world hash other than the terrain's (seq " + std::to_string(seq_) +
                ")");
    // only the last capacity ops fit; the log's base is the state before the first kept one
    const std::size_t skip = ops.size() > log_.capacity() ? ops.size() - log_.capacity() : 0;
    OpLog log(log_.capacity(), base_seq + skip, skip == 0 ? base_hash : ops[skip - 1].world_hash);
    for (std::size_t i = skip; i < ops.size(); ++i)
        log.push(ops[i]);
    log_ = std::move(log);
    return Ok{};
}

} // namespace terrain::server
