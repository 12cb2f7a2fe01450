#pragma once

// A change a replica applied, recorded so that a second copy of the world (a tessellation
// worker's, on another thread) applies the same one and reaches the same bits: a whole state
// (snapshot or genesis), an op, or a repair. Cheap to record for an op (the op itself); a state
// is a copy of the world, shared read-only.

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
    std::shared_ptr<const Terrain> state;
    std::vector<TileRecord> tiles;
    std::vector<std::uint64_t> tile_hashes;
};

} // namespace terrain::client
