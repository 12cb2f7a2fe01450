#pragma once

// The client's copy of the world: applies snapshots and ops with the shared core, checks every
// op's world hash, tracks what diverged and what changed. No sockets, no GL, no clocks; the
// connection (client/net) feeds it and the tessellator reads its dirty set.
// Not thread safe: one owner (the client's frame loop).

#include <terrain/client/replica_change.h>
#include <terrain/client/replica_sync.h>
#include <terrain/deform_op.h>
#include <terrain/result.h>
#include <terrain/snapshot.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace terrain::client {

/// What changed since the last takeDirty(): whole tiles (repairs) and cell rectangles (ops:
/// the cells whose surface the op may have changed, nothing more), for re-tessellation and
/// buffer uploads.
struct DirtySet {
    std::vector<std::int32_t> tiles; ///< repaired tiles, ascending, unique
    std::vector<CellRect> cells;     ///< one per op, in apply order
    bool all = false;                ///< a snapshot replaced everything
};

struct ReplicaStats {
    std::uint64_t ops_applied = 0;
    std::uint64_t ops_stale = 0; ///< already held (seq <= current): ignored
    std::uint64_t hash_mismatches = 0;
    std::uint64_t repairs = 0; ///< repairs that restored the server's hash
    std::uint64_t snapshots = 0;
};

class Replica {
  public:
    enum class OpOutcome {
        kApplied,  ///< applied, hash verified (or the replica was already diverged)
        kStale,    ///< seq <= current seq: already held, ignored
        kDiverged, ///< applied, but the hash differs: call repair with suspectTiles()
    };

    /// Ops apply on `runner` from now on (not owned; null: serially, the default). The bits are
    /// the same either way; a game picks the threads it can spare beside its frame.
    void setApplyRunner(TaskRunner* runner) { runner_ = runner; }

    /// True once a snapshot was loaded.
    bool ready() const { return terrain_.has_value(); }
    std::uint64_t seq() const { return seq_; }
    std::uint64_t worldHash() const { return terrain_ ? terrain_->worldHash() : 0; }
    const Terrain& terrain() const { return *terrain_; }
    /// True from a hash mismatch until a repair or snapshot restores the server's hash.
    bool diverged() const { return diverged_; }
    /// The last seq whose hash was verified equal to the server's.
    std::uint64_t verifiedSeq() const { return verified_seq_; }
    std::uint64_t verifiedHash() const { return verified_hash_; }

    /// Replaces the whole state (the snapshot was decoded and checked by the core).
    void loadSnapshot(DecodedSnapshot snapshot);

    /// Starts from the world's genesis, the map as it was created (a game ships it, or makes it
    /// from the procedural seed): the state at seq 0. A connection then resumes from seq 0
    /// while the server still holds every op, and otherwise joins by a genesis delta.
    /// Errors: kInvariantBroken when `genesis` has ops on it (it is not a genesis).
    Status loadGenesis(Terrain genesis);
    /// The genesis of the world held (Terrain::genesisHash: its original ground), computed once
    /// per loaded state; 0 before any state.
    std::uint64_t genesisHash() const;

    /// Applies op `seq` on top of seq - 1 and compares the hash. Errors (the caller resyncs by
    /// snapshot): kOutOfRange for a gap (seq > current + 1) or no state yet; the core's refusal
    /// if the op does not apply (validation depends on the spec only, so this means a bad peer).
    /// Without `world_hash` (an op inside a batch whose hash comes after its last op), the op is
    /// applied unchecked: the next checked op verifies it too, and a mismatch there suspects
    /// the tiles of every op since the last verified one.
    Result<OpOutcome>
    applyOp(std::uint64_t seq, const DeformOp& op, std::optional<std::uint64_t> world_hash);

    /// Tiles to ask the server for: those changed by ops since the divergence, ascending.
    std::vector<std::int32_t> suspectTiles() const;

    /// Applies tile state that the server sent at `seq` (must equal the current seq: it follows
    /// every op up to it on the stream). Replaces the tiles, checks the patch invariants, then
    /// compares every tile hash with `server_tile_hashes` (when given). Returns the tiles that
    /// still differ (empty when the world hash now equals `world_hash`).
    /// Errors: kOutOfRange (seq differs), kInvariantBroken (the repaired state breaks an
    /// invariant: resync by snapshot), kSizeMismatch (hash list of the wrong length).
    Result<std::vector<std::int32_t>> applyRepair(
        std::uint64_t seq,
        std::uint64_t world_hash,
        std::vector<TileRecord> tiles,
        std::span<const std::uint64_t> server_tile_hashes);

    /// Returns and clears what changed since the last call.
    DirtySet takeDirty();

    /// From now on, records every change applied (a state loaded, an op applied, a repair
    /// applied) for takeChanges(), so that another copy can follow (takeSync). Off by default:
    /// nothing would take them.
    void recordChanges(bool on);
    bool recordingChanges() const { return recording_; }
    /// The changes recorded since the last call, in the order applied.
    std::vector<ReplicaChange> takeChanges();
    /// What changed since the copy whose tile versions are `versions` last took a sync
    /// (Terrain::takeSync: resized and updated; empty: the copy holds nothing yet, and takes the
    /// whole world), with `changes`, the changes recorded since (takeChanges()). For a copy on
    /// another thread: hand it over under a lock, apply it there with follow().
    ReplicaSync
    takeSync(std::vector<std::uint64_t>& versions, std::vector<ReplicaChange> changes) const;
    /// Becomes equal to the replica `sync` was taken from without applying anything: copies the
    /// tiles that changed (their patch lists shared, copy-on-write: no second copy of them) and
    /// its seq and checks, and marks dirty what the sync's changes changed, as if applied here.
    /// Syncs apply in the order taken. The cost of the tiles changed, not of the ops (a crater:
    /// microseconds where its apply is a millisecond). Records the changes when recording.
    /// With kOwnCopies the patch lists are copied here instead (Terrain::PatchLists).
    void follow(const ReplicaSync& sync, Terrain::PatchLists lists = Terrain::PatchLists::kShared);
    const DirtySet& peekDirty() const { return dirty_; }

    const ReplicaStats& stats() const { return stats_; }

    /// Tests only: corrupts the replica behind the hashes' back (e.g. a local op the server never
    /// sent), to exercise detection and repair.
    Terrain& terrainForTesting() {
        genesis_hash_.reset();
        return *terrain_;
    }

  private:
    void markTile(std::int32_t tile);

    std::optional<Terrain> terrain_;
    TaskRunner* runner_ = nullptr;
    mutable std::optional<std::uint64_t> genesis_hash_; // cache: it hashes the whole map
    std::uint64_t seq_ = 0;
    std::uint64_t verified_seq_ = 0;
    std::uint64_t verified_hash_ = 0;
    bool diverged_ = false;
    std::vector<std::int32_t> suspects_;
    std::vector<std::int32_t> unverified_tiles_; // dirtied by unchecked ops since the last check
    DirtySet dirty_;
    ReplicaStats stats_;
    bool recording_ = false;
    std::vector<ReplicaChange> changes_;
};

} // namespace terrain::client
