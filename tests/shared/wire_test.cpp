// Framing, codec and snapshot streaming, byte-level.

#include "support/terrain_builders.h"

#include <terrain/procedural_map.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/compression.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/op_batch.h>
#include <terrain/wire/snapshot_stream.h>

#include <gtest/gtest.h>

#include <random>

namespace terrain::wire {
namespace {

TEST(Framing, SplitsAStreamFedOneByteAtATime) {
    std::vector<std::uint8_t> stream;
    std::vector<std::size_t> sizes = {1, 127, 128, 300, 16383, 16384, 70000};
    for (std::size_t n : sizes) {
        appendFramePrefix(n, stream);
        for (std::size_t i = 0; i < n; ++i)
            stream.push_back(static_cast<std::uint8_t>(n + i));
    }
    FrameReader reader(1 << 20);
    std::vector<std::size_t> got;
    for (std::uint8_t b : stream) {
        reader.feed({&b, 1});
        auto f = reader.next();
        ASSERT_TRUE(f.ok());
        if (f->has_value()) {
            got.push_back((*f)->size());
            EXPECT_EQ((**f)[0], static_cast<std::uint8_t>((*f)->size()));
        }
    }
    EXPECT_EQ(got, sizes);
    EXPECT_EQ(reader.buffered(), 0u);
}

TEST(Framing, RefusesOversizeBeforeBufferingTheBody) {
    FrameReader reader(1000);
    std::vector<std::uint8_t> bytes;
    appendFramePrefix(1001, bytes);
    reader.feed(bytes);
    auto f = reader.next();
    ASSERT_FALSE(f.ok());
    EXPECT_EQ(f.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(f.error().message.find("limit"), std::string::npos);
    // a huge claim is refused on its first bytes, never allocated
    FrameReader r2(1000);
    const std::uint8_t huge[] = {0xff, 0xff};
    r2.feed(huge);
    EXPECT_FALSE(r2.next().ok());
    EXPECT_LT(r2.buffered(), 8u);
}

TEST(Framing, RefusesLongPrefixAndEmptyFrames) {
    FrameReader reader(kMaxFrameBytesLimit);
    const std::uint8_t longer[] = {0x80, 0x80, 0x80, 0x80, 0x80, 0x00};
    reader.feed(longer);
    auto f = reader.next();
    ASSERT_FALSE(f.ok());
    FrameReader r2;
    const std::uint8_t zero[] = {0x00};
    r2.feed(zero);
    ASSERT_FALSE(r2.next().ok());
    EXPECT_EQ(r2.next().error().code, ErrorCode::kBadFormat);
}

TEST(Codec, OpRoundTripsAndCraterBroadcastFitsIn32Bytes) {
    DeformOp op;
    op.kind = OpKind::kCrater;
    op.center_x = 812 * 1024 + 300;
    op.center_y = 97 * 1024 + 5;
    op.radius = 4 * 1024;
    op.height = 1536;
    op.strength = kUnitStrength;
    pb::Envelope e;
    opToWire(op, 1'500'000, 0x0123456789abcdefULL, *e.mutable_op_applied());
    std::vector<std::uint8_t> frame;
    appendFrame(e, frame);
    EXPECT_LE(frame.size(), 32u);
    FrameReader reader;
    reader.feed(frame);
    auto body = reader.next();
    ASSERT_TRUE(body.ok() && body->has_value());
    auto decoded = decodeEnvelope(**body);
    ASSERT_TRUE(decoded.ok());
    auto back = opFromWire(decoded->op_applied());
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(*back, op);
    EXPECT_EQ(appliedSeq(decoded->op_applied(), 7), 1'500'000u); // explicit: a multiple of 16
    // between explicit seqs the stream position gives the seq, and the frame is 3-4 bytes shorter
    pb::Envelope implicit;
    opToWire(op, 1'500'001, 0x0123456789abcdefULL, *implicit.mutable_op_applied());
    EXPECT_EQ(implicit.op_applied().seq(), 0u);
    EXPECT_EQ(appliedSeq(implicit.op_applied(), 1'500'000), 1'500'001u);
    std::vector<std::uint8_t> shorter;
    appendFrame(implicit, shorter);
    EXPECT_EQ(shorter.size() + 4, frame.size());
    // a crater with a non-default rim strength still fits
    DeformOp rim = op;
    rim.strength = 19661; // 0.3
    pb::Envelope with_rim;
    opToWire(rim, 1'500'001, 0x0123456789abcdefULL, *with_rim.mutable_op_applied());
    std::vector<std::uint8_t> rim_frame;
    appendFrame(with_rim, rim_frame);
    EXPECT_LE(rim_frame.size(), 32u);
    // every kind and a non-default strength round trip too
    for (OpKind k : {OpKind::kRaise, OpKind::kFlatten, OpKind::kSmooth}) {
        op.kind = k;
        op.strength = 12345;
        op.height = -77;
        pb::Op w;
        opToWire(op, w);
        EXPECT_EQ(*opFromWire(w), op);
    }
}

TEST(Codec, RefusesOpsThatDoNotFitTheCoreTypes) {
    pb::Op w;
    w.set_kind(4);
    EXPECT_EQ(opFromWire(w).error().code, ErrorCode::kUnsupported);
    w.set_kind(0);
    w.set_center_x(~0ull);
    EXPECT_EQ(opFromWire(w).error().code, ErrorCode::kOutsideMap);
    w.set_center_x(0);
    w.set_radius(0x80000000u);
    EXPECT_EQ(opFromWire(w).error().code, ErrorCode::kOutOfRange);
    w.set_radius(1);
    w.set_strength_minus_unit(std::numeric_limits<std::int32_t>::max());
    EXPECT_EQ(opFromWire(w).error().code, ErrorCode::kOutOfRange);
    EXPECT_FALSE(decodeEnvelope(std::vector<std::uint8_t>{0xff, 0xff, 0xff}).ok());
    // a valid but empty envelope names the problem
    auto empty = decodeEnvelope(std::vector<std::uint8_t>{0x08, 0x01}); // unknown-less garbage
    EXPECT_FALSE(empty.ok());
}

TEST(Compression, RefusesLiesAboutSize) {
    std::vector<std::uint8_t> raw(10000, 7);
    auto c = compress(raw);
    EXPECT_TRUE(decompress(c, raw.size(), raw.size()).ok());
    EXPECT_EQ(decompress(c, raw.size() + 1, 1 << 20).error().code, ErrorCode::kSizeMismatch);
    EXPECT_EQ(decompress(c, raw.size(), 100).error().code, ErrorCode::kOutOfRange);
    c[c.size() / 2] ^= 0x55;
    c.erase(c.end() - 3, c.end()); // truncated (resize() trips GCC's -O1 stringop check)
    EXPECT_FALSE(decompress(c, raw.size(), raw.size()).ok());
}

Terrain craterMapGenesis() {
    ProceduralMapOptions o;
    o.width = 200;
    o.height = 170;
    return std::move(*makeProceduralMap(o));
}

Terrain craterMap() {
    Terrain t = craterMapGenesis();
    std::mt19937_64 rng(3);
    for (int i = 0; i < 30; ++i) {
        OpRequest r{
            OpKind::kCrater,
            5.0 + static_cast<double>(rng() % 190),
            5.0 + static_cast<double>(rng() % 160),
            3,
            1,
            0.3};
        EXPECT_TRUE(t.apply(*quantizeOp(r, t.spec())).ok());
    }
    return t;
}

TEST(SnapshotStream, ChunkedSnapshotReassemblesToTheSameWorld) {
    Terrain t = craterMap();
    SnapshotFrames frames = buildSnapshotFrames(t, 42, 4096);
    ASSERT_GT(frames.frames.size(), 3u);
    SnapshotAssembler a(1 << 26);
    for (std::size_t i = 0; i < frames.frames.size(); ++i) {
        FrameReader r(1 << 20);
        r.feed(*frames.frames[i]);
        auto env = decodeEnvelope(**r.next());
        ASSERT_TRUE(env.ok());
        if (i == 0)
            ASSERT_TRUE(a.begin(env->snapshot_begin()).ok());
        else
            ASSERT_TRUE(a.add(env->snapshot_chunk()).ok());
    }
    ASSERT_TRUE(a.complete());
    auto s = a.finish();
    ASSERT_TRUE(s.ok()) << s.error().message;
    EXPECT_EQ(s->sequence, 42u);
    EXPECT_EQ(s->terrain.worldHash(), t.worldHash());
    EXPECT_EQ(s->terrain.patchCount(), t.patchCount());
}

TEST(SnapshotStream, RefusesChunksOutOfOrderAndOversizeSnapshots) {
    Terrain t = craterMap();
    SnapshotFrames frames = buildSnapshotFrames(t, 1, 4096);
    std::vector<pb::Envelope> envs;
    for (const Frame& f : frames.frames) {
        FrameReader r(1 << 20);
        r.feed(*f);
        envs.push_back(*decodeEnvelope(**r.next()));
    }
    SnapshotAssembler small(1000);
    EXPECT_EQ(small.begin(envs[0].snapshot_begin()).error().code, ErrorCode::kOutOfRange);
    SnapshotAssembler a(1 << 26);
    ASSERT_TRUE(a.begin(envs[0].snapshot_begin()).ok());
    EXPECT_FALSE(a.add(envs[2].snapshot_chunk()).ok());
    SnapshotAssembler b(1 << 26);
    EXPECT_FALSE(b.add(envs[1].snapshot_chunk()).ok());
    // a lying announced hash is caught after decoding
    pb::SnapshotBegin lie = envs[0].snapshot_begin();
    lie.set_world_hash(lie.world_hash() ^ 1);
    SnapshotAssembler c(1 << 26);
    ASSERT_TRUE(c.begin(lie).ok());
    for (std::size_t i = 1; i < envs.size(); ++i)
        ASSERT_TRUE(c.add(envs[i].snapshot_chunk()).ok());
    EXPECT_EQ(c.finish().error().code, ErrorCode::kHashMismatch);
}

TEST(SnapshotStream, AGenesisDeltaNeedsTheGenesisItWasMadeOn) {
    const Terrain t = craterMap();
    const Terrain genesis = craterMapGenesis();
    const SnapshotFrames frames = buildGenesisDeltaFrames(t, 42, t.genesisHash(), 4096);
    EXPECT_EQ(frames.genesis_hash, t.genesisHash());
    std::vector<pb::Envelope> envs;
    for (const Frame& f : frames.frames) {
        FrameReader r(1 << 20);
        r.feed(*f);
        envs.push_back(*decodeEnvelope(**r.next()));
    }
    EXPECT_EQ(envs[0].snapshot_begin().genesis_hash(), t.genesisHash());
    auto assemble = [&](const Terrain* holder) {
        SnapshotAssembler a(static_cast<std::size_t>(maxSnapshotOrDeltaBytes(t.spec())));
        EXPECT_TRUE(a.begin(envs[0].snapshot_begin()).ok());
        EXPECT_EQ(a.genesisHash(), t.genesisHash());
        for (std::size_t i = 1; i < envs.size(); ++i)
            EXPECT_TRUE(a.add(envs[i].snapshot_chunk()).ok());
        return a.finish(holder);
    };
    auto s = assemble(&genesis);
    ASSERT_TRUE(s.ok()) << s.error().message;
    EXPECT_EQ(s->sequence, 42u);
    EXPECT_EQ(s->terrain.worldHash(), t.worldHash());
    // no state held, or another world's genesis: refused by name (the client then asks for the
    // whole snapshot)
    EXPECT_EQ(assemble(nullptr).error().code, ErrorCode::kUnsupported);
    Terrain other = craterMapGenesis();
    OpRequest r{OpKind::kRaise, 50.0, 50.0, 5.0, 1.0, 1.0};
    ASSERT_TRUE(other.apply(*quantizeOp(r, other.spec())).ok());
    const Terrain other_genesis = [&] {
        // a world whose original ground differs: its samples at creation differ
        WorldSpec spec = t.spec();
        std::vector<std::int32_t> flat(
            static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height), 0);
        return std::move(*Terrain::create(spec, flat));
    }();
    EXPECT_EQ(assemble(&other_genesis).error().code, ErrorCode::kHashMismatch);
    // any later state of the same world holds the genesis
    auto again = assemble(&other);
    ASSERT_TRUE(again.ok()) << again.error().message;
    EXPECT_EQ(again->terrain.worldHash(), t.worldHash());
}

TEST(OpBatch, PacksOpsWithoutTagsAndRefusesWhatIsMalformed) {
    const Terrain t = craterMapGenesis();
    std::vector<DeformOp> ops;
    std::vector<std::uint64_t> hashes;
    for (int i = 0; i < 20; ++i) {
        const OpKind kind = static_cast<OpKind>(1 + i % 4);
        OpRequest r{
            kind,
            10.0 + 7.0 * i,
            20.0 + 5.0 * i,
            1.5 + 0.2 * i,
            kind == OpKind::kFlatten  ? 30.0
            : kind == OpKind::kSmooth ? 0.0
                                      : 0.5 + 0.1 * i,
            kind == OpKind::kRaise ? 1.0 : 0.3};
        auto op = quantizeOp(r, t.spec());
        ASSERT_TRUE(op.ok()) << op.error().message;
        ops.push_back(*op);
        hashes.push_back(1000u + static_cast<std::uint64_t>(i));
    }
    pb::OpBatch batch;
    batchToWire(ops, 17, hashes, false, batch);
    // no tags, no hash per op: a battle-sized op in about 14 bytes
    EXPECT_LT(batch.ops().size(), ops.size() * 16);
    auto back = batchFromWire(batch, 16);
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_EQ(back->size(), ops.size());
    for (std::size_t i = 0; i < ops.size(); ++i) {
        EXPECT_EQ((*back)[i].op, ops[i]);
        EXPECT_EQ((*back)[i].seq, 17 + i);
        EXPECT_EQ((*back)[i].world_hash.has_value(), i + 1 == ops.size());
    }
    EXPECT_EQ(*back->back().world_hash, hashes.back());
    // with every op's hash, and with the first seq implicit
    pb::OpBatch each;
    batchToWire(ops, 0, hashes, true, each);
    auto implicit = batchFromWire(each, 40);
    ASSERT_TRUE(implicit.ok());
    EXPECT_EQ(implicit->front().seq, 41u);
    EXPECT_EQ(*(*implicit)[3].world_hash, hashes[3]);
    // refused: hashes for another count of ops, a truncated op, a number in a longer form
    each.mutable_op_hashes()->RemoveLast();
    EXPECT_EQ(batchFromWire(each, 40).error().code, ErrorCode::kBadFormat);
    pb::OpBatch cut = batch;
    cut.mutable_ops()->pop_back();
    EXPECT_EQ(batchFromWire(cut, 16).error().code, ErrorCode::kBadFormat);
    pb::OpBatch longer;
    longer.set_ops(std::string("\x80\x00\x01\x01\x01\x00\x00", 7)); // kind 0 in two bytes
    EXPECT_EQ(batchFromWire(longer, 0).error().code, ErrorCode::kBadFormat);
    pb::OpBatch empty;
    EXPECT_EQ(batchFromWire(empty, 0).error().code, ErrorCode::kBadFormat);
    pb::OpBatch bad_kind;
    bad_kind.set_ops(std::string("\x09\x01\x01\x01\x00\x00", 6));
    EXPECT_FALSE(batchFromWire(bad_kind, 0).ok());
}

TEST(TileBlob, RoundTripsAndRefusesDisorder) {
    Terrain t = craterMap();
    const std::vector<std::int32_t> tiles = {0, 2, 5};
    TileBlob blob = encodeTiles(t, tiles);
    auto records = decodeTiles(blob.compressed, blob.raw_bytes, t.spec(), 16);
    ASSERT_TRUE(records.ok()) << records.error().message;
    ASSERT_EQ(records->size(), 3u);
    EXPECT_EQ((*records)[2].tile, 5);
    const std::vector<std::int32_t> disorder = {2, 0};
    TileBlob bad = encodeTiles(t, disorder);
    EXPECT_EQ(
        decodeTiles(bad.compressed, bad.raw_bytes, t.spec(), 16).error().code,
        ErrorCode::kBadFormat);
    EXPECT_FALSE(decodeTiles(blob.compressed, blob.raw_bytes, t.spec(), 2).ok());
}

TEST(TileBlob, TheSizeLimitAdmitsAWhollyPatchedTile) {
    // one entry of a tile whose 4096 cells are all patched: u32 length + 451,604 bytes of
    // record. The limit must let it through to the record checks (here: a zeroed record,
    // refused for what it holds, not for its size); one byte more is over the limit.
    constexpr std::size_t kEntry = 4 + 12 + 2 * 65 * 65 * 4 + 64 * 64 * 102;
    static_assert(kEntry == 451'608);
    const Terrain t = craterMap();
    const std::vector<std::uint8_t> whole(kEntry, 0);
    const auto fits = decodeTiles(compress(whole), kEntry, t.spec(), 1);
    ASSERT_FALSE(fits.ok());
    EXPECT_NE(fits.error().code, ErrorCode::kOutOfRange) << fits.error().message;
    const std::vector<std::uint8_t> over(kEntry + 1, 0);
    const auto too_big = decodeTiles(compress(over), kEntry + 1, t.spec(), 1);
    ASSERT_FALSE(too_big.ok());
    EXPECT_EQ(too_big.error().code, ErrorCode::kOutOfRange) << too_big.error().message;
}

} // namespace
} // namespace terrain::wire
