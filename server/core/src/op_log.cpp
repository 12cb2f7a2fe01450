#include <terrain/assert.h>
#include <terrain/server/op_log.h>

namespace terrain::server {

OpLog::OpLog(std::size_t capacity, std::uint64_t base_seq, std::uint64_t base_hash)
    : ring_(capacity == 0 ? 1 : capacity), last_seq_(base_seq), oldest_state_seq_(base_seq),
      oldest_state_hash_(base_hash) {}

void OpLog::push(const LoggedOp& entry) {
    TERRAIN_ASSERT(entry.seq == last_seq_ + 1);
    LoggedOp& slot = ring_[entry.seq % ring_.size()];
    if (last_seq_ - oldest_state_seq_ == ring_.size()) {
        // the slot about to be overwritten holds op oldest+1: the oldest resumable state moves up
        oldest_state_seq_ = slot.seq;
        oldest_state_hash_ = slot.world_hash;
    }
    slot = entry;
    last_seq_ = entry.seq;
}

bool OpLog::hashAt(std::uint64_t seq, std::uint64_t& hash) const {
    if (seq < oldest_state_seq_ || seq > last_seq_)
        return false;
    hash = seq == oldest_state_seq_ ? oldest_state_hash_ : ring_[seq % ring_.size()].world_hash;
    return true;
}

const LoggedOp& OpLog::at(std::uint64_t seq) const {
    TERRAIN_ASSERT(seq > oldest_state_seq_ && seq <= last_seq_);
    const LoggedOp& entry = ring_[seq % ring_.size()];
    TERRAIN_ASSERT(entry.seq == seq);
    return entry;
}

} // namespace terrain::server
