#pragma once

// The server's retained history: the last `capacity` accepted ops by seq, in a fixed ring that
// never reallocates. A reconnecting client whose last seq is still covered gets only the ops it
// missed; otherwise it gets a snapshot. Each slot stores its seq so eviction is detectable.

#include <terrain/deform_op.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrain::server {

struct LoggedOp {
    std::uint64_t seq = 0;
    DeformOp op;
    std::uint64_t world_hash = 0; ///< after the op
};

class OpLog {
  public:
    /// capacity >= 1. `base_seq` is the seq of the state the log starts from (nothing retained).
    OpLog(std::size_t capacity, std::uint64_t base_seq, std::uint64_t base_hash);

    /// Appends the op with seq lastSeq() + 1 (asserted).
    void push(const LoggedOp& entry);

    std::uint64_t lastSeq() const { return last_seq_; }
    /// Oldest state a client may resume from: ops (resumableFrom, lastSeq] are all retained.
    std::uint64_t resumableFrom() const { return oldest_state_seq_; }
    /// World hash of the state at `seq`, when resumableFrom() <= seq <= lastSeq().
    bool hashAt(std::uint64_t seq, std::uint64_t& hash) const;
    /// The op with this seq; requires resumableFrom() < seq <= lastSeq().
    const LoggedOp& at(std::uint64_t seq) const;
    std::size_t capacity() const { return ring_.size(); }

  private:
    std::vector<LoggedOp> ring_;
    std::uint64_t last_seq_;
    std::uint64_t oldest_state_seq_;  // seq of the oldest state whose successors are all kept
    std::uint64_t oldest_state_hash_; // its world hash (needed when nothing is retained yet)
};

} // namespace terrain::server
