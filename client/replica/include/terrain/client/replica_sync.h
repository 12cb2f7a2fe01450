#pragma once

// What a replica changed since a copy of it last looked: the tiles that changed (their samples
// copied, their patch lists shared), the replica's seq and checks, and the changes it recorded
// meanwhile (for the copy's dirty set). Taken on the replica's thread (Replica::takeSync) and
// applied by a copy on another (Replica::follow), so that an op is applied once per client: the
// copies follow it at the cost of the tiles it changed.

#include <terrain/client/replica_change.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <vector>

namespace terrain::client {

struct ReplicaSync {
    Terrain::TileSync terrain;
    std::vector<ReplicaChange> changes; ///< recorded since the last sync, in the order applied
    std::uint64_t seq = 0;
    std::uint64_t verified_seq = 0;
    std::uint64_t verified_hash = 0;
    bool diverged = false;
    bool empty() const { return changes.empty() && terrain.tileCount() == 0; }
};

} // namespace terrain::client
