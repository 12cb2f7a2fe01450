#include <terrain/wire/codec.h>
#include <terrain/wire/compression.h>
#include <terrain/wire/framing.h>

#include <cstring>
#include <limits>
#include <string>

namespace terrain::wire {
namespace {

constexpr std::uint32_t kKindCount = 4; // wire kind = OpKind - 1

// Op and OpApplied carry the op under the same field names; these read and write them for both
template <typename Message> Result<DeformOp> opFromFields(const Message& m) {
    const std::uint32_t kind = m.kind();
    const std::uint64_t cx = m.center_x();
    const std::uint64_t cy = m.center_y();
    const std::uint32_t radius = m.radius();
    const std::int32_t height = m.height();
    const std::int32_t strength_minus_unit = m.strength_minus_unit();
    if (kind >= kKindCount)
        return makeError(
            ErrorCode::kUnsupported, "op kind " + std::to_string(kind) + " is not 0..3");
    constexpr auto kMaxI64 = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
    if (cx > kMaxI64 || cy > kMaxI64)
        return makeError(ErrorCode::kOutsideMap, "op centre does not fit a signed 64-bit int");
    if (radius > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max()))
        return makeError(ErrorCode::kOutOfRange, "op radius does not fit a signed 32-bit int");
    const std::int64_t strength = std::int64_t{strength_minus_unit} + kUnitStrength;
    if (strength > std::numeric_limits<std::int32_t>::max())
        return makeError(ErrorCode::kOutOfRange, "op strength does not fit 16.16");
    DeformOp op;
    op.kind = static_cast<OpKind>(kind + 1);
    op.center_x = static_cast<std::int64_t>(cx);
    op.center_y = static_cast<std::int64_t>(cy);
    op.radius = static_cast<std::int32_t>(radius);
    op.height = height;
    op.strength = static_cast<std::int32_t>(strength);
    return op;
}

std::uint32_t kindToWire(OpKind kind) {
    return static_cast<std::uint32_t>(kind) - 1;
}

// centres of valid ops are inside the map, hence non-negative; a negative one is sent as a huge
// unsigned value and refused on arrival
std::uint64_t coordToWire(std::int64_t v) {
    return static_cast<std::uint64_t>(v);
}

std::int32_t strengthToWire(std::int32_t strength) {
    return static_cast<std::int32_t>(std::int64_t{strength} - kUnitStrength);
}

template <typename Message> void putOpFields(const DeformOp& op, Message& out) {
    out.set_kind(kindToWire(op.kind));
    out.set_center_x(coordToWire(op.center_x));
    out.set_center_y(coordToWire(op.center_y));
    out.set_radius(static_cast<std::uint32_t>(op.radius));
    out.set_height(op.height);
    out.set_strength_minus_unit(strengthToWire(op.strength));
}

void putU32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int i = 0; i < 4; ++i)
        out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

} // namespace

void appendFrame(const pb::Envelope& envelope, std::vector<std::uint8_t>& out) {
    const std::size_t size = envelope.ByteSizeLong();
    appendFramePrefix(size, out);
    const std::size_t at = out.size();
    out.resize(at + size);
    envelope.SerializeWithCachedSizesToArray(out.data() + at);
}

Frame encodeFrame(const pb::Envelope& envelope) {
    auto bytes = std::make_shared<std::vector<std::uint8_t>>();
    appendFrame(envelope, *bytes);
    return bytes;
}

Result<pb::Envelope> decodeEnvelope(std::span<const std::uint8_t> body) {
    pb::Envelope envelope;
    if (body.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()) ||
        !envelope.ParseFromArray(body.data(), static_cast<int>(body.size())))
        return makeError(ErrorCode::kBadFormat, "frame is not a valid terrain.v1.Envelope");
    if (envelope.body_case() == pb::Envelope::BODY_NOT_SET)
        return makeError(ErrorCode::kBadFormat, "envelope carries no message (unknown field?)");
    return envelope;
}

void opToWire(const DeformOp& op, pb::Op& out) {
    putOpFields(op, out);
}

void opToWire(const DeformOp& op, std::uint64_t seq, std::uint64_t world_hash, pb::OpApplied& out) {
    if (seq % kExplicitSeqEvery == 0)
        out.set_seq(seq);
    out.set_world_hash(world_hash);
    putOpFields(op, out);
}

std::uint64_t appliedSeq(const pb::OpApplied& op, std::uint64_t current_seq) {
    return op.seq() != 0 ? op.seq() : current_seq + 1;
}

Result<DeformOp> opFromWire(const pb::Op& op) {
    return opFromFields(op);
}

