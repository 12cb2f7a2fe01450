#include <terrain/assert.h>
#include <terrain/genesis_delta.h>
#include <terrain/snapshot.h>
#include <terrain/wire/compression.h>
#include <terrain/wire/snapshot_stream.h>

#include <zstd.h>

#include <algorithm>
#include <memory>
#include <string>

namespace terrain::wire {

std::size_t SnapshotFrames::totalBytes() const {
    std::size_t n = 0;
    for (const Frame& f : frames)
        n += f->size();
    return n;
}

namespace {

SnapshotFrames chunked(
    const Terrain& terrain,
    std::uint64_t seq,
    std::uint64_t genesis_hash,
    std::vector<std::uint8_t> raw,
    std::size_t chunk_bytes) {
    const std::vector<std::uint8_t> compressed = compress(raw);
    const std::size_t raw_size = raw.size();
    raw = {}; // freed before the frames copy the compressed bytes: a lower peak
    chunk_bytes = std::max<std::size_t>(chunk_bytes, 1);
    const std::size_t chunks = (compressed.size() + chunk_bytes - 1) / chunk_bytes;

    SnapshotFrames out;
    out.seq = seq;
    out.world_hash = terrain.worldHash();
    out.genesis_hash = genesis_hash;
    out.raw_bytes = raw_size;
    out.compressed_bytes = compressed.size();
    pb::Envelope envelope;
    pb::SnapshotBegin* begin = envelope.mutable_snapshot_begin();
    begin->set_seq(seq);
    begin->set_world_hash(out.world_hash);
    begin->set_raw_bytes(raw_size);
    begin->set_compressed_bytes(compressed.size());
    begin->set_chunk_count(static_cast<std::uint32_t>(chunks));
    begin->set_genesis_hash(genesis_hash);
    out.frames.push_back(encodeFrame(envelope));
    for (std::size_t i = 0; i < chunks; ++i) {
        pb::Envelope chunk_envelope;
        pb::SnapshotChunk* chunk = chunk_envelope.mutable_snapshot_chunk();
        chunk->set_index(static_cast<std::uint32_t>(i));
        const std::size_t at = i * chunk_bytes;
        const std::size_t n = std::min(chunk_bytes, compressed.size() - at);
        chunk->set_data(compressed.data() + at, n);
        out.frames.push_back(encodeFrame(chunk_envelope));
    }
    return out;
}

/// The same frames as chunked(encodeSnapshot()), without the raw snapshot ever held whole: its
/// pieces go through a zstd stream (one frame, its content size pledged), and each chunk's worth
/// of output becomes a frame as it fills.
SnapshotFrames
streamedSnapshot(const Terrain& terrain, std::uint64_t seq, std::size_t chunk_bytes) {
    chunk_bytes = std::max<std::size_t>(chunk_bytes, 1);
    const std::uint64_t raw_size = snapshotBytes(terrain);
    const std::unique_ptr<ZSTD_CCtx, decltype(&ZSTD_freeCCtx)> ctx(
        ZSTD_createCCtx(), ZSTD_freeCCtx);
    ZSTD_CCtx_setParameter(ctx.get(), ZSTD_c_compressionLevel, kDefaultCompressionLevel);
    ZSTD_CCtx_setPledgedSrcSize(ctx.get(), raw_size);
    SnapshotFrames out;
    out.frames.emplace_back(); // SnapshotBegin, once the totals are known
    std::vector<std::uint8_t> chunk(chunk_bytes);
    ZSTD_outBuffer buffer{chunk.data(), chunk.size(), 0};
    std::uint32_t chunks = 0;
    std::uint64_t compressed = 0;
    const auto emit = [&] {
        pb::Envelope envelope;
        pb::SnapshotChunk* c = envelope.mutable_snapshot_chunk();
        c->set_index(chunks++);
        c->set_data(chunk.data(), buffer.pos);
        compressed += buffer.pos;
        out.frames.push_back(encodeFrame(envelope));
        buffer.pos = 0;
    };
    const auto feed = [&](std::span<const std::uint8_t> piece, ZSTD_EndDirective mode) {
        ZSTD_inBuffer in{piece.data(), piece.size(), 0};
        for (;;) {
            const std::size_t left = ZSTD_compressStream2(ctx.get(), &buffer, &in, mode);
            TERRAIN_ASSERT(!ZSTD_isError(left)); // fails only on bad parameters or a wrong pledge
            if (buffer.pos == buffer.size)
                emit();
            if (mode == ZSTD_e_end ? left == 0 : in.pos == in.size)
                break;
        }
    };
    encodeSnapshotTo(
        terrain, seq, [&](std::span<const std::uint8_t> piece) { feed(piece, ZSTD_e_continue); });
    feed({}, ZSTD_e_end);
    if (buffer.pos > 0)
        emit();
    out.seq = seq;
    out.world_hash = terrain.worldHash();
    out.raw_bytes = raw_size;
    out.compressed_bytes = compressed;
    pb::Envelope envelope;
    pb::SnapshotBegin* begin = envelope.mutable_snapshot_begin();
    begin->set_seq(seq);
    begin->set_world_hash(out.world_hash);
    begin->set_raw_bytes(raw_size);
    begin->set_compressed_bytes(compressed);
    begin->set_chunk_count(chunks);
    begin->set_genesis_hash(0);
    out.frames.front() = encodeFrame(envelope);
    return out;
}

} // namespace

SnapshotFrames
buildSnapshotFrames(const Terrain& terrain, std::uint64_t seq, std::size_t chunk_bytes) {
    return streamedSnapshot(terrain, seq, chunk_bytes);
}

SnapshotFrames buildGenesisDeltaFrames(
    const Terrain& terrain,
    std::uint64_t seq,
    std::uint64_t genesis_hash,
    std::size_t chunk_bytes) {
    return chunked(
        terrain, seq, genesis_hash, encodeGenesisDelta(terrain, seq, genesis_hash), chunk_bytes);
}

std::uint64_t maxSnapshotOrDeltaBytes(const WorldSpec& spec) {
    return std::max(maxSnapshotBytes(spec), maxGenesisDeltaBytes(spec));
}

std::uint64_t maxSnapshotBytes(const WorldSpec& spec) {
    constexpr std::uint64_t kHeader = 4 + 4 + 5 * 4 + 8 + 4;
    constexpr std::uint64_t kMaxTileRecord =
        4 + 8 + 2 * 65 * 65 * 4 + 4 + std::uint64_t{kTileCells} * kTileCells * (2 + 25 * 4);
    return kHeader + static_cast<std::uint64_t>(spec.tileCount()) * kMaxTileRecord + 16;
}

struct SnapshotAssembler::Stream {
    ZSTD_DCtx* ctx = ZSTD_createDCtx();
    ~Stream() { ZSTD_freeDCtx(ctx); }
};

SnapshotAssembler::SnapshotAssembler(std::size_t max_raw_bytes)
    : max_raw_bytes_(max_raw_bytes), stream_(std::make_unique<Stream>()) {}

SnapshotAssembler::~SnapshotAssembler() = default;

void SnapshotAssembler::reset() {
    active_ = false;
    next_chunk_ = 0;
    chunk_count_ = 0;
    received_bytes_ = 0;
    raw_filled_ = 0;
    frame_done_ = false;
    genesis_hash_ = 0;
    raw_.reset();
    ZSTD_DCtx_reset(stream_->ctx, ZSTD_reset_session_only);
}

Status SnapshotAssembler::begin(const pb::SnapshotBegin& begin) {
    reset();
    if (begin.raw_bytes() > max_raw_bytes_ || begin.compressed_bytes() > max_raw_bytes_)
        return makeError(
            ErrorCode::kOutOfRange, "snapshot of " + std::to_string(begin.raw_bytes()) +
                                        " bytes is above the client's limit of " +
                                        std::to_string(max_raw_bytes_));
    if (begin.chunk_count() == 0 || begin.compressed_bytes() == 0 || begin.raw_bytes() == 0)
        return makeError(ErrorCode::kBadFormat, "snapshot announces no chunks");
    active_ = true;
    seq_ = begin.seq();
    world_hash_ = begin.world_hash();
    genesis_hash_ = begin.genesis_hash();
    raw_bytes_ = begin.raw_bytes();
    compressed_bytes_ = begin.compressed_bytes();
    chunk_count_ = begin.chunk_count();
    raw_.reset(new std::uint8_t[static_cast<std::size_t>(raw_bytes_)]);
    return Ok{};
}

Status SnapshotAssembler::add(const pb::SnapshotChunk& chunk) {
    if (!active_)
        return makeError(ErrorCode::kBadFormat, "snapshot chunk without a SnapshotBegin");
    if (chunk.index() != next_chunk_ || next_chunk_ >= chunk_count_)
        return makeError(
            ErrorCode::kBadFormat, "snapshot chunk " + std::to_string(chunk.index()) +
                                       " arrived where chunk " + std::to_string(next_chunk_) +
                                       " of " + std::to_string(chunk_count_) + " was expected");
    if (received_bytes_ + chunk.data().size() > compressed_bytes_)
        return makeError(ErrorCode::kBadFormat, "snapshot chunks carry more than announced");
    received_bytes_ += chunk.data().size();
    ZSTD_inBuffer in{chunk.data().data(), chunk.data().size(), 0};
    while (in.pos < in.size) {
        if (frame_done_)
            return makeError(ErrorCode::kBadFormat, "snapshot data continues after its zstd frame");
        ZSTD_outBuffer out{raw_.get(), static_cast<std::size_t>(raw_bytes_), raw_filled_};
        const std::size_t in_before = in.pos;
        const std::size_t ret = ZSTD_decompressStream(stream_->ctx, &out, &in);
        if (ZSTD_isError(ret))
            return makeError(ErrorCode::kBadFormat, std::string("zstd: ") + ZSTD_getErrorName(ret));
        const bool progressed = out.pos != raw_filled_ || ret == 0;
        raw_filled_ = out.pos;
        frame_done_ = ret == 0;
        if (!progressed && in.pos == in_before)
            return makeError(
                ErrorCode::kSizeMismatch, "snapshot decompresses to more than announced");
    }
    ++next_chunk_;
    if (next_chunk_ == chunk_count_ && received_bytes_ != compressed_bytes_)
        return makeError(ErrorCode::kBadFormat, "snapshot chunks carry less than announced");
    return Ok{};
}

Result<DecodedSnapshot> SnapshotAssembler::finish(const Terrain* holder) {
    if (!complete()) {
        reset();
        return makeError(ErrorCode::kTruncated, "snapshot finished before its last chunk");
    }
    if (!frame_done_ || raw_filled_ != raw_bytes_) {
        reset();
        return makeError(
            ErrorCode::kSizeMismatch, "snapshot zstd frame ends early or differs from its size");
    }
    std::unique_ptr<std::uint8_t[]> raw = std::move(raw_);
    const std::size_t raw_size = static_cast<std::size_t>(raw_bytes_);
    const std::uint64_t seq = seq_;
    const std::uint64_t hash = world_hash_;
    const bool delta = genesis_hash_ != 0;
    reset();
    if (delta && holder == nullptr)
        return makeError(
            ErrorCode::kUnsupported, "a genesis delta arrived, but no genesis is held here");
    Result<DecodedSnapshot> decoded = delta ? decodeGenesisDelta({raw.get(), raw_size}, *holder)
                                            : decodeSnapshot({raw.get(), raw_size});
    if (!decoded)
        return decoded.error();
    if (decoded->sequence != seq || decoded->terrain.worldHash() != hash)
        return makeError(
            ErrorCode::kHashMismatch, "snapshot content disagrees with its announced seq/hash");
    return decoded;
}

} // namespace terrain::wire
