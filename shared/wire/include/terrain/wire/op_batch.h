#pragma once

// Tick batching: the ops of one group commit in one OpBatch frame, packed without protobuf tags,
// for bursts (a battle) where the per-op envelope, tags and hash were half of every op's bytes.
// Packed op: var kind (0 crater .. 3 smooth), var center_x, var center_y, var radius, zig height,
// zig (strength - 65536); var = LEB128 (at most 10 bytes, shortest form), zig = zigzag then
// LEB128 (PROTOCOL.md, "OpBatch").

#include <terrain/deform_op.h>
#include <terrain/result.h>
#include <terrain/wire/codec.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace terrain::wire {

/// The packed bytes of `ops`, in order.
std::string packOps(std::span<const DeformOp> ops);

/// Errors: kBadFormat (truncated, a number too long or not in its shortest form, more than
/// `max_ops` ops), opFromWire()'s range checks.
Result<std::vector<DeformOp>> unpackOps(std::span<const std::uint8_t> bytes, std::size_t max_ops);

/// An OpBatch of ops `first_seq` ... with `hashes` (the world hash after each op). `per_op_hashes`:
/// every op's hash travels (op_hashes), else only the last one's (world_hash).
void batchToWire(
    std::span<const DeformOp> ops,
    std::uint64_t first_seq,
    std::span<const std::uint64_t> hashes,
    bool per_op_hashes,
    pb::OpBatch& out);

/// One op of a batch as a receiver applies it: the hash to check after it, when it has one.
struct BatchedOp {
    std::uint64_t seq = 0;
    DeformOp op;
    std::optional<std::uint64_t> world_hash;
};

/// A received OpBatch, for a receiver whose last op is `current_seq`. Errors: unpackOps()'s;
/// kBadFormat for an empty batch or op_hashes of another length than the ops.
Result<std::vector<BatchedOp>> batchFromWire(const pb::OpBatch& batch, std::uint64_t current_seq);

/// At most this many ops in one batch (the server cuts longer groups): bounds a frame.
inline constexpr std::size_t kMaxBatchOps = 4096;

} // namespace terrain::wire