Result<DeformOp> opFromWire(const pb::OpApplied& op) {
    return opFromFields(op);
}

void requestToWire(const OpRequest& request, pb::OpMetres& out) {
    out.set_kind(kindToWire(request.kind));
    out.set_x(request.x);
    out.set_y(request.y);
    out.set_radius(request.radius);
    out.set_height(request.height);
    out.set_strength(request.strength);
}

Result<OpRequest> requestFromWire(const pb::OpMetres& request) {
    if (request.kind() >= kKindCount)
        return makeError(
            ErrorCode::kUnsupported, "op kind " + std::to_string(request.kind()) + " is not 0..3");
    OpRequest r;
    r.kind = static_cast<OpKind>(request.kind() + 1);
    r.x = request.x();
    r.y = request.y();
    r.radius = request.radius();
    r.height = request.height();
    r.strength = request.strength();
    return r; // finiteness and ranges: quantizeOp()
}

void specToWire(const WorldSpec& spec, pb::WorldInfo& out) {
    out.set_width(spec.width);
    out.set_height(spec.height);
    out.set_spacing(spec.spacing);
    out.set_units_per_metre(spec.units_per_metre);
    out.set_patch_tolerance(spec.patch_tolerance);
}

Result<WorldSpec> specFromWire(const pb::WorldInfo& info) {
    WorldSpec spec;
    spec.width = info.width();
    spec.height = info.height();
    spec.spacing = info.spacing();
    spec.units_per_metre = info.units_per_metre();
    spec.patch_tolerance = info.patch_tolerance();
    if (Status s = spec.validate(); !s)
        return s.error();
    return spec;
}

pb::Reason reasonFor(ErrorCode code) {
    return static_cast<pb::Reason>(static_cast<int>(code) + 1);
}

void refusalToWire(const Error& error, pb::Refusal& out) {
    out.set_reason(reasonFor(error.code));
    out.set_message(error.message);
}

std::string describe(pb::Reason reason, const std::string& message) {
    std::string name =
        pb::Reason_IsValid(reason) ? pb::Reason_Name(reason) : "REASON_" + std::to_string(reason);
    return message.empty() ? name : name + ": " + message;
}

TileBlob encodeTiles(const Terrain& terrain, std::span<const std::int32_t> tiles) {
    std::vector<std::uint8_t> raw;
    std::vector<std::uint8_t> record;
    for (std::int32_t tile : tiles) {
        record.clear();
        terrain.appendTileBytes(tile, record);
        putU32(raw, static_cast<std::uint32_t>(record.size()));
        raw.insert(raw.end(), record.begin(), record.end());
    }
    TileBlob blob;
    blob.raw_bytes = raw.size();
    blob.compressed = compress(raw);
    return blob;
}

Result<std::vector<TileRecord>> decodeTiles(
    std::span<const std::uint8_t> compressed,
    std::uint64_t raw_bytes,
    const WorldSpec& spec,
    std::size_t max_tiles) {
    // (kMaxTileEntryBytes had lost the length once: a reply whose every cell is patched was
    // refused by 4 bytes a tile)
    Result<std::vector<std::uint8_t>> raw = decompress(
        compressed, static_cast<std::size_t>(raw_bytes),
        static_cast<std::size_t>(kMaxTileEntryBytes * max_tiles));
    if (!raw)
        return raw.error();
    return decodeTileRecords(*raw, spec, max_tiles);
}

Result<std::vector<TileRecord>>
decodeTileRecords(std::span<const std::uint8_t> raw, const WorldSpec& spec, std::size_t max_tiles) {
    std::vector<TileRecord> records;
    std::span<const std::uint8_t> rest(raw);
    while (!rest.empty()) {
        if (records.size() == max_tiles)
            return makeError(ErrorCode::kBadFormat, "more tiles than the map has");
        if (rest.size() < 4)
            return makeError(ErrorCode::kTruncated, "tile record length cut short");
        std::uint32_t length = 0;
        for (int i = 0; i < 4; ++i)
            length |= std::uint32_t{rest[static_cast<std::size_t>(i)]} << (8 * i);
        rest = rest.subspan(4);
        if (length > rest.size())
            return makeError(ErrorCode::kTruncated, "tile record longer than the bytes left");
        Result<TileRecord> record = decodeTile(rest.first(length), spec);
        if (!record)
            return record.error();
        if (!records.empty() && record->tile <= records.back().tile)
            return makeError(ErrorCode::kBadFormat, "tile records are not in ascending order");
        records.push_back(std::move(*record));
        rest = rest.subspan(length);
    }
    return records;
}

} // namespace terrain::wire
