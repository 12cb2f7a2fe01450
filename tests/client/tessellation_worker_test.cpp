// The tessellation worker (client/view): in lockstep it draws, frame by frame, what the
// synchronous path draws (index lists, vertices as drawn, versions, visibility) through a battle,
// a repair and a snapshot of another world; running free, it lags but settles on the mesh a
// synchronous view settles on; a replica's recorded changes replayed on another copy reach the
// same bits.

#include "support/drawn_mesh_checks.h"

#include <terrain/client/tessellation_worker.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <random>
#include <set>
#include <thread>

namespace terrain::client {
namespace {

using testing::difference;

Terrain map(std::uint64_t seed, std::int32_t width, std::int32_t height) {
    ProceduralMapOptions o;
    o.seed = seed;
    o.width = width;
    o.height = height;
    return std::move(*makeProceduralMap(o));
}

roam::Camera lowOver(const Terrain& t, double x, double y, double yaw) {
    roam::Camera c;
    c.eye = {x, y, surfaceHeight(t, x, y) + 6.0};
    c.forward = {std::cos(yaw), std::sin(yaw), -0.25};
    c.viewport_width = 640;
    c.viewport_height = 360;
    c.near_plane = 0.25;
    return c;
}

/// The server's side: a world and its ops, fed to every replica given.
struct Server {
    Terrain world;
    std::uint64_t seq = 1;
    std::mt19937_64 rng{17};

