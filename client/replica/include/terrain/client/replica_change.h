#pragma once

// A change a replica applied, recorded so that a copy of the world that follows it by changed
// tiles (Replica::follow, replica_sync.h) marks dirty what it changed, as an apply would have: a
// whole state (snapshot or genesis), an op's cells, or a repair's tiles.

#include <terrain/terrain.h>

#include <cstdint>
#include <vector>

namespace terrain::client {

struct ReplicaChange {
    enum class Kind : std::uint8_t {
        kState,  ///< a snapshot or a genesis loaded at `seq`
        kOp,     ///< op `seq`
        kRepair, ///< tile state sent at `seq`
    };
    Kind kind = Kind::kOp;
    std::uint64_t seq = 0;
    /// kOp: the cells whose surface the op may have changed (its OpEffect's).
    CellRect cells;
    /// kRepair: the tiles replaced, in the order sent.
    std::vector<std::int32_t> tiles;
};

} // namespace terrain::client
