#pragma once

// The world's replica on its own, in C++ (17 or later): an inline wrapper over terrain_replica.h,
// for programs that speak the protocol themselves, replay journals or check a world's state.
// Load a state (snapshot, genesis delta, procedural genesis), then apply each op with the world
// hash the server sent after it; a mismatch names the suspect tiles, which the server's tile
// state repairs. Every call either does what it says or changes nothing.
//
//   terrain::game::Replica replica;
//   replica.load(snapshot_bytes);                       // or loadProcedural(seed, size)
//   for each op the server sends: replica.applyOp(seq, op, &world_hash)
//   on ReplicaOutcome::kDiverged: ask for suspectTiles(), then applyRepair(...)

#include <terrain/game/client.h>

#include <terrain_replica.h>

#include <cstddef>
#include <cstdint>
#include <new>
#include <vector>

namespace terrain::game {

/// An op as broadcast and journaled: quanta, 16.16 strength (terrain_op).
using ReplicaOp = terrain_op;
using ReplicaState = terrain_replica_state;

enum class ReplicaOutcome {
    kApplied = TERRAIN_OP_APPLIED,             ///< applied; the hash matches (or had none)
    kStale = TERRAIN_OP_STALE,                 ///< seq already held: ignored
    kDiverged = TERRAIN_OP_DIVERGED,           ///< applied, the hash differs: repair
    kStillDiverged = TERRAIN_OP_STILL_DIVERGED ///< applied while diverged: not repaired yet
};

class Replica {
  public:
    /// Throws std::bad_alloc if it cannot be made.
    Replica() {
        if (terrain_replica_create(&replica_) != TERRAIN_OK)
            throw std::bad_alloc();
    }
    ~Replica() { terrain_replica_destroy(replica_); }
    Replica(const Replica&) = delete;
    Replica& operator=(const Replica&) = delete;

    /// A raw snapshot, a genesis delta over the genesis held, or one zstd frame of either.
    ClientResult load(const void* bytes, std::size_t size) {
        return result(terrain_replica_load(replica_, bytes, size));
    }
    ClientResult load(const std::vector<std::uint8_t>& bytes) {
        return load(bytes.data(), bytes.size());
    }
    /// The genesis of `terrain-server --seed seed --size size` (tolerance 0: the default).
    ClientResult
    loadProcedural(std::uint64_t seed, std::int32_t size, double patch_tolerance_metres = 0.0) {
        return result(
            terrain_replica_load_procedural(replica_, seed, size, patch_tolerance_metres));
    }
    ClientResult resetToGenesis() { return result(terrain_replica_reset_to_genesis(replica_)); }

    /// world_hash: the server's hash after the op, or nullptr inside a batch (checked later).
    ClientResult applyOp(
        std::uint64_t seq,
        const ReplicaOp& op,
        const std::uint64_t* world_hash,
        ReplicaOutcome* outcome = nullptr) {
        int o = TERRAIN_OP_APPLIED;
        ClientResult r = result(terrain_replica_apply_op(replica_, seq, &op, world_hash, &o));
        if (r && outcome != nullptr)
            *outcome = static_cast<ReplicaOutcome>(o);
        return r;
    }

    ReplicaState state() const {
        ReplicaState s{};
        terrain_replica_state_get(replica_, &s);
        return s;
    }
    std::vector<std::int32_t> suspectTiles() const {
        std::size_t count = 0;
        terrain_replica_suspect_tiles(replica_, nullptr, 0, &count);
        std::vector<std::int32_t> tiles(count);
        terrain_replica_suspect_tiles(replica_, tiles.data(), tiles.size(), &count);
        tiles.resize(count < tiles.size() ? count : tiles.size());
        return tiles;
    }
    ClientResult tileHash(std::int32_t tile, std::uint64_t& out) const {
        return result(terrain_replica_tile_hash(replica_, tile, &out));
    }
    ClientResult heightAt(double x, double y, double& out) const {
        return result(terrain_replica_height_at(replica_, x, y, &out));
    }

    /// RepairState: its tiles (the zstd frame or its content) and tile hashes (or none).
    ClientResult applyRepair(
        std::uint64_t seq,
        std::uint64_t world_hash,
        const std::vector<std::uint8_t>& tiles,
        const std::vector<std::uint64_t>& tile_hashes,
        std::size_t* still_differing = nullptr) {
        return result(terrain_replica_apply_repair(
            replica_, seq, world_hash, tiles.data(), tiles.size(), tile_hashes.data(),
            tile_hashes.size(), still_differing));
    }

    /// The state held as a snapshot or a genesis delta (terrain_state_format).
    ClientResult save(terrain_state_format format, std::vector<std::uint8_t>& out) {
        const std::uint8_t* bytes = nullptr;
        std::size_t size = 0;
        ClientResult r = result(terrain_replica_save(replica_, format, &bytes, &size));
        if (r)
            out.assign(bytes, bytes + size);
        return r;
    }

  private:
    ClientResult result(terrain_status status) const {
        return detail::resultOf(status, terrain_replica_last_error(replica_));
    }

    terrain_replica* replica_ = nullptr;
};

} // namespace terrain::game
