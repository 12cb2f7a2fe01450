#!/usr/bin/env python3
"""The terrain client's C ABI from Python through ctypes (the system python3 alone), as another
language's binding would drive it: join a live server (the network on the client's own thread),
fire craters, check the replica's world hash against the server's at the end, read a tile's
buffers.

    test_c_abi.py LIBRARY PORT TOKEN SERVER_BIN   exit 0 when every check holds
"""
import ctypes as C
import subprocess
import sys

from terrain_ctypes import Answer, Camera, Options, Tile, World


def main():
    library, port, token, server_bin = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
    lib = C.CDLL(library)
    lib.terrain_client_last_error.restype = C.c_char_p
    lib.terrain_status_name.restype = C.c_char_p
    lib.terrain_client_tile_count.restype = C.c_int32
    handle = C.c_void_p()

    def check(status, what):
        if status != 0:
            raise SystemExit("%s: %s: %s" % (what, lib.terrain_status_name(status).decode(),
                                             lib.terrain_client_last_error(handle).decode()))

    assert lib.terrain_abi_version() == 2
    options = Options()
    lib.terrain_client_options_init(C.byref(options))
    assert options.port == 7777 and options.tau_pixels == 1.0
    options.port = port
    options.token = token.encode()
    options.give_up_seconds = 10.0
    options.network_thread = 1  # the C and C++ examples pump the network; this uses the thread
    check(lib.terrain_client_create(C.byref(options), C.byref(handle)), "create")
    # misuse, refused at once by name: a crater before connect, a bad tile
    assert lib.terrain_client_request_op(handle, 1, C.c_double(5), C.c_double(5), C.c_double(3),
                                         C.c_double(1), C.c_double(0.3), None) == 2  # NOT_CONNECTED
    check(lib.terrain_client_connect(handle), "connect")
    check(lib.terrain_client_wait_synced(handle, C.c_double(20.0)), "wait_synced")
    world = World()
    check(lib.terrain_client_world(handle, C.byref(world)), "world")
    assert world.loaded and world.synced, "synced"
    assert lib.terrain_client_request_op(handle, 1, C.c_double(float("nan")), C.c_double(5),
                                         C.c_double(3), C.c_double(1), C.c_double(0.3),
                                         None) == 1  # BAD_PARAMETER
    assert b"finite" in lib.terrain_client_last_error(handle), lib.terrain_client_last_error(handle)

    ids = []
    for i in range(20):
        rid = C.c_uint32()
        check(lib.terrain_client_request_op(handle, 1, C.c_double(40.0 + 7 * i),
                                            C.c_double(50.0 + 4 * i), C.c_double(3.0),
                                            C.c_double(1.5), C.c_double(0.3), C.byref(rid)),
              "request_op")
        ids.append(rid.value)
    camera = Camera()
    lib.terrain_camera_init(C.byref(camera))
    camera.eye[0], camera.eye[1], camera.eye[2] = 30.0, 30.0, 60.0
    camera.forward[0], camera.forward[1], camera.forward[2] = 1.0, 0.8, -0.4
    answers = {}
    answer, got, changed = Answer(), C.c_int(), C.c_int()
    for _ in range(5000):
        check(lib.terrain_client_pump(handle), "pump")
        check(lib.terrain_client_tessellate(handle, C.byref(camera), C.byref(changed)),
              "tessellate")
        while True:
            check(lib.terrain_client_next_answer(handle, C.byref(answer), C.byref(got)), "answer")
            if not got.value:
                break
            answers[answer.request_id] = (answer.accepted, answer.seq)
        check(lib.terrain_client_world(handle, C.byref(world)), "world")
        if len(answers) == len(ids) and world.synced and world.seq == len(ids):
            break
    assert sorted(answers) == sorted(ids), "every crater answered"
    assert all(a for a, _ in answers.values()), "every crater accepted"
    health = subprocess.run([server_bin, "health", "--connect", "127.0.0.1:%d" % port],
                            capture_output=True, text=True).stdout
    expected = "seq %d, hash %016x" % (world.seq, world.world_hash)
    assert expected in health, "the server's world: %r, ours: %r" % (health, expected)
    assert world.hash_mismatches == 0 and world.ops_applied == len(ids)

    # a tile's buffers, as an engine would copy them
    triangles = 0
    for t in range(lib.terrain_client_tile_count(handle)):
        tile = Tile()
        check(lib.terrain_client_tile(handle, t, C.byref(tile)), "tile")
        for k in range(tile.index_count):
            assert tile.indices[k] < tile.vertex_count
        for v in range(tile.vertex_count):
            vx = tile.vertices[v]
            assert 0.0 <= vx.x <= world.extent_x and 0.0 <= vx.y <= world.extent_y
            assert vx.normal != 0
        if tile.visible:
            triangles += tile.index_count // 3
        check(lib.terrain_client_mark_uploaded(handle, t), "mark_uploaded")
    assert triangles > 0
    assert lib.terrain_client_tile(handle, 10**6, C.byref(Tile())) == 1  # BAD_PARAMETER

    lib.terrain_client_close(handle)
    assert lib.terrain_client_pump(handle) == 5  # CLOSED
    lib.terrain_client_destroy(handle)
    print("python ctypes: seq %d hash %016x, %d craters answered, %d triangles drawn" %
          (world.seq, world.world_hash, len(answers), triangles))


if __name__ == "__main__":
    main()
