#!/usr/bin/env python3
"""The replica on its own through the C ABI (terrain_replica.h), from Python's ctypes (the system
python3 alone), as a client in another language that speaks the protocol itself would use it.

It fires ops of every kind at a live server through the game client, then follows the server's
journal (server/journal/FORMAT.md, read here from the document alone) through replicas made from
the server's snapshot files, from the procedural genesis and from a genesis delta: every op's
world hash is checked against the one the server journaled. A replica made to diverge names its
suspect tiles and is repaired from the server's tile records. Misuse is refused by name.

    test_replica_abi.py LIBRARY PORT TOKEN DATA_DIR SEED SIZE   exit 0 when every check holds
"""
import ctypes as C
import glob
import os
import random
import shutil
import struct
import sys
import tempfile
import time

from terrain_ctypes import (Answer, BAD_DATA, BAD_PARAMETER, NOT_SYNCED, OK, Op, Options,
                            OP_APPLIED, OP_DIVERGED, OP_STALE, OP_STILL_DIVERGED, ReplicaState,
                            SEQ_GAP, STATE_GENESIS_DELTA, STATE_SNAPSHOT, World, declare_replica)

# ops fired, a round at a time; the server snapshots every 30 ops and keeps its newest two, so a
# copy after every 10 ops sees each snapshot and each record before a prune can delete it
ROUNDS = (10,) * 13
RECORD = struct.Struct("<4sQBqqiiiQQ")  # FORMAT.md, "Record (57 bytes, fixed)"


class Deformer:
    """The game client through the C ABI, firing ops of the four kinds at the server."""

    def __init__(self, lib, port, token, size):
        self.lib, self.size, self.handle = lib, size, C.c_void_p()
        self.rng = random.Random(47)
        options = Options()
        lib.terrain_client_options_init(C.byref(options))
        options.port, options.token, options.give_up_seconds = port, token.encode(), 10.0
        self.check(lib.terrain_client_create(C.byref(options), C.byref(self.handle)), "create")
        self.check(lib.terrain_client_connect(self.handle), "connect")
        self.check(lib.terrain_client_wait_synced(self.handle, C.c_double(20.0)), "wait_synced")
        self.fired = 0

    def check(self, status, what):
        if status != OK:
            raise SystemExit("%s: %s: %s" % (
                what, self.lib.terrain_status_name(status).decode(),
                self.lib.terrain_client_last_error(self.handle).decode()))

    def fire(self, n):
        """Sends n ops and waits until each is accepted and applied; returns (seq, hash)."""
        lib, rng, extent = self.lib, self.rng, float(self.size - 1)
        for _ in range(n):
            kind = 1 + self.fired % 4  # crater, raise, flatten, smooth
            self.fired += 1
            x, y = rng.uniform(8, extent - 8), rng.uniform(8, extent - 8)
            radius = rng.uniform(2.0, 7.0)
            height, strength = {1: (rng.uniform(0.5, 2.0), 0.3),
                                2: (rng.choice([-1, 1]) * rng.uniform(0.5, 2.0), 1.0),
                                3: (rng.uniform(30.0, 50.0), 0.5),
                                4: (0.0, 0.5)}[kind]
            self.check(lib.terrain_client_request_op(
                self.handle, kind, C.c_double(x), C.c_double(y), C.c_double(radius),
                C.c_double(height), C.c_double(strength), None), "request_op")
            self.check(lib.terrain_client_pump(self.handle), "pump")
        world, answer, got = World(), Answer(), C.c_int()
        deadline = time.time() + 60
        while time.time() < deadline:
            self.check(lib.terrain_client_pump(self.handle), "pump")
            while True:
                self.check(lib.terrain_client_next_answer(self.handle, C.byref(answer),
                                                          C.byref(got)), "answer")
                if not got.value:
                    break
                assert answer.accepted, "op refused: %s" % answer.reason.decode()
            self.check(lib.terrain_client_world(self.handle, C.byref(world)), "world")
            if world.seq == self.fired:
                break
            time.sleep(0.002)
        assert world.seq == self.fired, "seq %d after %d ops" % (world.seq, self.fired)
        assert world.hash_mismatches == 0
        return world.seq, world.world_hash

    def close(self):
        self.lib.terrain_client_destroy(self.handle)


def snapshot_seqs(directory):
    return sorted(int(os.path.basename(p)[9:29])
                  for p in glob.glob(os.path.join(directory, "snapshot-*.trsn")))


