// The C ABI of the replica on its own (terrain_replica.h): the client's Replica behind argument
// checks, status codes and a message per replica. Each call either does all it says or changes
// nothing: bytes are decoded and checked whole before the state is touched.

#include "abi_guard.h"

#include <terrain/client/replica.h>
#include <terrain/genesis_delta.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>
#include <terrain/surface_query.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/compression.h>
#include <terrain/wire/snapshot_stream.h>

#include <terrain_replica.h>

#include <cmath>
#include <cstring>
#include <span>
#include <string>
#include <utility>
#include <vector>

struct terrain_replica {
    terrain::client::Replica replica;
    std::string last_error;
    std::vector<std::uint8_t> saved; // terrain_replica_save's bytes
};

namespace {

using terrain::ErrorCode;

// The largest decompressed state accepted before its header is read: the game client's own cap
// on a join snapshot. The decoder's limits per spec apply after.
constexpr std::size_t kMaxStateBytes = std::size_t{2} << 30;

terrain_status fail(terrain_replica* r, terrain_status status, const std::string& message) {
    r->last_error = std::string(terrain_status_name(status)) + ": " + message;
    return status;
}

terrain_status refused(terrain_replica* r, const terrain::Error& error) {
    return fail(r, TERRAIN_BAD_DATA, error.message);
}

template <typename F> terrain_status guarded(terrain_replica* r, F&& f) {
    return terrain::game::detail::guardedCall(
        [r](std::string message) { r->last_error = std::move(message); }, std::forward<F>(f));
}

std::span<const std::uint8_t> bytesOf(const void* bytes, size_t size) {
    return {static_cast<const std::uint8_t*>(bytes), size};
}

bool fourCC(std::span<const std::uint8_t> bytes, const char* magic) {
    return bytes.size() >= 4 && std::memcmp(bytes.data(), magic, 4) == 0;
}

// The replica holds `genesis` at seq 0 (made here, so a refusal is ours: INTERNAL).
terrain_status holdGenesis(terrain_replica* r, terrain::Terrain genesis) {
    if (auto loaded = r->replica.loadGenesis(std::move(genesis)); !loaded)
        return fail(r, TERRAIN_INTERNAL, loaded.error().message);
    r->replica.takeDirty();
    return TERRAIN_OK;
}

// The op as the core takes it; false (and the rule named) for a kind the core has not.
bool toDeformOp(const terrain_op& in, terrain::DeformOp& out, std::string& why) {
    if (in.kind < TERRAIN_OP_CRATER || in.kind > TERRAIN_OP_SMOOTH) {
        why = "op kind must be 1 (crater) to 4 (smooth), got " + std::to_string(in.kind);
        return false;
    }
    out.kind = static_cast<terrain::OpKind>(in.kind);
    out.center_x = in.center_x;
    out.center_y = in.center_y;
    out.radius = in.radius;
    out.height = in.height;
    out.strength = in.strength;
    return true;
}

} // namespace

