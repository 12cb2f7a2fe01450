#pragma once

// A change a replica applied, recorded so that a second copy of the world follows it: either by
// applying the same change (Replica::replay: the same bits) or by copying the tiles it changed
// and marking what it changed (Replica::follow: no apply). A whole state (snapshot or genesis),
// an op, or a repair. Cheap to record for an op (the op itself and its cells); a state is a copy
// of the world, shared read-only.

#include <terrain/deform_op.h>
#include <terrain/snapshot.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace terrain::client {

struct ReplicaChange {
    enum class Kind : std::uint8_t {
        kState,  ///< a snapshot or a genesis loaded: `state` at `seq`
        kOp,     ///< op `seq`, with the world hash it was checked against, if any
        kRepair, ///< tile state sent at `seq`, with the world hash and the server's tile hashes
    };
    Kind kind = Kind::kOp;
    std::uint64_t seq = 0;
    DeformOp op{};
    std::optional<std::uint64_t> world_hash;
    /// kOp: the cells whose surface the op may have changed (its OpEffect's), which a follower
    /// marks dirty without applying the op.
    CellRect cells;
    std::shared_ptr<const Terrain> state;
    std::vector<TileRecord> tiles;
    std::vector<std::uint64_t> tile_hashes;
};

} // namespace terrain::client