    /// Two craters 15-40 m ahead of (x, y) along `yaw`, applied to each replica.
    void shoot(double x, double y, double yaw, std::initializer_list<Replica*> replicas) {
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        for (int shot = 0; shot < 2; ++shot) {
            const double ahead = 15.0 + 25.0 * unit(rng);
            const double side = (unit(rng) - 0.5) * 20.0;
            OpRequest r;
            r.x = x + ahead * std::cos(yaw) - side * std::sin(yaw);
            r.y = y + ahead * std::sin(yaw) + side * std::cos(yaw);
            r.radius = 1.0 + 4.0 * unit(rng);
            r.height = 0.4 * r.radius;
            r.strength = 0.3 + 0.5 * unit(rng);
            auto op = quantizeOp(r, world.spec());
            if (!op || !world.apply(*op).ok())
                continue;
            ++seq;
            for (Replica* replica : replicas)
                ASSERT_TRUE(replica->applyOp(seq, *op, world.worldHash()).ok());
        }
    }
    /// Every tile of the world, as a repair carries them.
    std::vector<TileRecord> tiles() const {
        std::vector<TileRecord> out;
        for (std::int32_t t = 0; t < world.spec().tileCount(); ++t) {
            std::vector<std::uint8_t> bytes;
            world.appendTileBytes(t, bytes);
            out.push_back(std::move(*decodeTile(bytes, world.spec())));
        }
        return out;
    }
    void load(Replica& replica) const {
        replica.loadSnapshot(std::move(*decodeSnapshot(encodeSnapshot(world, seq))));
    }
};

TEST(TessellationWorker, InLockstepItDrawsWhatTheSynchronousPathDrawsFrameByFrame) {
    Server server{map(3, 257, 193)};
    Replica frame_replica; // the worker's, on the frame thread
    Replica sync_replica;  // the synchronous path's
    server.load(frame_replica);
    server.load(sync_replica);
    TessellationWorkerOptions o;
    o.lockstep = true;
    o.threads = 2; // the delta's contents on two threads: the same bytes
    TessellationWorker worker(frame_replica, o);
    ASSERT_EQ(worker.threads(), 2u);
    TerrainView sync(sync_replica, o.view);
    // the synchronous path's renderer takes the tessellator's changes every frame, as the
    // worker's collector does: what a frame may upload (the upload budget) is counted the same
    roam::DeltaCollector renderer;
    roam::MeshDelta taken;
    roam::DrawnMesh mesh;
    int upload_bound = 0;
#if defined(__SANITIZE_ADDRESS__)
    constexpr int kFrames = 40; // five times slower: the same events, closer together
#else
    constexpr int kFrames = 70;
#endif
    constexpr int kWhipFrom = kFrames * 2 / 7;
    constexpr int kWhipTo = kFrames * 3 / 7;
    constexpr int kRepairAt = kFrames / 2;
    constexpr int kNewWorldAt = kFrames * 5 / 7;
    for (int f = 0; f < kFrames; ++f) {
        const double x = 30.0 + (f % (kFrames / 2)) * 5.0 * 70.0 / kFrames;
        const double y = 40.0 + (f % (kFrames / 2)) * 2.5 * 70.0 / kFrames;
        const double yaw = f >= kWhipFrom && f < kWhipTo ? f * 0.7 : std::atan2(0.5, 1.0);
        if (f == kRepairAt) {
            // a repair of every tile (the same state: every tile dirty on both sides)
            const std::vector<std::uint64_t> hashes;
            ASSERT_TRUE(
                frame_replica
                    .applyRepair(server.seq, server.world.worldHash(), server.tiles(), hashes)
                    .ok());
            ASSERT_TRUE(
                sync_replica
                    .applyRepair(server.seq, server.world.worldHash(), server.tiles(), hashes)
                    .ok());
        }
        if (f == kNewWorldAt) {
            // a snapshot of another world, smaller
            server.world = map(9, 193, 193);
            server.seq = 1000;
            server.load(frame_replica);
            server.load(sync_replica);
        }
        if (f < kWhipFrom || f >= kWhipTo)
            server.shoot(x, y, yaw, {&frame_replica, &sync_replica});
        const roam::Camera camera = lowOver(server.world, x, y, yaw);
        sync.absorb();
        sync.update(camera);
        renderer.collect(sync.tessellator(), sync_replica.terrain(), taken);
        renderer.delivered();
        worker.post(camera);
        ASSERT_TRUE(worker.take(mesh)) << "lockstep: a delta for every frame";
        EXPECT_EQ(worker.lag(), 0u);
        EXPECT_EQ(worker.taken().frame, static_cast<std::uint64_t>(f + 1));
        EXPECT_EQ(worker.taken().seq, sync_replica.seq());
        EXPECT_EQ(worker.taken().world_hash, sync_replica.worldHash());
        EXPECT_EQ(worker.taken().stats.triangles, sync.lastStats().triangles);
        upload_bound += worker.taken().stats.upload_budget_bound ? 1 : 0;
        EXPECT_EQ(worker.taken().threshold, sync.tessellator().threshold());
        ASSERT_EQ(difference(mesh, sync.tessellator(), sync_replica.terrain(), f % 3 == 0), "")
            << "frame " << f;
    }
    EXPECT_GT(sync_replica.stats().ops_applied, static_cast<std::uint64_t>(kFrames));
    // the upload budget bound in some frames: the two paths counted uploads alike
    EXPECT_GT(upload_bound, 0);
}

/// Every drawn triangle's corners (lattice x, y), per tile, from the copy's lists.
std::multiset<std::array<float, 7>> drawnTriangles(const roam::DrawnMesh& mesh) {
    std::multiset<std::array<float, 7>> out;
    for (std::int32_t t = 0; t < mesh.tileCount(); ++t) {
        const auto indices = mesh.indices(t);
        const auto vertices = mesh.vertices(t);
        for (std::size_t s = 0; s + 2 < indices.size(); s += 3) {
            const auto& a = vertices[indices[s]];
            const auto& b = vertices[indices[s + 1]];
            const auto& c = vertices[indices[s + 2]];
            out.insert({static_cast<float>(t), a.x, a.y, b.x, b.y, c.x, c.y});
        }
    }
    return out;
}

TEST(TessellationWorker, RunningFreeItLagsButSettlesOnTheMeshASynchronousViewSettlesOn) {
    Server server{map(4, 257, 193)};
    Replica frame_replica;
    Replica sync_replica;
    server.load(frame_replica);
    server.load(sync_replica);
    TessellationWorkerOptions o;
    TessellationWorker worker(frame_replica, o);
    roam::DrawnMesh mesh;
    std::uint64_t taken = 0;
    std::uint64_t max_lag = 0;
    for (int f = 0; f < 60; ++f) {
        const double x = 30.0 + f * 3.0;
        const double y = 40.0 + f * 1.5;
        server.shoot(x, y, 0.46, {&frame_replica, &sync_replica});
        worker.post(lowOver(server.world, x, y, 0.46));
        // frames of 3 ms that take the worker's changes one in four: deltas the frame thread
        // never takes are superseded (their changes must reach it in the next)
        std::this_thread::sleep_for(std::chrono::milliseconds(3));
        if (f % 4 == 3)
            taken += worker.take(mesh) ? 1 : 0;
        max_lag = std::max(max_lag, worker.lag());
    }
    EXPECT_GT(taken, 0u);
    // settle: the same camera until the worker has caught up and its mesh stopped moving
    const roam::Camera last = lowOver(server.world, 30.0 + 59 * 3.0, 40.0 + 59 * 1.5, 0.46);
    for (int f = 0; f < 2000; ++f) {
        worker.post(last);
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        worker.take(mesh);
        if (worker.lag() == 0 && worker.taken().seq == server.seq &&
            !worker.taken().stats.budget_exhausted && worker.taken().stats.splits == 0 &&
            worker.taken().stats.merges == 0)
            break;
    }
    ASSERT_EQ(worker.taken().seq, server.seq);
    EXPECT_EQ(worker.taken().world_hash, server.world.worldHash());
    TerrainView sync(sync_replica, o.view);
    for (int f = 0; f < 200; ++f) {
        sync.update(last);
        if (!sync.lastStats().budget_exhausted && sync.lastStats().splits == 0 &&
            sync.lastStats().merges == 0)
            break;
    }
    roam::DrawnMesh settled;
    roam::DeltaCollector collector;
    roam::MeshDelta delta;
    collector.collect(sync.tessellator(), sync_replica.terrain(), delta);
    ASSERT_TRUE(settled.apply(delta));
    EXPECT_EQ(drawnTriangles(mesh), drawnTriangles(settled));
    RecordProperty("max_lag", static_cast<int>(max_lag));
}

/// The height (metres) a lattice point is drawn at: its cell's 17 x 17 grid, the cell at or
/// before it (the last real one on the map's far lines), as the tessellator reads it.
double drawnHeight(const Terrain& t, float x, float y) {
    const auto lx = static_cast<std::int32_t>(x);
    const auto ly = static_cast<std::int32_t>(y);
    const std::int32_t cx = std::min(lx / roam::kLatticePerCell, t.spec().cellsX() - 1);
    const std::int32_t cy = std::min(ly / roam::kLatticePerCell, t.spec().cellsY() - 1);
    std::array<std::int64_t, roam::kBlockVertices> grid{};
    roam::fillCellHeights(t, cx, cy, grid);
    const std::int32_t k = lx - cx * roam::kLatticePerCell;
    const std::int32_t l = ly - cy * roam::kLatticePerCell;
    return static_cast<double>(grid[static_cast<std::size_t>(l * roam::kBlockSide + k)]) *
           t.spec().metresPerUnit() / static_cast<double>(roam::kFineUnitsPerQuantum);
}

TEST(TessellationWorker, ACratersHeightsAreDrawnBeforeItsSplitsAndMerges) {
    // steps that end almost at once: a crater's moves take many of them, and its heights (the
    // triangles drawn now, at the new surface) go first
    Server server{map(5, 257, 193)};
    Replica frame_replica;
    server.load(frame_replica);
    TessellationWorkerOptions o;
    o.step_ms = 0.05;
    o.keep_step_log = true;
    TessellationWorker worker(frame_replica, o);
    roam::DrawnMesh mesh;
    const roam::Camera camera = lowOver(server.world, 60.0, 60.0, 0.46);
    // a crater 20 m ahead, drawn and settled (its detail blocks resident), then another on it
    const auto crater = [&](double radius, double depth) {
        OpRequest r;
        r.x = 60.0 + 20.0 * std::cos(0.46);
        r.y = 60.0 + 20.0 * std::sin(0.46);
        r.radius = radius;
        r.height = depth;
        r.strength = 0.4;
        auto op = quantizeOp(r, server.world.spec());
        ASSERT_TRUE(op.ok());
        ASSERT_TRUE(server.world.apply(*op).ok());
        ++server.seq;
        ASSERT_TRUE(frame_replica.applyOp(server.seq, *op, server.world.worldHash()).ok());
    };
    crater(5.0, 2.0);
    worker.finish(camera, mesh);
    ASSERT_EQ(worker.taken().settled_seq, server.seq);
    crater(3.0, 1.2); // a smaller one in the bowl: every height there moves
    worker.post(camera);
    for (int i = 0; i < 5000 && worker.taken().seq < server.seq; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        worker.take(mesh);
    }
    ASSERT_EQ(worker.taken().seq, server.seq);
    // the first delta with the craters: every vertex a drawn triangle uses is at its new height
    std::int64_t checked = 0;
    for (std::int32_t t = 0; t < mesh.tileCount(); ++t) {
        const auto indices = mesh.indices(t);
        const auto vertices = mesh.vertices(t);
        for (const std::uint32_t i : indices) {
            const roam::DrawVertex& v = vertices[i];
            ASSERT_NEAR(v.z, drawnHeight(server.world, v.x, v.y), 1e-3)
                << "tile " << t << " vertex " << i << " at " << v.x << "," << v.y;
            ++checked;
        }
    }
    EXPECT_GT(checked, 10000);
    const std::vector<WorkerStep> log = worker.stepLog();
    EXPECT_TRUE(std::any_of(
        log.begin(), log.end(), [](const WorkerStep& s) { return s.ops > 0 && s.heights_first; }));
    // and the moves follow: the same camera until done, at the world's hash
    worker.finish(camera, mesh);
    EXPECT_EQ(worker.taken().world_hash, server.world.worldHash());
    EXPECT_EQ(worker.taken().settled_seq, server.seq) << "the craters converged";
}

TEST(ReplicaSyncs, FollowedByChangedTilesCopiesReachTheSameBitsAndDirtyCellsApplyingNothing) {
    // as a client's copies follow: the network's replica -> the frame's -> the worker's
    Server server{map(5, 193, 129)};
    Replica source;
    server.load(source);
    source.recordChanges(true);
    Replica frame;
    Replica worker;
    frame.recordChanges(true);
    std::vector<std::uint64_t> frame_versions;
    std::vector<std::uint64_t> worker_versions;
    frame.follow(source.takeSync(frame_versions, source.takeChanges()));
    worker.follow(frame.takeSync(worker_versions, frame.takeChanges()));
    EXPECT_TRUE(worker.takeDirty().all) << "a first follow is a whole new world";
    EXPECT_EQ(worker.terrain().computeWorldHash(), source.worldHash());
    const auto opsIn = [](const std::vector<ReplicaChange>& list) {
        return static_cast<std::size_t>(
            std::count_if(list.begin(), list.end(), [](const ReplicaChange& c) {
                return c.kind == ReplicaChange::Kind::kOp;
            }));
    };
    (void)source.takeDirty();
    for (int round = 0; round < 6; ++round) {
        server.shoot(40.0 + round * 20.0, 60.0, 0.3, {&source});
        server.shoot(50.0 + round * 20.0, 70.0, 0.5, {&source});
        if (round == 2) {
            // a tile corrupted behind the hashes' back, then repaired from the server
            source.terrainForTesting().apply(*quantizeOp(
                OpRequest{OpKind::kCrater, 70.0, 60.0, 5, 2, 0.3}, server.world.spec()));
            server.shoot(80.0, 60.0, 0.3, {&source});
            const std::vector<std::uint64_t> hashes;
            ASSERT_TRUE(
                source.applyRepair(server.seq, server.world.worldHash(), server.tiles(), hashes)
                    .ok());
        }
        if (round == 4)
            server.load(source);
        const DirtySet a = source.takeDirty();
        const ReplicaSync sync = source.takeSync(frame_versions, source.takeChanges());
        if (round != 2 && round != 4) {
            EXPECT_LT(sync.terrain.tileCount(), 6u) << "the tiles the shots touched, not all";
        }
        const std::uint64_t taken_hash = source.worldHash();
        // the source goes on before the copies catch up: its writes must not reach the lists
        // they share with it
        server.shoot(60.0, 50.0, 0.4, {&source});
        frame.follow(sync);
        worker.follow(frame.takeSync(worker_versions, frame.takeChanges()));
        for (const Replica* copy : {&frame, &worker}) {
            EXPECT_EQ(copy->seq(), sync.seq);
            EXPECT_EQ(copy->worldHash(), taken_hash);
            EXPECT_EQ(copy->terrain().computeWorldHash(), taken_hash) << "round " << round;
            EXPECT_EQ(copy->verifiedSeq(), sync.seq);
        }
        // the worker's dirty set is the one the source had for the same changes
        (void)frame.takeDirty();
        const DirtySet b = worker.takeDirty();
        EXPECT_EQ(a.all, b.all);
        EXPECT_EQ(a.tiles, b.tiles);
        ASSERT_EQ(a.cells.size(), b.cells.size());
        for (std::size_t k = 0; k < a.cells.size(); ++k)
            EXPECT_TRUE(
                a.cells[k].x0 == b.cells[k].x0 && a.cells[k].y0 == b.cells[k].y0 &&
                a.cells[k].x1 == b.cells[k].x1 && a.cells[k].y1 == b.cells[k].y1)
                << "round " << round << ", rectangle " << k;
        if (round != 4) {
            EXPECT_EQ(b.cells.size(), opsIn(sync.changes));
        }
        if (round == 2) {
            EXPECT_FALSE(b.tiles.empty()) << "the repaired tiles";
        }
        // the shot after the sync reaches the copies with the next one
        const ReplicaSync late = source.takeSync(frame_versions, source.takeChanges());
        EXPECT_GT(late.terrain.tileCount(), 0u);
        frame.follow(late);
        worker.follow(frame.takeSync(worker_versions, frame.takeChanges()));
        EXPECT_EQ(worker.terrain().computeWorldHash(), source.worldHash());
        EXPECT_EQ(worker.takeDirty().cells.size(), opsIn(late.changes));
        (void)frame.takeDirty();
        (void)source.takeDirty();
    }
    EXPECT_EQ(worker.worldHash(), server.world.worldHash());
    EXPECT_EQ(frame.stats().ops_applied + worker.stats().ops_applied, 0u) << "they applied nothing";
    // a world of another shape reaches the copies whole
    server.world = map(9, 129, 193);
    server.seq = 50;
    server.load(source);
    frame.follow(source.takeSync(frame_versions, source.takeChanges()));
    worker.follow(frame.takeSync(worker_versions, frame.takeChanges()));
    EXPECT_TRUE(worker.takeDirty().all);
    EXPECT_EQ(worker.terrain().spec().width, 129);
    EXPECT_EQ(worker.terrain().computeWorldHash(), server.world.worldHash());
}

} // namespace
} // namespace terrain::client