extern "C" {

terrain_status terrain_replica_create(terrain_replica** out) {
    if (out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    *out = nullptr;
    try {
        *out = new terrain_replica();
    } catch (...) {
        return TERRAIN_INTERNAL;
    }
    return TERRAIN_OK;
}

void terrain_replica_destroy(terrain_replica* r) {
    delete r;
}

const char* terrain_replica_last_error(const terrain_replica* r) {
    if (r == nullptr)
        return "BAD_PARAMETER: replica is NULL";
    return r->last_error.c_str();
}

terrain_status terrain_replica_load(terrain_replica* r, const void* bytes, size_t size) {
    if (r == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(r, [&] {
        if (bytes == nullptr && size != 0)
            return fail(r, TERRAIN_BAD_PARAMETER, "bytes is NULL");
        std::span<const std::uint8_t> in = bytesOf(bytes, size);
        terrain::wire::RawBytes raw;
        if (terrain::wire::isZstdFrame(in)) {
            auto decompressed = terrain::wire::decompressFrame(in, kMaxStateBytes);
            if (!decompressed)
                return refused(r, decompressed.error());
            raw = std::move(*decompressed);
            in = raw.bytes();
        }
        if (fourCC(in, "TRGD")) {
            if (!r->replica.ready())
                return fail(
                    r, TERRAIN_NOT_SYNCED,
                    "a genesis delta needs its genesis: load a snapshot or the procedural map "
                    "first");
            auto decoded = terrain::decodeGenesisDelta(in, r->replica.terrain());
            if (!decoded)
                return refused(r, decoded.error());
            r->replica.loadSnapshot(std::move(*decoded));
        } else if (fourCC(in, "TRSN")) {
            auto decoded = terrain::decodeSnapshot(in);
            if (!decoded)
                return refused(r, decoded.error());
            r->replica.loadSnapshot(std::move(*decoded));
        } else {
            return fail(
                r, TERRAIN_BAD_DATA,
                "not a snapshot (TRSN), a genesis delta (TRGD) or a zstd frame of one: "
                "unknown magic");
        }
        r->replica.takeDirty();
        return TERRAIN_OK;
    });
}

terrain_status terrain_replica_load_procedural(
    terrain_replica* r, uint64_t seed, int32_t size, double patch_tolerance_metres) {
    if (r == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(r, [&] {
        // the server's --size range
        if (size < 65 || size > 8193)
            return fail(
                r, TERRAIN_BAD_PARAMETER,
                "size must be in [65, 8193], got " + std::to_string(size));
        if (!std::isfinite(patch_tolerance_metres) || patch_tolerance_metres < 0.0)
            return fail(
                r, TERRAIN_BAD_PARAMETER,
                "patch_tolerance_metres must be finite and >= 0 (0: 1/32 m)");
        terrain::ProceduralMapOptions options;
        options.seed = seed;
        options.width = size;
        options.height = size;
        if (patch_tolerance_metres > 0.0)
            options.patch_tolerance_metres = patch_tolerance_metres;
        auto map = terrain::makeProceduralMap(options);
        if (!map)
            return fail(r, TERRAIN_BAD_PARAMETER, map.error().message);
        return holdGenesis(r, std::move(*map));
    });
}

terrain_status terrain_replica_reset_to_genesis(terrain_replica* r) {
    if (r == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(r, [&] {
        if (!r->replica.ready())
            return fail(r, TERRAIN_NOT_SYNCED, "no world held: nothing to take the genesis of");
        const terrain::Terrain& held = r->replica.terrain();
        const terrain::WorldSpec& spec = held.spec();
        std::vector<std::int32_t> ground(
            static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height));
        for (std::int32_t y = 0; y < spec.height; ++y)
            for (std::int32_t x = 0; x < spec.width; ++x)
                ground
                    [static_cast<std::size_t>(y) * static_cast<std::size_t>(spec.width) +
                     static_cast<std::size_t>(x)] = held.original(x, y);
        auto genesis = terrain::Terrain::create(spec, ground);
        if (!genesis)
            return fail(r, TERRAIN_INTERNAL, genesis.error().message);
        return holdGenesis(r, std::move(*genesis));
    });
}

terrain_status terrain_replica_apply_op(
    terrain_replica* r,
    uint64_t seq,
    const terrain_op* op,
    const uint64_t* world_hash,
    int* outcome) {
    if (r == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(r, [&] {
        if (op == nullptr)
            return fail(r, TERRAIN_BAD_PARAMETER, "op is NULL");
        if (!r->replica.ready())
            return fail(r, TERRAIN_NOT_SYNCED, "no world held: load a state before ops");
        if (seq > r->replica.seq() + 1)
            return fail(
                r, TERRAIN_SEQ_GAP,
                "op seq " + std::to_string(seq) + " on top of seq " +
                    std::to_string(r->replica.seq()) + ": ops were missed (load a snapshot)");
        terrain::DeformOp deform;
        std::string why;
        if (!toDeformOp(*op, deform, why))
            return fail(r, TERRAIN_BAD_DATA, why);
        std::optional<std::uint64_t> hash;
        if (world_hash != nullptr)
            hash = *world_hash;
        auto applied = r->replica.applyOp(seq, deform, hash);
        if (!applied)
            return refused(r, applied.error());
        r->replica.takeDirty();
        if (outcome != nullptr) {
            using Outcome = terrain::client::Replica::OpOutcome;
            switch (*applied) {
            case Outcome::kStale:
                *outcome = TERRAIN_OP_STALE;
                break;
            case Outcome::kDiverged:
                *outcome = TERRAIN_OP_DIVERGED;
                break;
            case Outcome::kApplied:
                *outcome = r->replica.diverged() ? TERRAIN_OP_STILL_DIVERGED : TERRAIN_OP_APPLIED;
                break;
            }
        }
        return TERRAIN_OK;
    });
}

terrain_status terrain_replica_state_get(const terrain_replica* r, terrain_replica_state* out) {
    if (r == nullptr || out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    *out = terrain_replica_state{};
    const terrain::client::Replica& replica = r->replica;
    const terrain::client::ReplicaStats& stats = replica.stats();
    out->ops_applied = stats.ops_applied;
    out->hash_mismatches = stats.hash_mismatches;
    out->repairs = stats.repairs;
    out->states_loaded = stats.snapshots;
    if (!replica.ready())
        return TERRAIN_OK;
    const terrain::WorldSpec& spec = replica.terrain().spec();
    out->loaded = 1;
    out->seq = replica.seq();
    out->world_hash = replica.worldHash();
    out->genesis_hash = replica.genesisHash();
    out->diverged = replica.diverged() ? 1 : 0;
    out->verified_seq = replica.verifiedSeq();
    out->width = spec.width;
    out->height = spec.height;
    out->spacing = spec.spacing;
    out->units_per_metre = spec.units_per_metre;
    out->patch_tolerance = spec.patch_tolerance;
    out->tiles_x = spec.tilesX();
    out->tiles_y = spec.tilesY();
    return TERRAIN_OK;
}

terrain_status terrain_replica_suspect_tiles(
    const terrain_replica* r, int32_t* tiles, size_t capacity, size_t* count) {
    if (r == nullptr || count == nullptr || (tiles == nullptr && capacity != 0))
        return TERRAIN_BAD_PARAMETER;
    return guarded(const_cast<terrain_replica*>(r), [&] {
        const std::vector<std::int32_t> suspects = r->replica.suspectTiles();
        *count = suspects.size();
        for (std::size_t i = 0; i < suspects.size() && i < capacity; ++i)
            tiles[i] = suspects[i];
        return TERRAIN_OK;
    });
}

terrain_status terrain_replica_tile_hash(const terrain_replica* r, int32_t tile, uint64_t* out) {
    if (r == nullptr || out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    auto* mutable_r = const_cast<terrain_replica*>(r); // for the message only
    return guarded(mutable_r, [&] {
        if (!r->replica.ready())
            return fail(mutable_r, TERRAIN_NOT_SYNCED, "no world held");
        const std::int32_t tiles = r->replica.terrain().spec().tileCount();
        if (tile < 0 || tile >= tiles)
            return fail(
                mutable_r, TERRAIN_BAD_PARAMETER,
                "tile must be in [0, " + std::to_string(tiles) + "), got " + std::to_string(tile));
        *out = r->replica.terrain().tileHash(tile);
        return TERRAIN_OK;
    });
}

terrain_status
terrain_replica_height_at(const terrain_replica* r, double x, double y, double* height_out) {
    if (r == nullptr || height_out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    auto* mutable_r = const_cast<terrain_replica*>(r); // for the message only
    return guarded(mutable_r, [&] {
        if (!r->replica.ready())
            return fail(mutable_r, TERRAIN_NOT_SYNCED, "no world held");
        const terrain::WorldSpec& spec = r->replica.terrain().spec();
        if (!std::isfinite(x) || !std::isfinite(y) || x < 0.0 || y < 0.0 || x > spec.extentX() ||
            y > spec.extentY())
            return fail(
                mutable_r, TERRAIN_BAD_PARAMETER,
                "(x, y) must be on the map, [0, " + std::to_string(spec.extentX()) + "] x [0, " +
                    std::to_string(spec.extentY()) + "] m");
        *height_out = terrain::surfaceHeight(r->replica.terrain(), x, y);
        return TERRAIN_OK;
    });
}

terrain_status terrain_replica_apply_repair(
    terrain_replica* r,
    uint64_t seq,
    uint64_t world_hash,
    const void* tiles,
    size_t size,
    const uint64_t* tile_hashes,
    size_t tile_hash_count,
    size_t* still_differing) {
    if (r == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(r, [&] {
        if ((tiles == nullptr && size != 0) || (tile_hashes == nullptr && tile_hash_count != 0))
            return fail(r, TERRAIN_BAD_PARAMETER, "a NULL buffer with a size");
        if (!r->replica.ready())
            return fail(r, TERRAIN_NOT_SYNCED, "no world held: nothing to repair");
        if (seq != r->replica.seq())
            return fail(
                r, TERRAIN_BAD_PARAMETER,
                "tile state at seq " + std::to_string(seq) + " for a replica at seq " +
                    std::to_string(r->replica.seq()) + ": it must follow every op up to it");
        const terrain::WorldSpec& spec = r->replica.terrain().spec();
        const auto max_tiles = static_cast<std::size_t>(spec.tileCount());
        std::span<const std::uint8_t> in = bytesOf(tiles, size);
        terrain::wire::RawBytes raw;
        if (terrain::wire::isZstdFrame(in)) {
            auto decompressed = terrain::wire::decompressFrame(
                in, static_cast<std::size_t>(terrain::wire::kMaxTileEntryBytes * max_tiles));
            if (!decompressed)
                return refused(r, decompressed.error());
            raw = std::move(*decompressed);
            in = raw.bytes();
        }
        auto records = terrain::wire::decodeTileRecords(in, spec, max_tiles);
        if (!records)
            return refused(r, records.error());
        if (tile_hash_count != 0 && tile_hash_count != max_tiles)
            return fail(
                r, TERRAIN_BAD_DATA,
                "tile_hashes must hold every tile's hash (" + std::to_string(max_tiles) +
                    ") or none, got " + std::to_string(tile_hash_count));
        // records that each decode may still break an invariant together, found only once
        // they are in: the copy puts everything back then, or if anything throws (a repair is
        // rare; the copy is the world's size)
        terrain::client::Replica before = r->replica;
        terrain::Result<std::vector<std::int32_t>> differing = std::vector<std::int32_t>{};
        try {
            differing = r->replica.applyRepair(
                seq, world_hash, std::move(*records),
                std::span<const std::uint64_t>(tile_hashes, tile_hash_count));
        } catch (...) {
            r->replica = std::move(before);
            throw;
        }
        if (!differing) {
            r->replica = std::move(before);
            return refused(r, differing.error());
        }
        r->replica.takeDirty();
        if (still_differing != nullptr)
            *still_differing = differing->size();
        return TERRAIN_OK;
    });
}

terrain_status
terrain_replica_save(terrain_replica* r, int format, const uint8_t** bytes, size_t* size) {
    if (r == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(r, [&] {
        if (bytes == nullptr || size == nullptr)
            return fail(r, TERRAIN_BAD_PARAMETER, "bytes and size must not be NULL");
        *bytes = nullptr;
        *size = 0;
        if (format != TERRAIN_STATE_SNAPSHOT && format != TERRAIN_STATE_GENESIS_DELTA)
            return fail(
                r, TERRAIN_BAD_PARAMETER,
                "format must be 1 (snapshot) or 2 (genesis delta), got " + std::to_string(format));
        if (!r->replica.ready())
            return fail(r, TERRAIN_NOT_SYNCED, "no world held: nothing to save");
        const terrain::Terrain& terrain = r->replica.terrain();
        r->saved =
            format == TERRAIN_STATE_SNAPSHOT
                ? terrain::encodeSnapshot(terrain, r->replica.seq())
                : terrain::encodeGenesisDelta(terrain, r->replica.seq(), r->replica.genesisHash());
        *bytes = r->saved.data();
        *size = r->saved.size();
        return TERRAIN_OK;
    });
}

} // extern "C"
