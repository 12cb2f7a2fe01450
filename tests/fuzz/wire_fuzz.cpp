// libFuzzer target: the server's untrusted-input path, from TCP bytes to an applied op.
// Input: byte 0 picks how the stream is cut into reads; the rest is the TCP stream (varint length
// prefix + Envelope, repeated). Every frame is decoded and handled like the server (deform
// requests) and the client (ops, snapshots, repair state) would, on a small static world.
// Properties: never crash; the frames a FrameReader yields do not depend on how the stream is cut
// and match a reference parse; the reader never holds more than a frame + a read; validateOp()
// and Terrain::apply() agree; a refused op changes nothing; an applied op keeps every invariant
// and the incremental hashes; a canonical op round-trips through the wire form unchanged; a
// snapshot or repair that decodes satisfies every invariant.

#include <terrain/deform_op.h>
#include <terrain/procedural_map.h>
#include <terrain/terrain.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/op_batch.h>
#include <terrain/wire/snapshot_stream.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

namespace {

namespace pb = terrain::v1;
namespace wire = terrain::wire;

constexpr std::size_t kMaxFrame = std::size_t{64} << 10;
constexpr std::size_t kReadChunk = 4096; // as the server's session: prepare(kReadChunk) per read
constexpr std::size_t kMaxSnapshotBytes = std::size_t{1} << 20;

std::optional<terrain::Terrain> g_world;

void check(bool ok) {
    if (!ok)
        __builtin_trap();
}

// Reference framing: the frames of a whole stream, and how it ends (0: clean or cut short inside
// a frame, else the ErrorCode the reader must report).
struct RefFrame {
    std::size_t at = 0;
    std::size_t size = 0;
};
int referenceFrames(std::span<const std::uint8_t> s, std::vector<RefFrame>& out) {
    std::size_t pos = 0;
    while (pos < s.size()) {
        std::uint64_t length = 0;
        std::size_t prefix = 0;
        bool done = false;
        while (pos + prefix < s.size()) {
            const std::uint8_t b = s[pos + prefix];
            length |= std::uint64_t{b & 0x7fu} << (7 * prefix);
            ++prefix;
            if (length > kMaxFrame)
                return static_cast<int>(terrain::ErrorCode::kOutOfRange);
            if ((b & 0x80u) == 0) {
                done = true;
                break;
            }
            if (prefix == wire::kMaxPrefixBytes)
                return static_cast<int>(terrain::ErrorCode::kBadFormat);
        }
        if (!done)
            return 0;
        if (length == 0)
            return static_cast<int>(terrain::ErrorCode::kBadFormat);
        if (s.size() - pos - prefix < length)
            return 0;
        out.push_back({pos + prefix, static_cast<std::size_t>(length)});
        pos += prefix + static_cast<std::size_t>(length);
    }
    return 0;
}

// Both sides apply ops to the same world; validation must agree with apply, refusals change
// nothing, applied ops keep every invariant.
void applyOp(terrain::Terrain& t, const terrain::DeformOp& op) {
    const bool valid = terrain::validateOp(op, t.spec()).ok();
    const std::uint64_t before = t.worldHash();
    const bool applied = t.apply(op).ok();
    check(valid == applied);
    if (!applied) {
        check(t.worldHash() == before);
        return;
    }
    check(t.checkInvariants().ok());
    check(t.worldHash() == t.computeWorldHash());
}

void checkOpRoundTrip(const terrain::DeformOp& op) {
    pb::Op w;
    wire::opToWire(op, w);
    auto back = wire::opFromWire(w);
    check(back.ok() && *back == op);
    pb::OpApplied a;
    wire::opToWire(op, 7, 0x1234, a);
    auto back_applied = wire::opFromWire(a);
    check(back_applied.ok() && *back_applied == op);
}

void onDeform(terrain::Terrain& t, const pb::DeformRequest& request) {
    if (request.has_metres()) {
        auto r = wire::requestFromWire(request.metres());
        if (!r)
            return;
        auto op = terrain::quantizeOp(*r, t.spec());
        if (!op)
            return;
        check(terrain::validateOp(*op, t.spec()).ok()); // quantizeOp validates
        checkOpRoundTrip(*op);
        applyOp(t, *op);
    } else if (request.has_canonical()) {
        auto op = wire::opFromWire(request.canonical());
        if (!op)
            return;
        // any op that passes the range checks re-encodes to the very same fields
        pb::Op again;
        wire::opToWire(*op, again);
        const pb::Op& in = request.canonical();
        check(
            again.kind() == in.kind() && again.center_x() == in.center_x() &&
            again.center_y() == in.center_y() && again.radius() == in.radius() &&
            again.height() == in.height() &&
            again.strength_minus_unit() == in.strength_minus_unit());
        checkOpRoundTrip(*op);
        applyOp(t, *op);
    }
}

void onSnapshotChunk(wire::SnapshotAssembler& assembler, const pb::SnapshotChunk& chunk) {
    if (!assembler.add(chunk).ok() || !assembler.complete())
        return;
    auto decoded = assembler.finish();
    check(!assembler.active());
    if (!decoded)
        return;
    check(decoded->terrain.checkInvariants().ok());
    check(decoded->terrain.worldHash() == decoded->terrain.computeWorldHash());
}

// As Replica::applyRepair: replace the decoded tiles, then the whole must keep every invariant
// (or be refused); what is kept hashes the same incrementally and from scratch.
void onRepair(const terrain::Terrain& t, const pb::RepairState& state) {
    const terrain::WorldSpec& spec = t.spec();
    auto tiles = wire::decodeTiles(
        {reinterpret_cast<const std::uint8_t*>(state.tiles().data()), state.tiles().size()},
        state.raw_bytes(), spec, static_cast<std::size_t>(spec.tileCount()));
    if (!tiles)
        return;
    check(tiles->size() <= static_cast<std::size_t>(spec.tileCount()));
    terrain::Terrain repaired = t;
    for (terrain::TileRecord& record : *tiles) {
        check(record.tile >= 0 && record.tile < spec.tileCount());
        check(
            record.samples.size() == std::size_t{terrain::kTileVertices} * terrain::kTileVertices);
        check(record.originals.size() == record.samples.size());
        repaired.replaceTile(
            record.tile, record.samples, record.originals, std::move(record.patches));
    }
    if (!repaired.checkInvariants().ok())
        return;
    check(repaired.worldHash() == repaired.computeWorldHash());
}

void onWelcome(const pb::Welcome& welcome) {
    auto spec = wire::specFromWire(welcome.world());
    if (!spec)
        return;
    check(spec->validate().ok());
    pb::WorldInfo again;
    wire::specToWire(*spec, again);
    check(
        again.width() == welcome.world().width() && again.height() == welcome.world().height() &&
        again.spacing() == welcome.world().spacing() &&
        again.units_per_metre() == welcome.world().units_per_metre() &&
        again.patch_tolerance() == welcome.world().patch_tolerance());
}

} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    terrain::ProceduralMapOptions o;
    o.width = 129; // two tiles, so that repair records have an order
    o.height = 65;
    o.seed = 11;
    o.wavelength_metres = 24.0;
    auto t = terrain::makeProceduralMap(o);
    if (!t)
        std::abort();
    terrain::DeformOp op;
    op.kind = terrain::OpKind::kCrater;
    op.center_x = 40 * std::int64_t{t->spec().spacing};
    op.center_y = 30 * std::int64_t{t->spec().spacing};
    op.radius = 6 * t->spec().spacing;
    op.height = 2 * t->spec().units_per_metre;
    op.strength = terrain::kUnitStrength / 4;
    if (!t->apply(op).ok())
        std::abort();
    g_world.emplace(std::move(*t));
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0)
        return 0;
    // read sizes: a small xorshift stream seeded by byte 0, up to 1 << (byte0 % 14) bytes each
    std::uint32_t rng = 0x9e3779b9u ^ (std::uint32_t{data[0]} * 0x01000193u);
    const std::size_t max_read = std::size_t{1} << (data[0] % 14);
    const std::span<const std::uint8_t> stream(data + 1, size - 1);

    std::vector<RefFrame> expected;
    const int expected_end = referenceFrames(stream, expected);

    terrain::Terrain t = *g_world;
    wire::FrameReader reader(kMaxFrame);
    wire::SnapshotAssembler assembler(kMaxSnapshotBytes);
    std::size_t frames = 0;
    int end = 0;
    std::size_t pos = 0;
    while (pos < stream.size() && end == 0) {
        rng ^= rng << 13;
        rng ^= rng >> 17;
        rng ^= rng << 5;
        const std::size_t want = std::min<std::size_t>(1 + rng % max_read, stream.size() - pos);
        // a socket read: into the reader's own buffer, at most what prepare() offers
        const std::span<std::uint8_t> space = reader.prepare(kReadChunk);
        check(space.size() >= kReadChunk);
        // the reader's memory: one frame (prefix + body) and one read, never more
        check(reader.buffered() + space.size() <= kMaxFrame + wire::kMaxPrefixBytes + kReadChunk);
        const std::size_t n = std::min(want, space.size());
        std::memcpy(space.data(), stream.data() + pos, n);
        reader.commit(n);
        pos += n;
        for (;;) {
            auto next = reader.next();
            if (!next) {
                end = static_cast<int>(next.error().code);
                break;
            }
            if (!next->has_value())
                break;
            const std::span<const std::uint8_t> body = **next;
            check(frames < expected.size());
            check(body.size() == expected[frames].size);
            check(std::memcmp(body.data(), stream.data() + expected[frames].at, body.size()) == 0);
            ++frames;

            auto envelope = wire::decodeEnvelope(body);
            if (!envelope)
                continue;
            switch (envelope->body_case()) {
            case pb::Envelope::kDeform:
                onDeform(t, envelope->deform());
                break;
            case pb::Envelope::kOpApplied: {
                // the client's replica: range checks, then the same apply
                auto op = wire::opFromWire(envelope->op_applied());
                if (op)
                    applyOp(t, *op);
                break;
            }
            case pb::Envelope::kOpBatch: {
                // a batch: every op through the same range checks and apply; a packed op
                // re-packs to the same bytes
                auto ops = wire::batchFromWire(envelope->op_batch(), 0);
                if (!ops)
                    break;
                std::vector<terrain::DeformOp> plain;
                for (const wire::BatchedOp& b : *ops) {
                    plain.push_back(b.op);
                    applyOp(t, b.op);
                }
                check(wire::packOps(plain) == envelope->op_batch().ops());
                break;
            }
            case pb::Envelope::kSnapshotBegin:
                if (!assembler.begin(envelope->snapshot_begin()).ok())
                    check(!assembler.active());
                break;
            case pb::Envelope::kSnapshotChunk:
                onSnapshotChunk(assembler, envelope->snapshot_chunk());
                break;
            case pb::Envelope::kRepairState:
                onRepair(t, envelope->repair_state());
                break;
            case pb::Envelope::kWelcome:
                onWelcome(envelope->welcome());
                break;
            default:
                break;
            }
        }
        // after draining, at most one incomplete frame stays behind
        if (end == 0)
            check(reader.buffered() < kMaxFrame + wire::kMaxPrefixBytes);
    }
    // the same frames and the same ending, however the stream was cut
    check(frames == expected.size());
    check(end == expected_end);
    if (assembler.active())
        (void)assembler.finish(); // finished early: refused, never a crash
    check(t.checkInvariants().ok());
    check(t.worldHash() == t.computeWorldHash());
    return 0;
}
