#include "byte_io.h"

#include <terrain/snapshot.h>

#include <xxhash.h>

#include <string>

namespace terrain {
namespace {

constexpr std::uint8_t kMagic[4] = {'T', 'R', 'S', 'N'};

Error truncated(const char* what) {
    return makeError(ErrorCode::kTruncated, std::string("snapshot truncated in ") + what);
}

} // namespace

std::uint64_t snapshotBytes(const Terrain& terrain) {
    const WorldSpec& s = terrain.spec();
    constexpr std::uint64_t kHeader = 4 + 4 + 5 * 4 + 8 + 4;
    constexpr std::uint64_t kTileFixed =
        4 + 8 + 2 * std::uint64_t{kTileVertices} * kTileVertices * 4 + 4;
    constexpr std::uint64_t kPatch = 2 + 4 * std::uint64_t{kPatchControls};
    return kHeader + static_cast<std::uint64_t>(s.tileCount()) * kTileFixed +
           kPatch * terrain.patchCount() + 16;
}

void encodeSnapshotTo(
    const Terrain& terrain,
    std::uint64_t sequence,
    const SnapshotSink& sink,
    std::size_t piece_bytes) {
    const WorldSpec& s = terrain.spec();
    XXH3_state_t* const checksum = XXH3_createState();
    XXH3_64bits_reset(checksum);
    std::vector<std::uint8_t> piece(kMagic, kMagic + 4);
    piece.reserve(piece_bytes + (std::size_t{1} << 16));
    const auto flush = [&] {
        XXH3_64bits_update(checksum, piece.data(), piece.size());
        sink(piece);
        piece.clear();
    };
    detail::putU32(piece, kSnapshotVersion);
    for (std::int32_t v : {s.width, s.height, s.spacing, s.units_per_metre, s.patch_tolerance})
        detail::putI32(piece, v);
    detail::putU64(piece, sequence);
    detail::putU32(piece, static_cast<std::uint32_t>(s.tileCount()));
    for (std::int32_t tile = 0; tile < s.tileCount(); ++tile) {
        const std::size_t at = piece.size();
        detail::putU32(piece, 0); // length, patched below
        terrain.appendTileBytes(tile, piece);
        const auto length = static_cast<std::uint32_t>(piece.size() - at - 4);
        for (int b = 0; b < 4; ++b)
            piece[at + static_cast<std::size_t>(b)] = static_cast<std::uint8_t>(length >> (8 * b));
        if (piece.size() >= piece_bytes)
            flush();
    }
    detail::putU64(piece, terrain.worldHash());
    // the checksum covers what the world hash does not: the header and the sequence number
    XXH3_64bits_update(checksum, piece.data(), piece.size());
    detail::putU64(piece, XXH3_64bits_digest(checksum));
    XXH3_freeState(checksum);
    sink(piece);
}

std::vector<std::uint8_t> encodeSnapshot(const Terrain& terrain, std::uint64_t sequence) {
    std::vector<std::uint8_t> out;
    out.reserve(static_cast<std::size_t>(snapshotBytes(terrain)));
    encodeSnapshotTo(terrain, sequence, [&](std::span<const std::uint8_t> piece) {
        out.insert(out.end(), piece.begin(), piece.end());
    });
    return out;
}

Result<TileRecord> decodeTile(std::span<const std::uint8_t> bytes, const WorldSpec& spec) {
    detail::ByteReader r(bytes);
    std::uint32_t tx = 0;
    std::uint32_t ty = 0;
    if (!r.u32(tx) || !r.u32(ty))
        return makeError(ErrorCode::kTruncated, "tile record truncated in its header");
    if (tx >= static_cast<std::uint32_t>(spec.tilesX()) ||
        ty >= static_cast<std::uint32_t>(spec.tilesY()))
        return makeError(
            ErrorCode::kOutOfRange, "tile (" + std::to_string(tx) + ", " + std::to_string(ty) +
                                        ") is outside the " + std::to_string(spec.tilesX()) +
                                        " x " + std::to_string(spec.tilesY()) + " tile grid");
    TileRecord rec;
    rec.tile = static_cast<std::int32_t>(ty) * spec.tilesX() + static_cast<std::int32_t>(tx);
    rec.samples.resize(kTileVertices * kTileVertices);
    if (!r.i32s(rec.samples.data(), rec.samples.size()))
        return makeError(ErrorCode::kTruncated, "tile record truncated in its samples");
    for (std::int32_t v : rec.samples) {
        if (v > kMaxHeightQuanta || v < -kMaxHeightQuanta)
            return makeError(
                ErrorCode::kOutOfRange,
                "sample " + std::to_string(v) + " is beyond the height limit");
    }
    rec.originals.resize(kTileVertices * kTileVertices);
    if (!r.i32s(rec.originals.data(), rec.originals.size()))
        return makeError(ErrorCode::kTruncated, "tile record truncated in its displacements");
    for (std::size_t i = 0; i < rec.originals.size(); ++i) {
        // sample - displacement, without overflow: both are within int32
        const std::int64_t original = std::int64_t{rec.samples[i]} - rec.originals[i];
        if (original > kMaxHeightQuanta || original < -kMaxHeightQuanta)
            return makeError(
                ErrorCode::kOutOfRange,
                "original ground " + std::to_string(original) + " is beyond the height limit");
        rec.originals[i] = static_cast<std::int32_t>(original);
    }
    std::uint32_t count = 0;
    if (!r.u32(count))
        return makeError(ErrorCode::kTruncated, "tile record truncated before its patch count");
    if (count > static_cast<std::uint32_t>(kTileCells * kTileCells))
        return makeError(
            ErrorCode::kOutOfRange,
            "patch count " + std::to_string(count) + " exceeds the cells of a tile");
    if (r.remaining() < count * (2u + 4u * kPatchControls))
        return makeError(ErrorCode::kTruncated, "tile record truncated in its patches");
    rec.patches.resize(count);
    std::int32_t previous = -1;
    for (PatchEntry& e : rec.patches) {
        r.u16(e.cell);
        if (static_cast<std::int32_t>(e.cell) <= previous)
            return makeError(ErrorCode::kBadFormat, "patch cells must be strictly ascending");
        previous = e.cell;
        const std::int32_t cx = static_cast<std::int32_t>(tx) * kTileCells + e.cell % kTileCells;
        const std::int32_t cy = static_cast<std::int32_t>(ty) * kTileCells + e.cell / kTileCells;
        if (e.cell >= kTileCells * kTileCells || cx >= spec.cellsX() || cy >= spec.cellsY())
            return makeError(
                ErrorCode::kOutOfRange,
                "patch cell " + std::to_string(e.cell) + " is outside the map");
        for (std::int32_t& c : e.patch.control) {
            r.i32(c);
            if (c > kControlScale * kMaxHeightQuanta || c < -kControlScale * kMaxHeightQuanta)
                return makeError(ErrorCode::kOutOfRange, "patch control beyond the height limit");
        }
    }
    if (r.remaining() != 0)
        return makeError(ErrorCode::kBadFormat, "tile record has trailing bytes");
    return rec;
}

Result<DecodedSnapshot> decodeSnapshot(std::span<const std::uint8_t> bytes) {
    detail::ByteReader r(bytes);
    std::uint32_t magic = 0;
    if (!r.u32(magic))
        return truncated("the magic number");
    if (bytes[0] != kMagic[0] || bytes[1] != kMagic[1] || bytes[2] != kMagic[2] ||
        bytes[3] != kMagic[3])
        return makeError(ErrorCode::kBadFormat, "not a terrain snapshot (magic is not TRSN)");
    std::uint32_t version = 0;
    if (!r.u32(version))
        return truncated("the version");
    if (version != kSnapshotVersion)
        return makeError(
            ErrorCode::kUnsupported,
            "snapshot version " + std::to_string(version) + " is not supported (this build reads " +
                "version " + std::to_string(kSnapshotVersion) +
                (version == 1 ? ": version 1 worlds were built by v1 craters)" : ")"));
    WorldSpec spec;
    std::uint64_t sequence = 0;
    std::uint32_t tile_count = 0;
    if (!r.i32(spec.width) || !r.i32(spec.height) || !r.i32(spec.spacing) ||
        !r.i32(spec.units_per_metre) || !r.i32(spec.patch_tolerance) || !r.u64(sequence) ||
        !r.u32(tile_count))
        return truncated("the header");
    if (auto status = spec.validate(); !status)
        return status.error();
    if (tile_count != static_cast<std::uint32_t>(spec.tileCount()))
        return makeError(
            ErrorCode::kSizeMismatch, "tile count " + std::to_string(tile_count) + " != " +
                                          std::to_string(spec.tileCount()) + " for the map size");

    // every record holds at least its header, samples and patch count: refuse a count the bytes
    // cannot hold before reserving anything for it
    constexpr std::size_t kMinRecord = 4 + 8 + kTileVertices * kTileVertices * 4 + 4;
    if (r.remaining() / kMinRecord < tile_count)
        return truncated("the tile records");
    std::vector<TileRecord> records;
    records.reserve(tile_count);
    std::vector<std::span<const std::uint8_t>> record_bytes;
    record_bytes.reserve(tile_count);
    for (std::uint32_t i = 0; i < tile_count; ++i) {
        std::uint32_t length = 0;
        if (!r.u32(length))
            return truncated("a tile length");
        if (length > r.remaining())
            return truncated("a tile record");
        auto rec = decodeTile(bytes.subspan(r.position(), length), spec);
        if (!rec)
            return rec.error();
        if (rec->tile != static_cast<std::int32_t>(i))
            return makeError(ErrorCode::kBadFormat, "tile records are out of order");
        record_bytes.push_back(bytes.subspan(r.position(), length));
        r.skip(length);
        records.push_back(std::move(*rec));
    }
    std::uint64_t world_hash = 0;
    if (!r.u64(world_hash))
        return truncated("the world hash");
    const std::size_t checked = r.position();
    std::uint64_t checksum = 0;
    if (!r.u64(checksum))
        return truncated("the checksum");
    if (r.remaining() != 0)
        return makeError(ErrorCode::kBadFormat, "snapshot has trailing bytes");
    if (checksum != XXH3_64bits(bytes.data(), checked))
        return makeError(
            ErrorCode::kHashMismatch, "snapshot checksum differs: the bytes are corrupt");

    // base samples of the real map from the records; a vertex on a tile edge is stored by every
    // tile that shares it, and all copies must agree
    const std::size_t pw = static_cast<std::size_t>(spec.paddedWidth());
    std::vector<std::int32_t> padded(pw * static_cast<std::size_t>(spec.paddedHeight()));
    std::vector<std::int32_t> padded_original(padded.size());
    std::vector<std::uint8_t> seen(padded.size(), 0);
    for (const TileRecord& rec : records) {
        const std::int32_t tx = rec.tile % spec.tilesX();
        const std::int32_t ty = rec.tile / spec.tilesX();
        for (std::int32_t y = 0; y < kTileVertices; ++y)
            for (std::int32_t x = 0; x < kTileVertices; ++x) {
                const std::size_t at = static_cast<std::size_t>(ty * kTileCells + y) * pw +
                                       static_cast<std::size_t>(tx * kTileCells + x);
                const auto i = static_cast<std::size_t>(y * kTileVertices + x);
                const std::int32_t v = rec.samples[i];
                const std::int32_t o = rec.originals[i];
                if (seen[at] != 0 && (padded[at] != v || padded_original[at] != o))
                    return makeError(
                        ErrorCode::kInvariantBroken, "tiles disagree on the shared edge vertex (" +
                                                         std::to_string(tx * kTileCells + x) +
                                                         ", " +
                                                         std::to_string(ty * kTileCells + y) + ")");
                padded[at] = v;
                padded_original[at] = o;
                seen[at] = 1;
            }
    }
    std::vector<std::int32_t> samples(
        static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height));
    for (std::int32_t y = 0; y < spec.height; ++y)
        for (std::int32_t x = 0; x < spec.width; ++x)
            samples
                [static_cast<std::size_t>(y) * static_cast<std::size_t>(spec.width) +
                 static_cast<std::size_t>(x)] =
                    padded[static_cast<std::size_t>(y) * pw + static_cast<std::size_t>(x)];
    // hashes come from the records below; hashing the tiles here as well would be thrown away
    auto terrain = Terrain::createUnhashed(spec, samples);
    if (!terrain)
        return terrain.error();
    for (TileRecord& rec : records)
        terrain->loadTile(rec.tile, rec.samples, rec.originals, std::move(rec.patches));
    // a record is the tile's canonical bytes (shared edges were checked equal above), so its hash
    // is the record's: no need to serialize the tile again
    for (std::size_t i = 0; i < records.size(); ++i) {
        terrain->refreshBounds(records[i].tile);
        Terrain::Tile& tile = terrain->tiles_[static_cast<std::size_t>(records[i].tile)];
        tile.hash = XXH3_64bits(record_bytes[i].data(), record_bytes[i].size());
        tile.version = Terrain::nextTileVersion();
    }
    terrain->rehashWorld();
    if (auto status = terrain->checkInvariants(); !status)
        return status.error();
    if (terrain->worldHash() != world_hash)
        return makeError(
            ErrorCode::kHashMismatch,
            "world hash of the decoded state differs from the snapshot's");
    return DecodedSnapshot{std::move(*terrain), sequence};
}

} // namespace terrain
