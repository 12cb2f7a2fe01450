#include <terrain/client/replica.h>

#include <algorithm>
#include <string>
#include <utility>

namespace terrain::client {

void Replica::loadSnapshot(DecodedSnapshot snapshot) {
    seq_ = snapshot.sequence;
    terrain_.emplace(std::move(snapshot.terrain));
    genesis_hash_.reset();
    verified_seq_ = seq_;
    verified_hash_ = terrain_->worldHash();
    diverged_ = false;
    suspects_.clear();
    unverified_tiles_.clear();
    dirty_.tiles.clear();
    dirty_.cells.clear();
    dirty_.all = true;
    ++stats_.snapshots;
    if (recording_) {
        ReplicaChange change;
        change.kind = ReplicaChange::Kind::kState;
        change.seq = seq_;
        changes_.push_back(change);
    }
}

Result<Replica::OpOutcome>
Replica::applyOp(std::uint64_t seq, const DeformOp& op, std::optional<std::uint64_t> checked_hash) {
    if (!terrain_)
        return makeError(ErrorCode::kOutOfRange, "op before any snapshot");
    if (seq <= seq_) {
        ++stats_.ops_stale;
        return OpOutcome::kStale;
    }
    if (seq != seq_ + 1)
        return makeError(
            ErrorCode::kOutOfRange, "op seq " + std::to_string(seq) + " arrived on top of seq " +
                                        std::to_string(seq_) + " (a gap)");
    Result<OpEffect> effect = terrain_->apply(op, runner_);
    if (!effect)
        return effect.error();
    seq_ = seq;
    ++stats_.ops_applied;
    if (recording_) {
        ReplicaChange change;
        change.kind = ReplicaChange::Kind::kOp;
        change.seq = seq;
        change.cells = effect->cells;
        changes_.push_back(change);
    }
    // an op dirties its own cells: whole tiles would make every crater re-derive tiles of
    // blocks and bounds on the client (tiles are for snapshots and repairs)
    if (!effect->cells.empty())
        dirty_.cells.push_back(effect->cells);
    if (!checked_hash) {
        // checked with a later op: its tiles are suspects if that check fails
        auto& into = diverged_ ? suspects_ : unverified_tiles_;
        into.insert(into.end(), effect->dirty_tiles.begin(), effect->dirty_tiles.end());
        return OpOutcome::kApplied;
    }
    const std::uint64_t world_hash = *checked_hash;
    if (diverged_) {
        suspects_.insert(suspects_.end(), effect->dirty_tiles.begin(), effect->dirty_tiles.end());
        if (terrain_->worldHash() != world_hash)
            return OpOutcome::kApplied;
        diverged_ = false; // a later op happened to bring both sides together again
        suspects_.clear();
    }
    if (terrain_->worldHash() != world_hash) {
        ++stats_.hash_mismatches;
        diverged_ = true;
        suspects_.swap(unverified_tiles_);
        suspects_.insert(suspects_.end(), effect->dirty_tiles.begin(), effect->dirty_tiles.end());
        unverified_tiles_.clear();
        return OpOutcome::kDiverged;
    }
    unverified_tiles_.clear();
    verified_seq_ = seq;
    verified_hash_ = world_hash;
    return OpOutcome::kApplied;
}

std::vector<std::int32_t> Replica::suspectTiles() const {
    std::vector<std::int32_t> tiles = suspects_;
    std::sort(tiles.begin(), tiles.end());
    tiles.erase(std::unique(tiles.begin(), tiles.end()), tiles.end());
    return tiles;
}

Status Replica::loadGenesis(Terrain genesis) {
    const std::uint64_t hash = genesis.genesisHash();
    if (hash != genesis.worldHash())
        return makeError(
            ErrorCode::kInvariantBroken,
            "not a genesis: the world has ops on it (its hash differs from its original ground's)");
    loadSnapshot(DecodedSnapshot{std::move(genesis), 0});
    genesis_hash_ = hash;
    return Ok{};
}

std::uint64_t Replica::genesisHash() const {
    if (!terrain_)
        return 0;
    if (!genesis_hash_)
        genesis_hash_ = terrain_->genesisHash();
    return *genesis_hash_;
}

Result<std::vector<std::int32_t>> Replica::applyRepair(
    std::uint64_t seq,
    std::uint64_t world_hash,
    std::vector<TileRecord> tiles,
    std::span<const std::uint64_t> server_tile_hashes) {
    if (!terrain_ || seq != seq_)
        return makeError(
            ErrorCode::kOutOfRange, "repair state at seq " + std::to_string(seq) +
                                        " does not match the replica's seq " +
                                        std::to_string(seq_));
    const std::int32_t tile_count = terrain_->spec().tileCount();
    if (!server_tile_hashes.empty() &&
        server_tile_hashes.size() != static_cast<std::size_t>(tile_count))
        return makeError(
            ErrorCode::kSizeMismatch, "repair carries a tile hash list of the wrong length");
    if (recording_) {
        ReplicaChange change;
        change.kind = ReplicaChange::Kind::kRepair;
        change.seq = seq;
        for (const TileRecord& record : tiles)
            change.tiles.push_back(record.tile);
        changes_.push_back(std::move(change));
    }
    for (TileRecord& record : tiles) {
        genesis_hash_.reset(); // a repaired tile carries its own original ground
        terrain_->replaceTile(
            record.tile, record.samples, record.originals, std::move(record.patches));
        markTile(record.tile);
    }
    // replaceTile() trusts its input: the repaired whole must keep every patch invariant
    if (Status s = terrain_->checkInvariants(); !s)
        return s.error();
    std::vector<std::int32_t> still_different;
    for (std::size_t t = 0; t < server_tile_hashes.size(); ++t)
        if (terrain_->tileHash(static_cast<std::int32_t>(t)) != server_tile_hashes[t])
            still_different.push_back(static_cast<std::int32_t>(t));
    if (terrain_->worldHash() == world_hash) {
        diverged_ = false;
        suspects_.clear();
        verified_seq_ = seq_;
        verified_hash_ = world_hash;
        ++stats_.repairs;
        return std::vector<std::int32_t>{};
    }
    if (still_different.empty() && server_tile_hashes.empty())
        still_different = suspectTiles();
    suspects_ = still_different;
    return still_different;
}

void Replica::markTile(std::int32_t tile) {
    auto it = std::lower_bound(dirty_.tiles.begin(), dirty_.tiles.end(), tile);
    if (it == dirty_.tiles.end() || *it != tile)
        dirty_.tiles.insert(it, tile);
}

DirtySet Replica::takeDirty() {
    DirtySet out = std::move(dirty_);
    dirty_ = DirtySet{};
    return out;
}

void Replica::recordChanges(bool on) {
    recording_ = on;
    if (!on)
        changes_.clear();
}

std::vector<ReplicaChange> Replica::takeChanges() {
    std::vector<ReplicaChange> out;
    out.swap(changes_);
    return out;
}

ReplicaSync
Replica::takeSync(std::vector<std::uint64_t>& versions, std::vector<ReplicaChange> changes) const {
    ReplicaSync sync;
    if (!terrain_)
        return sync;
    sync.terrain = terrain_->takeSync(versions);
    sync.changes = std::move(changes);
    sync.seq = seq_;
    sync.verified_seq = verified_seq_;
    sync.verified_hash = verified_hash_;
    sync.diverged = diverged_;
    return sync;
}

void Replica::follow(const ReplicaSync& sync, Terrain::PatchLists lists) {
    if (!terrain_ && !sync.terrain.whole())
        return; // a copy with nothing yet follows from a whole world (taken with no versions)
    // a whole world of a new shape is rebuilt; one of the same shape (every tile repaired or
    // reloaded) is marked by its changes
    const bool new_shape = !terrain_ || (sync.terrain.whole() &&
                                         !(terrain_->spec() == sync.terrain.wholeTerrain().spec()));
    if (!terrain_) {
        terrain_.emplace(sync.terrain.wholeTerrain());
        if (lists == Terrain::PatchLists::kOwnCopies)
            terrain_->applySync(sync.terrain, lists);
    } else {
        terrain_->applySync(sync.terrain, lists);
    }
    if (new_shape) {
        dirty_ = DirtySet{};
        dirty_.all = true;
        genesis_hash_.reset();
    }
    seq_ = sync.seq;
    verified_seq_ = sync.verified_seq;
    verified_hash_ = sync.verified_hash;
    diverged_ = sync.diverged;
    for (const ReplicaChange& change : sync.changes) {
        switch (change.kind) {
        case ReplicaChange::Kind::kState:
            dirty_ = DirtySet{};
            dirty_.all = true;
            genesis_hash_.reset();
            break;
        case ReplicaChange::Kind::kOp:
            if (!change.cells.empty())
                dirty_.cells.push_back(change.cells);
            break;
        case ReplicaChange::Kind::kRepair:
            genesis_hash_.reset();
            for (std::int32_t tile : change.tiles)
                markTile(tile);
            break;
        }
    }
    if (recording_)
        changes_.insert(changes_.end(), sync.changes.begin(), sync.changes.end());
}

} // namespace terrain::client
