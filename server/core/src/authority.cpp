#include <terrain/server/authority.h>

#include <utility>

namespace terrain::server {

Authority::Authority(Terrain terrain, std::uint64_t seq, std::size_t log_capacity)
    : terrain_(std::move(terrain)), seq_(seq), log_(log_capacity, seq, terrain_.worldHash()) {}

Result<Accepted> Authority::apply(const OpRequest& request) {
    Result<DeformOp> op = quantizeOp(request, terrain_.spec());
    if (!op)
        return op.error();
    return apply(*op);
}

Result<Accepted> Authority::apply(const DeformOp& op) {
    Result<OpEffect> effect = terrain_.apply(op); // validates first; refusals change nothing
    if (!effect)
        return effect.error();
    ++seq_;
    Accepted accepted{seq_, terrain_.worldHash(), op, std::move(*effect)};
    log_.push(LoggedOp{seq_, op, accepted.world_hash});
    return accepted;
}

} // namespace terrain::server
