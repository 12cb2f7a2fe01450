#pragma once

// The one place where protobuf types (terrain.v1) meet core types. The net layers on both sides
// build and read Envelopes; everything behind them (authority, journal, replica) sees only core
// types. Every conversion from the wire treats its input as untrusted and names the rule broken.
//
// Frame layout: varint length | Envelope (see proto/PROTOCOL.md).

#include <terrain/deform_op.h>
#include <terrain/result.h>
#include <terrain/snapshot.h>
#include <terrain/terrain.h>
#include <terrain/v1/session.pb.h>
#include <terrain/world_spec.h>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace terrain::wire {

namespace pb = ::terrain::v1;

/// 2: the crater model anchored to the ground around it (v1 craters were additive); the
/// messages are those of v1.
inline constexpr std::uint32_t kProtocolVersion = 2;

/// An encoded frame (prefix + envelope), shared by every session that sends it.
using Frame = std::shared_ptr<const std::vector<std::uint8_t>>;

Frame encodeFrame(const pb::Envelope& envelope);
/// Appends prefix + envelope to `out` (benchmarks and tests).
void appendFrame(const pb::Envelope& envelope, std::vector<std::uint8_t>& out);

/// Parses one frame body. Errors: kBadFormat (protobuf refused the bytes, or no body is set).
Result<pb::Envelope> decodeEnvelope(std::span<const std::uint8_t> body);

// ops
void opToWire(const DeformOp& op, pb::Op& out);
/// Every op stream is gap-free (ops follow each other, a snapshot at S, or a resume from
/// last_seq), so OpApplied states its seq only when seq % kExplicitSeqEvery == 0 and is
/// otherwise the receiver's seq + 1: 3-4 bytes saved per op, and a misaligned stream is still
/// caught by the world hash at once and by the explicit seq within 16 ops.
inline constexpr std::uint64_t kExplicitSeqEvery = 16;
void opToWire(const DeformOp& op, std::uint64_t seq, std::uint64_t world_hash, pb::OpApplied& out);
/// The seq of an OpApplied received by a replica at `current_seq`.
std::uint64_t appliedSeq(const pb::OpApplied& op, std::uint64_t current_seq);
/// Range checks only (kind known, fields fit the core types); validateOp() checks the world.
Result<DeformOp> opFromWire(const pb::Op& op);
Result<DeformOp> opFromWire(const pb::OpApplied& op);
void requestToWire(const OpRequest& request, pb::OpMetres& out);
Result<OpRequest> requestFromWire(const pb::OpMetres& request);

// world
void specToWire(const WorldSpec& spec, pb::WorldInfo& out);
/// Errors: the spec's own rules (WorldSpec::validate).
Result<WorldSpec> specFromWire(const pb::WorldInfo& info);

// refusals
pb::Reason reasonFor(ErrorCode code);
void refusalToWire(const Error& error, pb::Refusal& out);
/// "REASON_OUT_OF_RANGE: radius 0.2 m is below ..." for logs and error messages.
std::string describe(pb::Reason reason, const std::string& message);

// repair: tile records (Terrain::appendTileBytes), each behind a u32 length, zstd-compressed
struct TileBlob {
    std::vector<std::uint8_t> compressed;
    std::uint64_t raw_bytes = 0;
};
TileBlob encodeTiles(const Terrain& terrain, std::span<const std::int32_t> tiles);
/// Errors: decompression's, kBadFormat/kTruncated for records, decodeTile()'s rules, and
/// kBadFormat for tiles out of ascending order or more than max_tiles.
Result<std::vector<TileRecord>> decodeTiles(
    std::span<const std::uint8_t> compressed,
    std::uint64_t raw_bytes,
    const WorldSpec& spec,
    std::size_t max_tiles);
/// decodeTiles() after the zstd frame: the records themselves, each behind its u32 length.
Result<std::vector<TileRecord>>
decodeTileRecords(std::span<const std::uint8_t> raw, const WorldSpec& spec, std::size_t max_tiles);
/// The most bytes one entry of decodeTileRecords() takes: the u32 length, then a tile record
/// with every cell patched.
inline constexpr std::uint64_t kMaxTileEntryBytes = 4 + 12 + 2 * 65 * 65 * 4 + 64 * 64 * 102;

} // namespace terrain::wire
