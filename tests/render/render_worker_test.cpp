// The renderer fed by a tessellation worker (TessellationWorker -> DrawnMesh -> sync(mesh)),
// through a battle: view-aimed craters in bursts while the camera crosses the zone low.
// - Lockstep (the worker tessellates each frame's camera before the frame draws): every picture
//   equals, pixel for pixel, the synchronous path's picture of the same frame, drawn by a second
//   renderer from its own tessellator.
// - Running free (the frame never waits, but for every tenth frame): the mesh lags, but after
//   every sync the renderer's buffers, read back, equal the copy it was fed, and no picture
//   shows sky below the horizon.

#include "support/image_checks.h"
#include "support/render_scene.h"
#include "support/terrain_builders.h"

#include <terrain/client/tessellation_worker.h>
#include <terrain/lodlab/flights.h>
#include <terrain/render/sky_holes.h>
#include <terrain/snapshot.h>

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace terrain {
namespace {

constexpr int kWorkerWidth = 480;
constexpr int kWorkerHeight = 320;

int frames() {
#if defined(__SANITIZE_ADDRESS__)
    return 40;
#else
    return 100;
#endif
}

/// The server's world, its battle, and the replicas that follow it.
struct Battle {
    Terrain world = testing::makeHills(21, 321, 321, 1.0);
    BattleGenerator shots = lodlab::battleGenerator(world);
    std::uint64_t seq = 1;
    int craters = 0;

    void load(client::Replica& replica) const {
        replica.loadSnapshot(std::move(*decodeSnapshot(encodeSnapshot(world, seq))));
    }
    /// Frame f's craters: none most frames, one, or a burst of 6.
    void fire(int f, std::initializer_list<client::Replica*> replicas) {
        const int n = f % 7 == 3 ? 6 : (f % 3 == 0 ? 1 : 0);
        for (int k = 0; k < n; ++k) {
            const BattleShot shot = shots.next(world);
            if (!shot.crater)
                continue;
            auto op = quantizeOp(*shot.crater, world.spec());
            if (!op || !world.apply(*op).ok())
                continue;
            ++seq;
            ++craters;
            for (client::Replica* replica : replicas)
                ASSERT_TRUE(replica->applyOp(seq, *op, world.worldHash()).ok());
        }
    }
    std::vector<lodlab::FlightFrame> flight() const {
        lodlab::FlightOptions fo;
        fo.kind = lodlab::FlightKind::kBattle;
        fo.frames = frames();
        fo.width = kWorkerWidth;
        fo.height = kWorkerHeight;
        fo.seed = 3;
        return lodlab::makeFlight(world, fo);
    }
};

client::TessellationWorkerOptions workerOptions(bool lockstep) {
    client::TessellationWorkerOptions o;
    o.view.tessellation.tau_pixels = 1.0;
    o.lockstep = lockstep;
    return o;
}

TEST(RenderWorker, InLockstepEveryPictureIsTheSynchronousPathsPicture) {
    Battle battle;
    const std::vector<lodlab::FlightFrame> flight = battle.flight();
    client::Replica worker_replica;
    client::Replica sync_replica;
    battle.load(worker_replica);
    battle.load(sync_replica);
    const client::TessellationWorkerOptions o = workerOptions(true);
    client::TessellationWorker worker(worker_replica, o);
    client::TerrainView sync(sync_replica, o.view);
    roam::DrawnMesh mesh;

    testing::RenderScene scene(sync_replica.terrain(), 1.0, kWorkerWidth, kWorkerHeight);
    ASSERT_TRUE(scene.ok());
    auto from_worker = render::TerrainRenderer::create(*scene.context, scene.validating());
    ASSERT_TRUE(from_worker.ok());
    const render::RenderOptions draw_options;
    std::int64_t differing = 0;
    std::string first_difference;
    for (int f = 0; f < frames(); ++f) {
        const roam::Camera& camera = flight[static_cast<std::size_t>(f)].camera;
        battle.fire(f, {&worker_replica, &sync_replica});
        sync.absorb();
        sync.update(camera);
        scene.renderer->sync(sync.tessellator(), sync_replica.terrain());
        scene.renderer->draw(sync.tessellator(), camera, draw_options);
        const io::RgbImage want = scene.context->readPixels();

        worker.post(camera);
        ASSERT_TRUE(worker.take(mesh));
        (*from_worker)->sync(mesh);
        (*from_worker)->draw(mesh, camera, draw_options);
        const io::RgbImage got = scene.context->readPixels();
        const std::int64_t n = testing::countDiffering(want, got, 0).differing;
        if (n > 0 && first_difference.empty())
            first_difference = "frame " + std::to_string(f) + ": " + std::to_string(n) + " pixels";
        differing += n;
    }
    EXPECT_GT(battle.craters, frames() / 2);
    EXPECT_EQ(differing, 0) << first_difference;
    const render::ValidationReport& v = (*from_worker)->validation();
    EXPECT_TRUE(v.clean()) << v.first_problem;
    EXPECT_EQ(v.syncs, static_cast<std::uint64_t>(frames()));
    scene.expectClean();
}

TEST(RenderWorker, RunningFreeTheBuffersHoldTheCopyAndThePictureHasNoHoles) {
    Battle battle;
    const std::vector<lodlab::FlightFrame> flight = battle.flight();
    client::Replica replica;
    battle.load(replica);
    client::TessellationWorker worker(replica, workerOptions(false));
    roam::DrawnMesh mesh;
    testing::RenderScene scene(replica.terrain(), 1.0, kWorkerWidth, kWorkerHeight);
    ASSERT_TRUE(scene.ok());
    scene.renderer->setEvictAfterFrames(4);
    const render::RenderOptions draw_options;
    std::int64_t holes = 0;
    std::uint64_t taken = 0;
    std::uint64_t max_lag = 0;
    int drawn = 0;
    for (int f = 0; f < frames(); ++f) {
        roam::Camera camera = flight[static_cast<std::size_t>(f)].camera;
        if (f % 30 >= 24)
            camera.forward = -camera.forward; // over the shoulder: tiles evicted and reloaded
        battle.fire(f, {&replica});
        // every tenth frame waits for the worker (a loading hitch), so that deltas are taken
        // however slow the worker is here; the others never wait
        const std::uint64_t step_before = worker.taken().step;
        if (f % 10 == 9) {
            worker.finish(camera, mesh);
        } else {
            worker.post(camera);
            worker.take(mesh);
        }
        taken += worker.taken().step != step_before ? 1 : 0;
        max_lag = std::max(max_lag, worker.lag());
        if (mesh.tileCount() == 0) {
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
            continue; // nothing finished yet
        }
        scene.renderer->sync(mesh);
        // the picture of the mesh the worker made for its camera (the newest camera would show
        // the map's padding or sky past a lagging mesh's visible tiles)
        const roam::Camera& drawn_for =
            flight[static_cast<std::size_t>(
                       std::min<std::uint64_t>(worker.taken().frame, flight.size()) - 1)]
                .camera;
        roam::Camera view = drawn_for;
        const int drawn_frame = static_cast<int>(worker.taken().frame) - 1;
        if (drawn_frame % 30 >= 24)
            view.forward = -view.forward;
        scene.renderer->draw(mesh, view, draw_options);
        ++drawn;
        const render::SkyHoles h =
            render::countSkyHoles(scene.context->readPixels(), draw_options.sky);
        if (h.count > 0 && holes == 0)
            ADD_FAILURE() << "frame " << f << ": " << h.count << " sky pixels below the horizon";
        holes += h.count;
    }
    // how many the worker finished between the waits depends on the machine
    EXPECT_GE(taken, static_cast<std::uint64_t>(frames() / 10));
    EXPECT_GT(drawn, frames() / 2);
    // the last frame waits for everything: the whole battle in the buffers, checked again
    const roam::Camera& last = flight.back().camera;
    worker.finish(last, mesh);
    EXPECT_EQ(worker.lag(), 0u);
    scene.renderer->sync(mesh);
    scene.renderer->draw(mesh, last, draw_options);
    holes += render::countSkyHoles(scene.context->readPixels(), draw_options.sky).count;
    EXPECT_EQ(holes, 0);
    scene.expectClean();
    std::printf(
        "free worker: %d craters, %llu deltas taken of %llu frames, lag up to %llu frames\n",
        battle.craters, static_cast<unsigned long long>(taken),
        static_cast<unsigned long long>(worker.posted()), static_cast<unsigned long long>(max_lag));
}

} // namespace
} // namespace terrain
