#pragma once

// The authority: owns the terrain, validates and applies ops, numbers them and keeps the
// retained log. No I/O, no clocks, no sockets: the net layer and the journal sit around it.
// Not thread safe; the server's single io thread owns it (ARCHITECTURE.md).

#include <terrain/deform_op.h>
#include <terrain/result.h>
#include <terrain/server/op_log.h>
#include <terrain/terrain.h>

#include <cstddef>
#include <cstdint>
#include <span>

namespace terrain::server {

struct Accepted {
    std::uint64_t seq = 0;
    std::uint64_t world_hash = 0; ///< after the op
    DeformOp op;                  ///< canonical form as applied and broadcast
    OpEffect effect;
};

class Authority {
  public:
    /// Starts from `terrain` at `seq` (0 for a fresh world, the journal's last seq on restart).
    /// Ops apply on `runner` (not owned; null: serially): the same bits either way.
    Authority(
        Terrain terrain, std::uint64_t seq, std::size_t log_capacity, TaskRunner* runner = nullptr);

    /// Validates (quantizeOp) and applies. On refusal nothing changes and seq stays.
    Result<Accepted> apply(const OpRequest& request);
    /// Validates (validateOp) and applies a canonical op (replay, trusted tools, wire ops).
    Result<Accepted> apply(const DeformOp& op);

    /// Refills the retained log after a restart: `ops` are seqs base_seq + 1 ... seq(), in
    /// order, and base_hash the world hash at base_seq (the journal's recovered history). Only
    /// the last log capacity ops are kept. Nothing changes on an error.
    /// Errors: kOutOfRange when the ops do not end at seq() or are not consecutive;
    /// kHashMismatch when the last one's hash (or base_hash, with no ops) is not the terrain's.
    Status
    restoreLog(std::uint64_t base_seq, std::uint64_t base_hash, std::span<const LoggedOp> ops);

    const Terrain& terrain() const { return terrain_; }
    std::uint64_t seq() const { return seq_; }
    const OpLog& log() const { return log_; }

  private:
    Terrain terrain_;
    std::uint64_t seq_;
    OpLog log_;
    TaskRunner* runner_ = nullptr;
};

} // namespace terrain::server
