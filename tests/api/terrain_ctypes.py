"""The C ABI's structures for ctypes (terrain_client.h, terrain_replica.h), field for field, as
another language's binding declares them; shared by the Python tests."""
import ctypes as C


class Options(C.Structure):
    _fields_ = [("host", C.c_char_p), ("port", C.c_uint16), ("token", C.c_char_p),
                ("client_name", C.c_char_p), ("connect_timeout_seconds", C.c_double),
                ("give_up_seconds", C.c_double), ("reconnect", C.c_int),
                ("ops_per_frame", C.c_int), ("catch_up_frames", C.c_int),
                ("tau_pixels", C.c_double), ("max_triangles", C.c_int64),
                ("worker_threads", C.c_uint32), ("network_thread", C.c_int)]


class World(C.Structure):
    _fields_ = [("seq", C.c_uint64), ("world_hash", C.c_uint64), ("loaded", C.c_int),
                ("live", C.c_int), ("synced", C.c_int), ("closed", C.c_int),
                ("ops_applied", C.c_uint64), ("hash_mismatches", C.c_uint64),
                ("repairs", C.c_uint64), ("snapshots", C.c_uint64),
                ("extent_x", C.c_double), ("extent_y", C.c_double)]


class Answer(C.Structure):
    _fields_ = [("request_id", C.c_uint32), ("accepted", C.c_int), ("seq", C.c_uint64),
                ("reason", C.c_char_p)]


class Camera(C.Structure):
    _fields_ = [("eye", C.c_double * 3), ("forward", C.c_double * 3), ("up", C.c_double * 3),
                ("fovy_radians", C.c_double), ("viewport_width", C.c_int),
                ("viewport_height", C.c_int), ("near_plane", C.c_double)]


class Vertex(C.Structure):
    _fields_ = [("x", C.c_float), ("y", C.c_float), ("z", C.c_float), ("normal", C.c_uint32)]


class Tile(C.Structure):
    _fields_ = [("visible", C.c_int), ("vertices", C.POINTER(Vertex)),
                ("vertex_count", C.c_uint32), ("indices", C.POINTER(C.c_uint32)),
                ("index_count", C.c_uint32), ("indices_rewritten", C.c_int),
                ("dirty_pages", C.POINTER(C.c_uint32)), ("dirty_page_count", C.c_uint32),
                ("vertices_all_changed", C.c_int), ("vertex_runs", C.c_void_p),
                ("vertex_run_count", C.c_uint32)]


class Op(C.Structure):
    _fields_ = [("kind", C.c_int), ("center_x", C.c_int64), ("center_y", C.c_int64),
                ("radius", C.c_int32), ("height", C.c_int32), ("strength", C.c_int32)]


class ReplicaState(C.Structure):
    _fields_ = [("loaded", C.c_int), ("seq", C.c_uint64), ("world_hash", C.c_uint64),
                ("genesis_hash", C.c_uint64), ("diverged", C.c_int),
                ("verified_seq", C.c_uint64), ("width", C.c_int32), ("height", C.c_int32),
                ("spacing", C.c_int32), ("units_per_metre", C.c_int32),
                ("patch_tolerance", C.c_int32), ("tiles_x", C.c_int32), ("tiles_y", C.c_int32),
                ("ops_applied", C.c_uint64), ("hash_mismatches", C.c_uint64),
                ("repairs", C.c_uint64), ("states_loaded", C.c_uint64)]


# terrain_status values
OK, BAD_PARAMETER, NOT_CONNECTED, NOT_SYNCED, TIMED_OUT, CLOSED = 0, 1, 2, 3, 4, 5
REFUSED_BY_SERVER, INTERNAL, BAD_DATA, SEQ_GAP = 6, 7, 8, 9
# terrain_op_outcome values
OP_APPLIED, OP_STALE, OP_DIVERGED, OP_STILL_DIVERGED = 0, 1, 2, 3
# terrain_state_format values
STATE_SNAPSHOT, STATE_GENESIS_DELTA = 1, 2


def declare_replica(lib):
    """The replica's prototypes: without them ctypes passes every Python int as a C int."""
    P = C.POINTER
    lib.terrain_status_name.restype = C.c_char_p
    lib.terrain_replica_last_error.restype = C.c_char_p
    lib.terrain_replica_create.argtypes = [P(C.c_void_p)]
    lib.terrain_replica_destroy.argtypes = [C.c_void_p]
    lib.terrain_replica_last_error.argtypes = [C.c_void_p]
    lib.terrain_replica_load.argtypes = [C.c_void_p, C.c_char_p, C.c_size_t]
    lib.terrain_replica_load_procedural.argtypes = [C.c_void_p, C.c_uint64, C.c_int32,
                                                    C.c_double]
    lib.terrain_replica_reset_to_genesis.argtypes = [C.c_void_p]
    lib.terrain_replica_apply_op.argtypes = [C.c_void_p, C.c_uint64, P(Op), P(C.c_uint64),
                                             P(C.c_int)]
    lib.terrain_replica_state_get.argtypes = [C.c_void_p, P(ReplicaState)]
    lib.terrain_replica_suspect_tiles.argtypes = [C.c_void_p, P(C.c_int32), C.c_size_t,
                                                  P(C.c_size_t)]
    lib.terrain_replica_tile_hash.argtypes = [C.c_void_p, C.c_int32, P(C.c_uint64)]
    lib.terrain_replica_height_at.argtypes = [C.c_void_p, C.c_double, C.c_double,
                                              P(C.c_double)]
    lib.terrain_replica_apply_repair.argtypes = [C.c_void_p, C.c_uint64, C.c_uint64, C.c_char_p,
                                                 C.c_size_t, P(C.c_uint64), C.c_size_t,
                                                 P(C.c_size_t)]
    lib.terrain_replica_save.argtypes = [C.c_void_p, C.c_int, P(P(C.c_uint8)), P(C.c_size_t)]
    for f in (lib.terrain_replica_create, lib.terrain_replica_load,
              lib.terrain_replica_load_procedural, lib.terrain_replica_reset_to_genesis,
              lib.terrain_replica_apply_op, lib.terrain_replica_state_get,
              lib.terrain_replica_suspect_tiles, lib.terrain_replica_tile_hash,
              lib.terrain_replica_height_at, lib.terrain_replica_apply_repair,
              lib.terrain_replica_save):
        f.restype = C.c_int