def keep_files(data_dir, kept):
    """Copies the data dir's snapshots and segments into `kept`. The server writes a snapshot on
    its own thread and then deletes all but its newest two with the segments before the older, so
    a file listed here may be gone when it is copied: an earlier round copied it, and a newer
    snapshot is there."""
    for path in glob.glob(os.path.join(data_dir, "*.t*")):
        if path.endswith((".trsn", ".tjl")):
            try:
                shutil.copy(path, kept)
            except FileNotFoundError:
                pass


def read_journal(data_dir, last_seq):
    """Every record up to last_seq, checked against FORMAT.md's layout: [(seq, Op, hash)]."""
    records = []
    for path in sorted(glob.glob(os.path.join(data_dir, "journal-*.tjl"))):
        with open(path, "rb") as f:
            data = f.read()
        magic, version, first = struct.unpack_from("<4sIQ", data, 0)
        assert magic == b"TJSG" and version == 2, (path, magic, version)
        assert first == int(os.path.basename(path)[8:28]), path
        for k in range((len(data) - 24) // RECORD.size):
            (magic, seq, kind, cx, cy, radius, height, strength, world_hash,
             _checksum) = RECORD.unpack_from(data, 24 + RECORD.size * k)
            assert magic == b"TJR1" and seq == first + k, (path, k, magic, seq)
            records.append((seq, Op(kind, cx, cy, radius, height, strength), world_hash))
    records = [r for r in records if r[0] <= last_seq]
    assert [r[0] for r in records] == list(range(1, last_seq + 1)), "the journal has every seq"
    return records


def read_snapshot(data_dir, seq):
    """The snapshot file at seq: (bytes, world hash, {tile: record bytes})."""
    with open(os.path.join(data_dir, "snapshot-%020d.trsn" % seq), "rb") as f:
        data = f.read()
    magic, version = struct.unpack_from("<4sI", data, 0)
    assert magic == b"TRSN" and version == 2
    (file_seq,) = struct.unpack_from("<Q", data, 28)
    (tile_count,) = struct.unpack_from("<I", data, 36)
    assert file_seq == seq
    tiles, at = {}, 40
    for t in range(tile_count):
        (length,) = struct.unpack_from("<I", data, at)
        tiles[t] = data[at + 4:at + 4 + length]
        at += 4 + length
    (world_hash,) = struct.unpack_from("<Q", data, len(data) - 16)
    return data, world_hash, tiles


def main():
    library, port, token, data_dir = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
    seed, size = int(sys.argv[5]), int(sys.argv[6])
    lib = C.CDLL(library)
    lib.terrain_client_last_error.restype = C.c_char_p
    declare_replica(lib)
    assert lib.terrain_abi_version() == 2

    kept = tempfile.mkdtemp(prefix="terrain-replica-abi-")
    deformer = Deformer(lib, port, token, size)
    for n in ROUNDS:
        last_seq, last_hash = deformer.fire(n)
        keep_files(data_dir, kept)
    deformer.close()
    snapshots = snapshot_seqs(kept)
    assert len(snapshots) >= 3 and snapshots[0] == 0 and snapshots[2] < last_seq, snapshots
    journal = read_journal(kept, last_seq)
    assert journal[-1][2] == last_hash, "the journal's last hash is the client's"

    replicas = []

    def replica():
        r = C.c_void_p()
        assert lib.terrain_replica_create(C.byref(r)) == OK
        replicas.append(r)
        return r

    def check(r, status, what):
        if status != OK:
            raise SystemExit("%s: %s: %s" % (what, lib.terrain_status_name(status).decode(),
                                             lib.terrain_replica_last_error(r).decode()))

    def state(r):
        s = ReplicaState()
        check(r, lib.terrain_replica_state_get(r, C.byref(s)), "state")
        return s

    def load(r, data, what):
        check(r, lib.terrain_replica_load(r, data, C.c_size_t(len(data))), what)

    def follow(r, records, expect=OP_APPLIED):
        """Applies each record's op with its journaled hash; every outcome must be `expect`."""
        outcome = C.c_int()
        for seq, op, world_hash in records:
            hash_in = C.c_uint64(world_hash)
            check(r, lib.terrain_replica_apply_op(r, seq, C.byref(op), C.byref(hash_in),
                                                  C.byref(outcome)), "apply op %d" % seq)
            assert outcome.value == expect, "op %d: outcome %d" % (seq, outcome.value)
            s = state(r)
            assert s.seq == seq
            if expect == OP_APPLIED:
                assert s.world_hash == world_hash, "op %d: hash differs" % seq
        return len(records)

    def save(r, fmt):
        data, n = C.POINTER(C.c_uint8)(), C.c_size_t()
        check(r, lib.terrain_replica_save(r, fmt, C.byref(data), C.byref(n)), "save")
        return C.string_at(data, n.value)

    snap0, hash0, _ = read_snapshot(kept, 0)
    mid, late = snapshots[1], snapshots[2]
    snap_mid, hash_mid, tiles_mid = read_snapshot(kept, mid)
    snap_late, hash_late, tiles_late = read_snapshot(kept, late)
    checked = 0

    # 1. from the server's first snapshot file through every op of the journal; the state saved
    #    at each later snapshot's seq is that file, byte for byte
    a = replica()
    load(a, snap0, "load snapshot 0")
    s = state(a)
    assert s.loaded and s.seq == 0 and s.world_hash == hash0 == s.genesis_hash
    assert (s.width, s.height, s.tiles_x * s.tiles_y) == (size, size, len(tiles_mid))
    checked += follow(a, journal[:mid])
    assert save(a, STATE_SNAPSHOT) == snap_mid, "seq %d saved as the server's file" % mid
    checked += follow(a, journal[mid:late])
    assert save(a, STATE_SNAPSHOT) == snap_late, "seq %d saved as the server's file" % late
    checked += follow(a, journal[late:])
    assert state(a).world_hash == last_hash and state(a).hash_mismatches == 0
    height = C.c_double()
    check(a, lib.terrain_replica_height_at(a, C.c_double(size / 2), C.c_double(size / 3),
                                           C.byref(height)), "height_at")
    assert 0.0 < height.value < 200.0, height.value

    # 2. the genesis made from the seed alone is the server's; a genesis delta on it is the world
    b = replica()
    check(b, lib.terrain_replica_load_procedural(b, C.c_uint64(seed), size, C.c_double(0)),
          "procedural")
    assert state(b).world_hash == hash0 and state(b).seq == 0
    delta = save(a, STATE_GENESIS_DELTA)
    assert delta[:4] == b"TRGD" and len(delta) < len(snap0)
    load(b, delta, "load genesis delta")
    assert (state(b).seq, state(b).world_hash) == (last_seq, last_hash)
    check(b, lib.terrain_replica_reset_to_genesis(b), "reset to genesis")
    assert (state(b).seq, state(b).world_hash) == (0, hash0)
    checked += follow(b, journal)  # the genesis, then every op again

    # 3. from the middle snapshot file on
    c = replica()
    load(c, snap_mid, "load snapshot %d" % mid)
    checked += follow(c, journal[mid:])

    # 4. diverged: an op that is not the server's is found by its hash, the suspect tiles named,
    #    and the server's tile records repair them
    d = replica()
    load(d, snap_mid, "load snapshot %d" % mid)
    checked += follow(d, journal[mid:late - 3])
    seq, op, world_hash = journal[late - 3]
    wrong = Op(op.kind, op.center_x, op.center_y, op.radius, op.height, op.strength)
    wrong.center_x += 3 * 1024  # 3 m off: the server's hash cannot match
    follow(d, [(seq, wrong, world_hash)], expect=OP_DIVERGED)
    follow(d, journal[late - 2:late], expect=OP_STILL_DIVERGED)
    assert state(d).diverged and state(d).verified_seq == late - 3
    count = C.c_size_t()
    check(d, lib.terrain_replica_suspect_tiles(d, None, 0, C.byref(count)), "suspects")
    suspects = (C.c_int32 * count.value)()
    check(d, lib.terrain_replica_suspect_tiles(d, suspects, count.value, C.byref(count)),
          "suspects")
    assert 0 < count.value < len(tiles_late), count.value
    repair = b"".join(struct.pack("<I", len(tiles_late[t])) + tiles_late[t] for t in suspects)
    server = replica()
    load(server, snap_late, "load snapshot %d" % late)
    hashes, tile_hash = (C.c_uint64 * len(tiles_late))(), C.c_uint64()
    for t in range(len(tiles_late)):
        check(server, lib.terrain_replica_tile_hash(server, t, C.byref(tile_hash)), "hash")
        hashes[t] = tile_hash.value
    # records a rule refuses change nothing: a tile off the map (the decoder's rule), and a
    # vertex moved under a patch's corner (found once the tiles are in: put back)
    off_map = bytearray(repair)
    struct.pack_into("<I", off_map, 4, 99)
    patched = [t for t in suspects if struct.unpack_from("<I", tiles_late[t], 33808)[0] > 0]
    assert patched, "a suspect tile has a patch"
    cornered = b""
    for t in suspects:
        record = bytearray(tiles_late[t])
        if t == patched[0]:
            (cell,) = struct.unpack_from("<H", record, 33812)
            vertex = (cell // 64) * 65 + cell % 64
            (h,) = struct.unpack_from("<i", record, 8 + 4 * vertex)
            struct.pack_into("<i", record, 8 + 4 * vertex, h + 1000)
        cornered += struct.pack("<I", len(record)) + bytes(record)
    before = state(d).world_hash
    for bad, rule in ((off_map, b"tile"), (cornered, b"corner")):
        status = lib.terrain_replica_apply_repair(d, late, hash_late, bytes(bad), len(bad),
                                                  hashes, len(tiles_late), None)
        message = lib.terrain_replica_last_error(d)
        assert status == BAD_DATA and rule in message, (status, message)
        assert state(d).world_hash == before and state(d).diverged and state(d).seq == late
    still = C.c_size_t(99)
    check(d, lib.terrain_replica_apply_repair(d, late, hash_late, repair, len(repair), hashes,
                                              len(tiles_late), C.byref(still)), "repair")
    assert still.value == 0 and not state(d).diverged and state(d).world_hash == hash_late
    assert state(d).repairs == 1
    checked += follow(d, journal[late:])

    # 5. misuse, refused at once by name, the state unchanged
    e = replica()
    assert lib.terrain_replica_load(e, delta, C.c_size_t(len(delta))) == NOT_SYNCED
    assert b"genesis" in lib.terrain_replica_last_error(e)
    assert lib.terrain_replica_apply_op(e, 1, C.byref(journal[0][1]), None, None) == NOT_SYNCED
    assert lib.terrain_replica_load(e, b"XXXXXXXX", C.c_size_t(8)) == BAD_DATA
    assert lib.terrain_replica_load(e, snap0[:-9], C.c_size_t(len(snap0) - 9)) == BAD_DATA
    assert not state(e).loaded
    check(e, lib.terrain_replica_load_procedural(e, C.c_uint64(seed + 1), size, C.c_double(0)),
          "procedural")
    assert lib.terrain_replica_load(e, delta, C.c_size_t(len(delta))) == BAD_DATA  # another genesis
    assert b"genesis" in lib.terrain_replica_last_error(e), lib.terrain_replica_last_error(e)
    outcome = C.c_int()
    assert lib.terrain_replica_apply_op(a, 5, C.byref(journal[4][1]), None,
                                        C.byref(outcome)) == OK and outcome.value == OP_STALE
    assert lib.terrain_replica_apply_op(a, last_seq + 2, C.byref(journal[0][1]), None,
                                        None) == SEQ_GAP
    assert b"missed" in lib.terrain_replica_last_error(a)
    for field, value in (("kind", 9), ("radius", 0), ("center_x", -1)):
        op = Op(1, 5000, 5000, 3000, 1000, 20000)
        setattr(op, field, value)
        assert lib.terrain_replica_apply_op(a, last_seq + 1, C.byref(op), None, None) == BAD_DATA
    assert b"center" in lib.terrain_replica_last_error(a) or \
        b"outside" in lib.terrain_replica_last_error(a), lib.terrain_replica_last_error(a)
    assert lib.terrain_replica_tile_hash(a, len(tiles_mid), C.byref(C.c_uint64())) == \
        BAD_PARAMETER
    assert lib.terrain_replica_save(a, 7, C.byref(C.POINTER(C.c_uint8)()),
                                    C.byref(C.c_size_t())) == BAD_PARAMETER
    assert (state(a).seq, state(a).world_hash) == (last_seq, last_hash), "misuse changed nothing"

    for r in replicas:
        lib.terrain_replica_destroy(r)
    shutil.rmtree(kept)
    print("python replica: %d ops followed with every hash checked, %d suspect tiles repaired, "
          "seq %d hash %016x" % (checked, count.value, last_seq, last_hash))


if __name__ == "__main__":
    main()
