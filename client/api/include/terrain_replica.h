/* The world's replica on its own, in C99 (also C++17): for a client in another language that
 * speaks the protocol itself (proto/PROTOCOL.md) and needs our core only to follow the ops, and
 * for tools that check journals. libterrain_client.so exports it beside terrain_client.h.
 *
 * A replica holds one world state at a seq: load a snapshot (a join snapshot, a snapshot file),
 * a genesis delta over the genesis it holds, or make the procedural genesis; then apply each op
 * with the world hash the server sent after it. A hash that differs marks the replica diverged
 * and names the suspect tiles; the server's tile state (RepairState) repairs them.
 *
 * Rules, as for terrain_client.h: every function returns a terrain_status (or a value that cannot
 * fail); on an error terrain_replica_last_error() names the rule broken, and the replica is as it
 * was before the call (a refused op, snapshot, delta or repair changes nothing). A replica is
 * used from one thread at a time; replicas are independent.
 *
 * Numbers are the protocol's: positions, radii and heights in quanta (the world's
 * units_per_metre per metre), strength 16.16 fixed point; tiles numbered t = ty * tiles_x + tx.
 */
#ifndef TERRAIN_REPLICA_H
#define TERRAIN_REPLICA_H

#include <terrain_client.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct terrain_replica terrain_replica;

/* An op as the server broadcasts and journals it (PROTOCOL.md, "The op"). kind is a
 * terrain_op_kind (1 crater .. 4 smooth: the wire's kind + 1, as in the journal), passed as an
 * int so that any value is checked, not undefined. */
typedef struct terrain_op {
    int kind;
    int64_t center_x, center_y; /* quanta from vertex (0, 0) */
    int32_t radius;             /* quanta */
    int32_t height;             /* quanta: depth, mound height, target level; smooth: 0 */
    int32_t strength;           /* 16.16: 65536 is 1 */
} terrain_op;

typedef enum terrain_op_outcome {
    TERRAIN_OP_APPLIED = 0,  /* applied; its hash equals the server's (or it had none to check) */
    TERRAIN_OP_STALE = 1,    /* seq already held: ignored, nothing changed */
    TERRAIN_OP_DIVERGED = 2, /* applied, but the hash differs: repair the suspect tiles */
    TERRAIN_OP_STILL_DIVERGED = 3 /* applied while diverged: not repaired yet (its hash, if
                                   * given, differs too) */
} terrain_op_outcome;

typedef struct terrain_replica_state {
    int loaded;            /* a world is held */
    uint64_t seq;          /* the last op applied (0: the genesis) */
    uint64_t world_hash;   /* at seq */
    uint64_t genesis_hash; /* the world hash of the genesis held (Hello.genesis_hash) */
    int diverged;          /* from a mismatch until a repair or a state restores the hash */
    uint64_t verified_seq; /* the last seq whose hash matched the server's */
    int32_t width, height; /* vertices */
    int32_t spacing;       /* quanta between vertices */
    int32_t units_per_metre;
    int32_t patch_tolerance; /* quanta */
    int32_t tiles_x, tiles_y;
    uint64_t ops_applied, hash_mismatches, repairs, states_loaded;
} terrain_replica_state;

/* Formats terrain_replica_save() writes. */
typedef enum terrain_state_format {
    TERRAIN_STATE_SNAPSHOT = 1,     /* a raw snapshot (TRSN), as snapshot-<seq>.trsn files */
    TERRAIN_STATE_GENESIS_DELTA = 2 /* a genesis delta (TRGD): the tiles that differ */
} terrain_state_format;

TERRAIN_API terrain_status terrain_replica_create(terrain_replica** out);
/* Frees; NULL is allowed. */
TERRAIN_API void terrain_replica_destroy(terrain_replica* replica);
/* The message of the last call that failed on this replica; "" if none. */
TERRAIN_API const char* terrain_replica_last_error(const terrain_replica* replica);

/* Replaces the state with one from bytes, each byte untrusted (a refusal names the rule):
 * - a raw snapshot (TRSN: a snapshot file, a join snapshot's content);
 * - a genesis delta (TRGD) over the genesis of the world held (NOT_SYNCED when none is held;
 *   BAD_DATA, naming the hash, when it was made on another genesis);
 * - either as one zstd frame with its content size (SnapshotChunk data, concatenated).
 * BAD_DATA for bytes any rule refuses. */
TERRAIN_API terrain_status
terrain_replica_load(terrain_replica* replica, const void* bytes, size_t size);
/* Makes the genesis of `terrain-server --seed S --size N [--tolerance T]`: the procedural map at
 * seq 0. patch_tolerance_metres 0 means the server's default (1/32 m). */
TERRAIN_API terrain_status terrain_replica_load_procedural(
    terrain_replica* replica, uint64_t seed, int32_t size, double patch_tolerance_metres);
/* Replaces the state with the genesis of the world held (its original ground, no op), at seq 0. */
TERRAIN_API terrain_status terrain_replica_reset_to_genesis(terrain_replica* replica);

/* Applies op `seq` on top of seq - 1. world_hash: the hash the server sent after it, or NULL for
 * an op of a batch whose hash comes with a later op (checked then). *outcome (may be NULL) gets a
 * terrain_op_outcome. NOT_SYNCED without a world; SEQ_GAP when seq > current + 1 (take a
 * snapshot); BAD_DATA when the op breaks a rule (PROTOCOL.md, "Valid ops"). */
TERRAIN_API terrain_status terrain_replica_apply_op(
    terrain_replica* replica,
    uint64_t seq,
    const terrain_op* op,
    const uint64_t* world_hash,
    int* outcome);

TERRAIN_API terrain_status
terrain_replica_state_get(const terrain_replica* replica, terrain_replica_state* out);
/* The tiles to ask the server for while diverged (RepairRequest.tiles), ascending. *count gets how
 * many there are; at most `capacity` are written to tiles (NULL with capacity 0: count only). */
TERRAIN_API terrain_status terrain_replica_suspect_tiles(
    const terrain_replica* replica, int32_t* tiles, size_t capacity, size_t* count);
TERRAIN_API terrain_status
terrain_replica_tile_hash(const terrain_replica* replica, int32_t tile, uint64_t* out);
/* The exact ground height at (x, y) metres; BAD_PARAMETER off the map. */
TERRAIN_API terrain_status
terrain_replica_height_at(const terrain_replica* replica, double x, double y, double* height_out);

/* Applies the server's tile state (RepairState): `tiles` is RepairState.tiles as received (one
 * zstd frame) or its content (per tile, ascending: u32 length + tile record); seq must be the
 * replica's (the reply follows every op up to it). tile_hashes: RepairState.tile_hashes (every
 * tile's, in order) or NULL with count 0. *still_differing (may be NULL) gets how many tiles
 * still differ from the server's hashes (0 when the world hash now matches: repaired). BAD_DATA
 * for records a rule refuses (nothing is applied), a repaired state that breaks an invariant,
 * or a hash list of the wrong length. */
TERRAIN_API terrain_status terrain_replica_apply_repair(
    terrain_replica* replica,
    uint64_t seq,
    uint64_t world_hash,
    const void* tiles,
    size_t size,
    const uint64_t* tile_hashes,
    size_t tile_hash_count,
    size_t* still_differing);

/* The state held, encoded in `format` (a terrain_state_format). *bytes stays valid until the next
 * call on the replica. */
TERRAIN_API terrain_status
terrain_replica_save(terrain_replica* replica, int format, const uint8_t** bytes, size_t* size);

#ifdef __cplusplus
}
#endif

#endif /* TERRAIN_REPLICA_H */
