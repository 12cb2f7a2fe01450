#include <terrain/varint.h>
#include <terrain/wire/op_batch.h>

#include <string>

namespace terrain::wire {

std::string packOps(std::span<const DeformOp> ops) {
    std::string out;
    out.reserve(ops.size() * 16);
    pb::Op wire;
    for (const DeformOp& op : ops) {
        opToWire(op, wire); // the same field mapping as an Op message
        varint::put(out, wire.kind());
        varint::put(out, wire.center_x());
        varint::put(out, wire.center_y());
        varint::put(out, wire.radius());
        varint::putSigned(out, wire.height());
        varint::putSigned(out, wire.strength_minus_unit());
    }
    return out;
}

Result<std::vector<DeformOp>> unpackOps(std::span<const std::uint8_t> bytes, std::size_t max_ops) {
    std::vector<DeformOp> ops;
    std::size_t at = 0;
    pb::Op wire;
    while (at < bytes.size()) {
        if (ops.size() == max_ops)
            return makeError(
                ErrorCode::kBadFormat,
                "op batch holds more than " + std::to_string(max_ops) + " ops");
        std::uint64_t kind = 0;
        std::uint64_t x = 0;
        std::uint64_t y = 0;
        std::uint64_t radius = 0;
        std::int32_t height = 0;
        std::int32_t strength = 0;
        if (!varint::read(bytes, at, kind) || !varint::read(bytes, at, x) ||
            !varint::read(bytes, at, y) || !varint::read(bytes, at, radius) ||
            !varint::readSigned(bytes, at, height) || !varint::readSigned(bytes, at, strength))
            return makeError(
                ErrorCode::kBadFormat,
                "op " + std::to_string(ops.size()) +
                    " of a batch is truncated or has a number too long or not in its shortest "
                    "form");
        if (kind > 0xffffffffu || radius > 0xffffffffu)
            return makeError(
                ErrorCode::kOutOfRange,
                "op " + std::to_string(ops.size()) + " of a batch: kind or radius beyond 32 bits");
        wire.set_kind(static_cast<std::uint32_t>(kind));
        wire.set_center_x(x);
        wire.set_center_y(y);
        wire.set_radius(static_cast<std::uint32_t>(radius));
        wire.set_height(height);
        wire.set_strength_minus_unit(strength);
        Result<DeformOp> op = opFromWire(wire);
        if (!op)
            return op.error();
        ops.push_back(*op);
    }
    return ops;
}

void batchToWire(
    std::span<const DeformOp> ops,
    std::uint64_t first_seq,
    std::span<const std::uint64_t> hashes,
    bool per_op_hashes,
    pb::OpBatch& out) {
    out.set_first_seq(first_seq);
    out.set_world_hash(hashes.empty() ? 0 : hashes.back());
    out.set_ops(packOps(ops));
    if (per_op_hashes)
        for (std::uint64_t h : hashes)
            out.add_op_hashes(h);
}

Result<std::vector<BatchedOp>> batchFromWire(const pb::OpBatch& batch, std::uint64_t current_seq) {
    Result<std::vector<DeformOp>> ops = unpackOps(
        {reinterpret_cast<const std::uint8_t*>(batch.ops().data()), batch.ops().size()},
        kMaxBatchOps);
    if (!ops)
        return ops.error();
    if (ops->empty())
        return makeError(ErrorCode::kBadFormat, "op batch holds no op");
    if (batch.op_hashes_size() != 0 &&
        static_cast<std::size_t>(batch.op_hashes_size()) != ops->size())
        return makeError(
            ErrorCode::kBadFormat, "op batch has " + std::to_string(batch.op_hashes_size()) +
                                       " hashes for " + std::to_string(ops->size()) + " ops");
    const std::uint64_t first = batch.first_seq() != 0 ? batch.first_seq() : current_seq + 1;
    std::vector<BatchedOp> out(ops->size());
    for (std::size_t i = 0; i < ops->size(); ++i) {
        out[i].seq = first + i;
        out[i].op = (*ops)[i];
        if (batch.op_hashes_size() != 0)
            out[i].world_hash = batch.op_hashes(static_cast<int>(i));
        else if (i + 1 == ops->size())
            out[i].world_hash = batch.world_hash();
    }
    return out;
}

} // namespace terrain::wire
