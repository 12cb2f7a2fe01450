// The client's side of a battle: what each crater costs a client, end to end. An authority
// applies the battle generator's shots (untimed, up front); a Replica loaded from the
// authority's snapshot then receives each op with the hash it produced, frame by frame, and a
// Tessellator follows a camera over the fight. Per frame, timed on this thread:
//   apply   Replica::applyOp (the core's apply and the hash check), for every op of the frame
//   feed    surfaceChanges + feedChanges (Tessellator::terrainChanged)
//   update  Tessellator::update for the frame's camera
// One op arrives per frame, except every --burst-every frames, when --burst ops arrive at once;
// the client applies them paced as the bot and the viewer do (--ops-per-frame, op_pacing.h: a
// burst waits for the next frames, reported as catch-up frames and the longest wait).
// Flights: "hover" (60 m above the zone, circling it, looking in), "cross" (10 m above the
// ground, 20 m/s at 60 frames/s, across the zone and back). --join-after K: the client joins
// after the first K shots (a late joiner) and receives the rest; --frames: fly at least this many
// frames (after the ops run out). --render draws every frame through OSMesa (sync + draw timed
// as `render`), with --frame-ms steering the triangle cap as the bot does. The authority is gone
// before the client starts, so the process's resident set is the client's (with the ops it
// will receive).
// --async: the tessellation runs on a worker thread (client::TessellationWorker), as the bot and
// the viewer run it; the frame thread, paced at --fps in real time, applies the frame's ops to
// its replica, posts them with the camera and takes the worker's newest tiles (`frame_thread`:
// what the frame pays for the terrain, no GL), and the report gives the worker's steps (apply,
// update, collect per step; the ops each carried), the drawn mesh's lag in frames and its error
// bound at the camera it was made for. With --render the frame draws the worker's tiles.
// The goals (client battle budget) are reported as met / not met, never asserted.
// Exit status: 0; 1 when a replica hash differs from the authority's; 2 on a bad option.

#include "op_apply_thread.h"
#include "support/bench_facts.h"
#include "support/tessellator_memory.h"

#include <terrain/battle.h>
#include <terrain/client/crater_latency.h>
#include <terrain/client/frame_budget.h>
#include <terrain/client/op_pacing.h>
#include <terrain/client/replica.h>
#include <terrain/client/tessellation_feed.h>
#include <terrain/client/tessellation_worker.h>
#include <terrain/lodlab/screen_measure.h>
#include <terrain/procedural_map.h>
#include <terrain/render/offscreen.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/tessellator.h>
#include <terrain/snapshot.h>
#include <terrain/surface_query.h>
#include <terrain/terrain.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <deque>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace terrain;
using Json = nlohmann::ordered_json;

struct SentOp {
    DeformOp op;
    std::uint64_t world_hash = 0;
};

Json summaryJson(const bench::Summary& s) {
    return Json{{"n", s.n}, {"p50", s.p50}, {"p99", s.p99}, {"max", s.max}, {"mean", s.mean}};
}

// The tessellator's memory by part, MiB (frame_stats.h says what each holds).
Json tessellatorParts(const roam::TessellatorMemory& m) {
    return Json{
        {"grid", bench::mib(m.grid)},
        {"records", bench::mib(m.records)},
        {"grains",
         Json::array({bench::mib(m.grains[0]), bench::mib(m.grains[1]), bench::mib(m.grains[2])})},
        {"heap", bench::mib(m.heap)},
        {"meshes", bench::mib(m.meshes)},
        {"scratch", bench::mib(m.scratch)}};
}

// The camera of frame `f`: see the header comment.
roam::Camera flightCamera(
    const std::string& flight,
    int f,
    const Terrain& t,
    const BattleOptions& o,
    int width,
    int height) {
    constexpr double kPi = 3.14159265358979323846;
    roam::Camera c;
    c.viewport_width = width;
    c.viewport_height = height;
    c.near_plane = 0.5;
    const glm::dvec3 zone(o.zone_x, o.zone_y, surfaceHeight(t, o.zone_x, o.zone_y));
    if (flight == "hover") {
        const double a = 0.2 * kPi / 180.0 * f; // a turn in 30 s
        const double range = 80.0;
        c.eye = glm::dvec3(zone.x + range * std::cos(a), zone.y + range * std::sin(a), 0.0);
        c.eye.z = zone.z + 60.0;
        c.forward = zone - c.eye;
        return c;
    }
    // cross: 20 m/s at 60 frames/s, from 150 m before the zone to 150 m past it, and back
    const double leg = 300.0;
    const double s = std::fmod(f * 20.0 / 60.0, 2.0 * leg);
    const double along = s < leg ? s - leg / 2 : leg / 2 - (s - leg);
    const double dir = s < leg ? 1.0 : -1.0;
    c.eye = glm::dvec3(zone.x + along, zone.y + 5.0, 0.0);
    c.eye.z = surfaceHeight(t, c.eye.x, c.eye.y) + 10.0;
    c.forward = glm::dvec3(dir, 0.0, -0.25);
    return c;
}

/// The command line.
struct Settings {
    int shots = 2000;
    int burst = 20;
    int burst_every = 100;
    double tau = 1.0;
    std::int64_t max_triangles = 400'000;
    double merge_band = roam::TessellatorOptions{}.merge_band;
    double step_ms = client::TessellationWorkerOptions{}.step_ms;
    std::int32_t max_blocks = roam::TessellatorOptions{}.max_detail_blocks;
    std::int64_t work_budget = roam::TessellatorOptions{}.work_budget;
    std::int64_t stale_budget = roam::TessellatorOptions{}.stale_block_budget;
    std::int64_t upload_budget = roam::TessellatorOptions{}.upload_budget_bytes;
    client::OpPacing pacing{.ops_per_frame = client::kDefaultOpsPerFrame};
    int width = 1280;
    int height = 720;
    std::string flight = "hover";
    int join_after = 0;
    int min_frames = 0;
    bool render = false;
    bool async = false;
    bool lockstep = false;
    bool apply_thread = false;
    unsigned threads = 0;
    double fps = 60.0;
    double frame_target_ms = 0.0;
    int measure_every = 0;
    ProceduralMapOptions map;
    BattleOptions battle;
    std::string out;
};

/// The command line into `s`; an exit code when the program should stop (help, a bad option).
std::optional<int> parseSettings(int argc, char** argv, Settings& s) {
    CLI::App app{"client_battle_bench: a battle's ops on a client replica and tessellator"};
    app.add_option("--shots", s.shots, "battle shots (the ops the client receives)")
        ->check(CLI::PositiveNumber);
    app.add_option("--burst", s.burst, "ops arriving in one frame every --burst-every frames")
        ->check(CLI::PositiveNumber);
    app.add_option("--burst-every", s.burst_every, "frames between bursts")
        ->check(CLI::PositiveNumber);
    app.add_option("--tau", s.tau, "screen-error threshold, pixels")->check(CLI::PositiveNumber);
    app.add_option("--max-triangles", s.max_triangles, "the tessellator's triangle cap")
        ->check(CLI::PositiveNumber);
    app.add_option(
           "--merge-band", s.merge_band,
           "a split diamond merges below this share of the threshold (hysteresis; 1: none)")
        ->check(CLI::Range(0.05, 1.0));
    app.add_option(
           "--step-ms", s.step_ms,
           "--async: the time a worker step aims at (0: one whole step per frame, the old way)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--max-blocks", s.max_blocks, "detail blocks resident at once (the pool)")
        ->check(CLI::PositiveNumber);
    app.add_option(
           "--ops-per-frame", s.pacing.ops_per_frame,
           "ops applied per frame at least, as the bot and the viewer do (0: as they arrive)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--work-budget", s.work_budget, "splits + merges per frame")
        ->check(CLI::PositiveNumber);
    app.add_option(
           "--stale-budget", s.stale_budget, "stale detail blocks re-bounded per frame (0: all)")
        ->check(CLI::NonNegativeNumber);
    app.add_option(
           "--upload-budget", s.upload_budget,
           "bytes of mesh changes a frame may make a renderer upload (0: no limit); it binds only "
           "where something takes the changes: --render, --async")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--width", s.width, "viewport width")->check(CLI::Range(64, 8192));
    app.add_option("--height", s.height, "viewport height")->check(CLI::Range(64, 8192));
    app.add_option("--flight", s.flight, "hover | cross")->check(CLI::IsMember({"hover", "cross"}));
    app.add_option("--map-size", s.map.width, "procedural map size in vertices")
        ->check(CLI::Range(65, 8193));
    app.add_option("--seed", s.battle.seed, "battle seed");
    app.add_option("--join-after", s.join_after, "shots before the client joins (a late joiner)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--frames", s.min_frames, "frames to fly at least (after the ops run out)")
        ->check(CLI::NonNegativeNumber);
    app.add_flag("--render", s.render, "draw every frame offscreen (OSMesa)");
    app.add_flag("--async", s.async, "tessellate on a worker thread; the frame loop runs at --fps");
    app.add_flag(
        "--lockstep", s.lockstep,
        "--async: each frame waits for its step (the synchronous path's steps on the worker: "
        "its cost per crater, comparable; --fps ignored)");
    app.add_flag(
           "--apply-thread", s.apply_thread,
           "--async: the ops are applied on a thread of their own, as the library's network thread "
           "does, and the frame's replica follows it by changed tiles (no pacing)")
        ->needs("--async");
    app.add_option(
        "--threads", s.threads,
        "--async: threads a worker step may use, its own included (0: min(cores - 1, 4))");
    app.add_option("--fps", s.fps, "--async: frames a second the frame loop keeps (real time)")
        ->check(CLI::Range(1.0, 1000.0));
    app.add_option(
           "--frame-ms", s.frame_target_ms,
           "frame time the triangle cap is steered to hold, as the bot does (0: off)")
        ->check(CLI::NonNegativeNumber);
    app.add_option(
           "--measure-every", s.measure_every,
           "--async: every this many frames, keep the drawn mesh (in view) and measure its screen "
           "error against the true surface of that frame after the run (0: never)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--out", s.out, "JSON report");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    s.map.height = s.map.width;
    return std::nullopt;
}

/// The authority's side, untimed: the ops the client receives with the hash each produced,
/// the snapshot it joins by (after --join-after shots), and the world's last hash.
struct Battle {
    std::vector<SentOp> sent;
    std::vector<std::uint8_t> snapshot;
    std::uint64_t final_hash = 0;
    BattleOptions options; ///< with the zone at the map's centre
};

Battle fightBattle(const Settings& s) {
    Battle b;
    b.options = s.battle;
    // the authority is gone when this returns: the process then holds the client's side only
    Terrain authority = std::move(*makeProceduralMap(s.map));
    const WorldSpec& spec = authority.spec();
    b.options.zone_x = spec.extentX() / 2;
    b.options.zone_y = spec.extentY() / 2;
    if (s.join_after == 0)
        b.snapshot = encodeSnapshot(authority, 0);
    BattleGenerator generator(b.options);
    for (int i = 0; i < s.shots; ++i) {
        const BattleShot shot = generator.next(authority);
        if (shot.crater) {
            auto op = quantizeOp(*shot.crater, spec);
            if (op && authority.apply(*op))
                b.sent.push_back({*op, authority.worldHash()});
        }
        if (i + 1 == s.join_after) {
            b.snapshot = encodeSnapshot(authority, 0);
            b.sent.clear(); // in the snapshot
        }
    }
    b.final_hash = authority.worldHash();
    return b;
}

/// The renderer, as a rendering bot has it (--render): sync and draw every frame.
struct Renderer {
    std::unique_ptr<render::GlContext> gl;
    std::unique_ptr<render::TerrainRenderer> terrain;
};

Result<Renderer> makeRenderer(const Settings& s) {
    Renderer r;
    if (!s.render)
        return r;
    auto context =
        render::createOffscreenContext(render::OffscreenBackend::kOsmesa, s.width, s.height);
    if (!context)
        return context.error();
    r.gl = std::move(*context);
    auto made = render::TerrainRenderer::create(*r.gl);
    if (!made)
        return made.error();
    r.terrain = std::move(*made);
    return r;
}

/// What the flight measured, frame by frame.
struct Tally {
    std::vector<double> single_total, single_apply, single_feed, single_update;
    std::vector<double> burst_total;
    std::vector<double> catch_up_total; // frames after a burst applying more than one op
    std::vector<double> quiet_total;    // frames applying no op (after the battle, --frames)
    std::vector<double> frame_total;
    std::vector<double> render_ms;
    std::vector<double> triangles;
    std::vector<double> error_bound; // pixels: tau, or what the cap forced
    std::vector<double> in_use;      // blocks that cannot go, sampled
    int max_delay_frames = 0;
    int threshold_moves = 0;
    int rebuilds = 0;
    int capped_frames = 0;
    std::int64_t pool_refusals = 0;
    std::int64_t materialised = 0;
    std::int64_t evicted = 0;
    bool hashes_agree = true;
};

/// The ops as a client receives them: one a frame, a burst every --burst-every frames, applied
/// to the replica paced as the bot and the viewer pace them (client/op_pacing.h).
struct OpFeed {
    struct Frame {
        int arriving = 0;         ///< ops that arrived this frame
        std::size_t applying = 0; ///< ops applied this frame
        double apply_ms = 0.0;
    };

    OpFeed(const Settings& s, const std::vector<SentOp>& ops)
        : settings(&s), sent(&ops), pacer(s.pacing) {}
    /// More to fly: ops not yet applied, or frames short of --frames.
    bool flying(int f) const { return next < sent->size() || f <= settings->min_frames; }
    /// Frame f's arrivals, and the ops it applies to `replica`, timed. With `applier` (the
    /// network thread's stand-in) the arrivals go to it at once, and `replica` follows what it
    /// applied (timed as the apply).
    Frame frame(int f, client::Replica& replica, bench::OpApplyThread* applier = nullptr) {
        Frame out;
        const std::size_t received = next + arrived_at.size();
        out.arriving =
            received >= sent->size() ? 0
            : f % settings->burst_every == 0
                ? static_cast<int>(std::min<std::size_t>(
                      static_cast<std::size_t>(settings->burst), sent->size() - received))
                : 1;
        for (int k = 0; k < out.arriving; ++k)
            arrived_at.push_back(f);
        if (applier != nullptr) {
            std::vector<bench::OpApplyThread::Arrival> ops;
            for (std::size_t k = handed; k < received + static_cast<std::size_t>(out.arriving); ++k)
                ops.push_back({k + 1, (*sent)[k].op, (*sent)[k].world_hash});
            handed = received + static_cast<std::size_t>(out.arriving);
            applier->arrive(std::move(ops));
            const auto t0 = bench::Clock::now();
            const std::uint64_t before = replica.seq();
            for (const client::ReplicaSync& sync : applier->take())
                replica.follow(sync);
            out.apply_ms = bench::msSince(t0);
            out.applying = static_cast<std::size_t>(replica.seq() - before);
            next += out.applying;
            seq = replica.seq();
            for (std::size_t k = 0; k < out.applying; ++k) {
                max_delay_frames = std::max(max_delay_frames, f - arrived_at.front());
                arrived_at.pop_front();
            }
            hashes_agree = hashes_agree && applier->hashesAgree();
            return out;
        }
        // the client's pacing: a burst waits for the next frames
        out.applying = pacer.take(arrived_at.size());
        const auto t0 = bench::Clock::now();
        for (std::size_t k = 0; k < out.applying; ++k, ++next) {
            auto outcome = replica.applyOp(++seq, (*sent)[next].op, (*sent)[next].world_hash);
            if (!outcome || *outcome != client::Replica::OpOutcome::kApplied)
                hashes_agree = false;
        }
        out.apply_ms = bench::msSince(t0);
        for (std::size_t k = 0; k < out.applying; ++k) {
            max_delay_frames = std::max(max_delay_frames, f - arrived_at.front());
            arrived_at.pop_front();
        }
        return out;
    }

    const Settings* settings;
    const std::vector<SentOp>* sent;
    client::OpPacer pacer;
    std::deque<int> arrived_at; ///< the frame each waiting op arrived in
    std::size_t next = 0;
    std::size_t handed = 0; ///< ops handed to the applier
    std::uint64_t seq = 0;
    int max_delay_frames = 0;
    bool hashes_agree = true;
};

/// The flight: ops arrive (one a frame, a burst every --burst-every frames), are applied paced,
/// fed to the tessellator, and the frame is tessellated (and drawn) for the flight's camera.
Tally fly(
    const Settings& s,
    const Battle& battle,
    client::Replica& replica,
    roam::Tessellator& tess,
    Renderer& renderer) {
    Tally t;
    client::FrameBudgetOptions budget_options;
    budget_options.target_ms = s.frame_target_ms;
    budget_options.max_triangles = s.max_triangles;
    client::FrameBudget budget(budget_options);
    OpFeed feed(s, battle.sent);
    for (int f = 1; feed.flying(f); ++f) {
        const auto [arriving, applying, apply_ms] = feed.frame(f, replica);
        const auto t1 = bench::Clock::now();
        const client::SurfaceChanges changes =
            client::surfaceChanges(replica.takeDirty(), replica.terrain().spec());
        client::feedChanges(changes, tess);
        const double feed_ms = bench::msSince(t1);
        const auto t2 = bench::Clock::now();
        const double threshold = tess.threshold();
        const roam::Camera camera =
            flightCamera(s.flight, f, replica.terrain(), battle.options, s.width, s.height);
        const roam::FrameStats fs = tess.update(camera);
        t.threshold_moves += tess.threshold() != threshold ? 1 : 0;
        const double update_ms = bench::msSince(t2);
        double draw_ms = 0.0;
        if (renderer.terrain) {
            const auto t3 = bench::Clock::now();
            renderer.terrain->sync(tess, replica.terrain());
            renderer.terrain->draw(tess, camera, render::RenderOptions{});
            renderer.gl->present();
            draw_ms = bench::msSince(t3);
            t.render_ms.push_back(draw_ms);
        }
        tess.setMaxTriangles(
            budget.observe(update_ms + feed_ms + apply_ms + draw_ms, fs.triangles));
        const double total = apply_ms + feed_ms + update_ms;
        t.frame_total.push_back(total);
        t.triangles.push_back(static_cast<double>(fs.triangles));
        t.error_bound.push_back(fs.error_bound_pixels);
        t.rebuilds += fs.rebuilt ? 1 : 0;
        t.capped_frames += fs.refused_by_cap > 0 ? 1 : 0;
        t.pool_refusals += fs.refused_by_pool;
        t.materialised += fs.blocks_materialised;
        t.evicted += fs.blocks_evicted;
        if (f % 25 == 0)
            t.in_use.push_back(static_cast<double>(tess.pinnedBlockCount()));
        if (arriving > 1) {
            t.burst_total.push_back(total); // the frame the s.burst arrives in
        } else if (applying > 1) {
            t.catch_up_total.push_back(total);
        } else if (applying == 1) {
            t.single_total.push_back(total);
            t.single_apply.push_back(apply_ms);
            t.single_feed.push_back(feed_ms);
            t.single_update.push_back(update_ms);
        } else {
            t.quiet_total.push_back(total); // no op applied: the s.flight alone
        }
    }
    t.max_delay_frames = feed.max_delay_frames;
    t.hashes_agree = feed.hashes_agree && replica.worldHash() == battle.final_hash;
    return t;
}

/// The drawn mesh of one frame (its triangles in view, metres) and what it was drawn for.
struct DrawnSample {
    int frame = 0;
    std::uint64_t seq = 0; ///< the frame's replica: the true surface at that frame
    roam::Camera camera;
    std::vector<glm::vec3> triangles;
};

void sampleDrawn(const roam::DrawnMesh& mesh, DrawnSample& out) {
    const double per_lattice = roam::DrawnMesh::metresPerLattice(mesh.spec());
    for (std::int32_t tile = 0; tile < mesh.tileCount(); ++tile) {
        if (!mesh.tileVisible(tile))
            continue;
        const std::span<const std::uint32_t> idx = mesh.indices(tile);
        const std::span<const roam::DrawVertex> v = mesh.vertices(tile);
        for (std::size_t i = 0; i + 2 < idx.size(); i += 3) {
            if (idx[i] == idx[i + 1] && idx[i] == idx[i + 2])
                continue; // a filled hole
            for (std::size_t k = 0; k < 3; ++k) {
                const roam::DrawVertex& d = v[idx[i + k]];
                out.triangles.emplace_back(
                    static_cast<float>(d.x * per_lattice), static_cast<float>(d.y * per_lattice),
                    d.z);
            }
        }
    }
}

/// The screen error of each sample against the true surface of its frame: the world replayed
/// from `snapshot` through the sent ops up to the sample's seq.
struct MeasuredError {
    std::vector<double> p99, max, over_tau_share;
    std::vector<int> frames;
};

MeasuredError measureSamples(
    const std::vector<DrawnSample>& samples,
    const std::vector<std::uint8_t>& snapshot,
    const std::vector<SentOp>& sent,
    double tau) {
    MeasuredError m;
    client::Replica world;
    world.loadSnapshot(std::move(*decodeSnapshot(snapshot)));
    std::uint64_t seq = 0;
    lodlab::ScreenErrorOptions options;
    options.tau_pixels = tau;
    std::vector<glm::dvec3> triangles;
    for (const DrawnSample& sample : samples) {
        for (; seq < sample.seq; ++seq)
            (void)world.applyOp(seq + 1, sent[seq].op, sent[seq].world_hash);
        triangles.assign(sample.triangles.begin(), sample.triangles.end());
        const lodlab::MeshError e =
            lodlab::measureMeshError(triangles, world.terrain(), sample.camera, options);
        m.frames.push_back(sample.frame);
        m.p99.push_back(e.p99_pixels);
        m.max.push_back(e.max_pixels);
        m.over_tau_share.push_back(
            e.triangles > 0 ? static_cast<double>(e.triangles_over_tau) / e.triangles : 0.0);
    }
    return m;
}

/// What the asynchronous flight measured (--async).
struct AsyncTally {
    std::vector<double> frame_thread;       ///< apply + post + take, every frame (ms)
    std::vector<double> burst_frame_thread; ///< of which the frames a burst arrived in
    std::vector<double> apply, post, take;  ///< the parts, every frame (ms)
    std::vector<double> lag;                ///< frames the drawn mesh is behind the camera
    std::vector<double> error_bound;        ///< of the drawn mesh, for the camera it was made for
    std::vector<double> triangles;          ///< of the drawn mesh
    std::vector<double> render_ms;
    std::vector<double> late_ms;   ///< how far past its deadline each frame started
    std::vector<double> sample_ms; ///< copying the drawn mesh for --measure-every (not timed above)
    /// Per op (crater), frames from the one that applied it on the frame thread to the first
    /// that drew it (a taken delta at or past its seq) and to the first whose drawn mesh had
    /// it converged (WorkerStep::settled_seq); the largest error bound drawn meanwhile.
    std::vector<double> to_drawn, to_converged, bound_until_converged;
    std::vector<DrawnSample> samples;
    std::vector<client::WorkerStep> steps;
    double rss_mib = 0.0;        ///< after the flight (before the measures' samples are measured)
    double drawn_mesh_mib = 0.0; ///< the frame's copy of the tiles
    MemoryUsage world;           ///< the frame's replica's terrain (each copy's share)
    int max_delay_frames = 0;
    bool hashes_agree = true;
};

/// The flight with the tessellation on a worker: the frame loop keeps --fps in real time.
AsyncTally flyAsync(
    const Settings& s,
    const Battle& battle,
    client::Replica& replica,
    client::TessellationWorker& worker,
    Renderer& renderer,
    bench::OpApplyThread* applier) {
    AsyncTally t;
    roam::DrawnMesh mesh;
    OpFeed feed(s, battle.sent);
    const auto period = std::chrono::duration_cast<bench::Clock::duration>(
        std::chrono::duration<double>(1.0 / s.fps));
    auto deadline = bench::Clock::now();
    double last_frame_ms = 0.0;
    client::CraterLatency latency;
    latency.start(replica.seq()); // (the snapshot's ops are not the flight's)
    for (int f = 1; feed.flying(f); ++f) {
        deadline += period;
        const auto started = bench::Clock::now();
        t.late_ms.push_back(std::max(
            0.0, std::chrono::duration<double, std::milli>(started - (deadline - period)).count()));
        const auto [arriving, applying, apply_ms] = feed.frame(f, replica, applier);
        latency.applied(f, feed.seq);
        const roam::Camera camera =
            flightCamera(s.flight, f, replica.terrain(), battle.options, s.width, s.height);
        const auto t1 = bench::Clock::now();
        worker.post(camera, s.frame_target_ms > 0.0 ? last_frame_ms : 0.0);
        const double post_ms = bench::msSince(t1);
        const auto t2 = bench::Clock::now();
        worker.take(mesh);
        const double take_ms = bench::msSince(t2);
        const double total = apply_ms + post_ms + take_ms;
        t.frame_thread.push_back(total);
        if (arriving > 1)
            t.burst_frame_thread.push_back(total);
        t.apply.push_back(apply_ms);
        t.post.push_back(post_ms);
        t.take.push_back(take_ms);
        t.lag.push_back(static_cast<double>(worker.lag()));
        t.error_bound.push_back(worker.taken().stats.error_bound_pixels);
        t.triangles.push_back(static_cast<double>(worker.taken().stats.triangles));
        latency.drawn(
            f, worker.taken().seq, worker.taken().settled_seq,
            worker.taken().stats.error_bound_pixels);
        if (s.measure_every > 0 && f % s.measure_every == 0 && mesh.tileCount() > 0) {
            const auto t4 = bench::Clock::now();
            DrawnSample& sample = t.samples.emplace_back();
            sample.frame = f;
            sample.seq = feed.seq;
            sample.camera = camera;
            sampleDrawn(mesh, sample);
            t.sample_ms.push_back(bench::msSince(t4));
        }
        double draw_ms = 0.0;
        if (renderer.terrain && mesh.tileCount() > 0) {
            const auto t3 = bench::Clock::now();
            renderer.terrain->sync(mesh);
            renderer.terrain->draw(mesh, camera, render::RenderOptions{});
            renderer.gl->present();
            draw_ms = bench::msSince(t3);
            t.render_ms.push_back(draw_ms);
        }
        last_frame_ms = total + draw_ms;
        if (s.lockstep)
            deadline = bench::Clock::now(); // no pacing: every frame waited for its step
        else
            std::this_thread::sleep_until(deadline);
    }
    // the worker's view of the same world: its last step has every op
    t.max_delay_frames = feed.max_delay_frames;
    t.hashes_agree = feed.hashes_agree;
    for (int k = 0; k < 1000 && worker.taken().seq < feed.seq; ++k) {
        worker.post(flightCamera(
            s.flight, static_cast<int>(t.frame_thread.size()), replica.terrain(), battle.options,
            s.width, s.height));
        std::this_thread::sleep_for(period);
        worker.take(mesh);
    }
    if (replica.worldHash() != battle.final_hash || worker.taken().world_hash != battle.final_hash)
        t.hashes_agree = false;
    t.to_drawn = latency.framesToDrawn();
    t.to_converged = latency.framesToConverged();
    t.bound_until_converged = latency.boundUntilConverged();
    t.steps = worker.stepLog();
    t.drawn_mesh_mib = bench::mib(mesh.memoryBytes());
    t.world = replica.terrain().memoryUsage();
    t.rss_mib = bench::mib(bench::residentBytes());
    return t;
}

/// The asynchronous run's JSON report and summary.
Json asyncReportOf(
    const Settings& s,
    const Battle& battle,
    const AsyncTally& t,
    const MeasuredError& measured,
    unsigned worker_threads) {
    const roam::TessellatorMemory tess_memory =
        t.steps.empty() ? roam::TessellatorMemory{} : t.steps.back().tessellator_memory;
    std::vector<double> step_ms, step_update, step_apply, step_collect, crater_steps, delta_kib;
    std::vector<double> per_op_ms;
    // the cost model, over the steps that applied ops (craters), no rebuild: each part's time
    // per unit of its work (with --lockstep, the synchronous path's steps: mostly one op each)
    std::vector<double> c_apply, c_absorb, c_bounds, c_policy, c_finish, c_pool, c_collect;
    std::vector<double> per_block_us, per_split_merge_us, per_evaluation_us, per_collect_kib_us;
    std::vector<double> c_splits, c_merges, c_evaluations, c_blocks, c_kib;
    for (const client::WorkerStep& w : t.steps) {
        if (w.ops >= 1 && !w.stats.rebuilt) {
            const auto phase = [&](roam::UpdatePhase p) {
                return w.phase_ms[static_cast<std::size_t>(p)];
            };
            c_apply.push_back(w.apply_ms);
            c_absorb.push_back(w.absorb_ms);
            c_bounds.push_back(phase(roam::UpdatePhase::kStaleBounds));
            c_policy.push_back(phase(roam::UpdatePhase::kSplitMerge));
            c_finish.push_back(phase(roam::UpdatePhase::kFinishFrame));
            c_pool.push_back(phase(roam::UpdatePhase::kPoolUpkeep));
            c_collect.push_back(w.collect_ms);
            const double sm = static_cast<double>(w.stats.splits + w.stats.merges);
            c_splits.push_back(static_cast<double>(w.stats.splits));
            c_merges.push_back(static_cast<double>(w.stats.merges));
            c_evaluations.push_back(static_cast<double>(w.stats.evaluations));
            c_blocks.push_back(static_cast<double>(w.stats.stale_blocks_bounded));
            c_kib.push_back(static_cast<double>(w.delta_bytes) / 1024.0);
            if (w.stats.stale_blocks_bounded > 0)
                per_block_us.push_back(
                    1000.0 * phase(roam::UpdatePhase::kStaleBounds) /
                    static_cast<double>(w.stats.stale_blocks_bounded));
            if (sm > 0)
                per_split_merge_us.push_back(1000.0 * phase(roam::UpdatePhase::kSplitMerge) / sm);
            if (w.stats.evaluations > 0)
                per_evaluation_us.push_back(
                    1000.0 * phase(roam::UpdatePhase::kSplitMerge) /
                    static_cast<double>(w.stats.evaluations));
            if (w.delta_bytes > 0)
                per_collect_kib_us.push_back(
                    1000.0 * w.collect_ms / (static_cast<double>(w.delta_bytes) / 1024.0));
        }
        const double total = w.apply_ms + w.update_ms + w.collect_ms;
        step_ms.push_back(total);
        step_update.push_back(w.update_ms);
        step_apply.push_back(w.apply_ms);
        step_collect.push_back(w.collect_ms);
        delta_kib.push_back(static_cast<double>(w.delta_bytes) / 1024.0);
        if (w.ops == 1)
            crater_steps.push_back(total);
        if (w.ops > 0)
            per_op_ms.push_back(total / static_cast<double>(w.ops));
    }
    // where the moves land, over every step (MoveCensus)
    double moves = 0.0, in_footprint = 0.0, undone = 0.0, ops = 0.0, evaluations = 0.0;
    double rebounds = 0.0, busy_ms = 0.0;
    // per crater all told: apply, absorb, update's phases (UpdatePhase order), collect
    std::array<double, 3 + roam::kUpdatePhases> part_ms{};
    for (const client::WorkerStep& w : t.steps) {
        moves += static_cast<double>(w.stats.splits + w.stats.merges);
        evaluations += static_cast<double>(w.stats.evaluations);
        rebounds += static_cast<double>(w.stats.stale_blocks_bounded);
        busy_ms += w.apply_ms + w.absorb_ms + w.update_ms + w.collect_ms;
        part_ms[0] += w.apply_ms;
        part_ms[1] += w.absorb_ms;
        for (std::size_t k = 0; k < roam::kUpdatePhases; ++k)
            part_ms[2 + k] += w.phase_ms[k];
        part_ms[2 + roam::kUpdatePhases] += w.collect_ms;
        in_footprint += static_cast<double>(w.stats.moves_in_footprint);
        undone += static_cast<double>(w.stats.moves_undone);
        ops += static_cast<double>(w.ops);
    }
    const double per_op = ops > 0 ? 1.0 / ops : 0.0;
    const double share = moves > 0 ? 100.0 / moves : 0.0;
    const bench::Summary drawn = bench::summarize(t.to_drawn);
    const bench::Summary converged = bench::summarize(t.to_converged);
    const bench::Summary bound_meanwhile = bench::summarize(t.bound_until_converged);
    const bench::Summary measured_p99 = bench::summarize(measured.p99);
    const bench::Summary measured_max = bench::summarize(measured.max);
    const bench::Summary frame = bench::summarize(t.frame_thread);
    const bench::Summary crater = bench::summarize(crater_steps);
    const bench::Summary lag = bench::summarize(t.lag);
    const bench::Summary error = bench::summarize(t.error_bound);
    Json report{
        {"benchmark", "client_battle_bench"},
        {"mode", s.lockstep ? "async-lockstep" : "async"},
        {"apply_thread", s.apply_thread},
        {"date", bench::isoNow()},
        {"cpu", bench::cpuModel()},
        {"cores", std::thread::hardware_concurrency()},
        {"worker_threads", worker_threads},
        {"map", "procedural " + std::to_string(s.map.width) + " x " + std::to_string(s.map.width)},
        {"flight", s.flight},
        {"viewport", std::to_string(s.width) + " x " + std::to_string(s.height)},
        {"tau_pixels", s.tau},
        {"max_triangles", s.max_triangles},
        {"shots", s.shots},
        {"ops", battle.sent.size()},
        {"fps", s.fps},
        {"upload_budget_bytes", s.upload_budget},
        {"frames", t.frame_thread.size()},
        {"render", s.render},
        {"hashes_agree", t.hashes_agree},
        {"frame_thread_ms",
         Json{
             {"total", summaryJson(frame)},
             {"burst_frames", summaryJson(bench::summarize(t.burst_frame_thread))},
             {"apply", summaryJson(bench::summarize(t.apply))},
             {"post", summaryJson(bench::summarize(t.post))},
             {"take", summaryJson(bench::summarize(t.take))}}},
        {"frame_late_ms", summaryJson(bench::summarize(t.late_ms))},
        {"render_ms", summaryJson(bench::summarize(t.render_ms))},
        {"lag_frames", summaryJson(lag)},
        {"error_bound_pixels", summaryJson(error)},
        {"triangles", summaryJson(bench::summarize(t.triangles))},
        {"worker",
         Json{
             {"steps", t.steps.size()},
             {"step_ms", summaryJson(bench::summarize(step_ms))},
             {"apply_ms", summaryJson(bench::summarize(step_apply))},
             {"update_ms", summaryJson(bench::summarize(step_update))},
             {"collect_ms", summaryJson(bench::summarize(step_collect))},
             {"one_crater_step_ms", summaryJson(crater)},
             {"per_op_ms", summaryJson(bench::summarize(per_op_ms))},
             {"delta_kib", summaryJson(bench::summarize(delta_kib))}}},
        {"crater_step_cost_model",
         Json{
             {"steps", c_apply.size()},
             {"ms",
              Json{
                  {"apply", summaryJson(bench::summarize(c_apply))},
                  {"absorb", summaryJson(bench::summarize(c_absorb))},
                  {"stale_bounds", summaryJson(bench::summarize(c_bounds))},
                  {"split_merge", summaryJson(bench::summarize(c_policy))},
                  {"finish_frame", summaryJson(bench::summarize(c_finish))},
                  {"pool_upkeep", summaryJson(bench::summarize(c_pool))},
                  {"collect", summaryJson(bench::summarize(c_collect))}}},
             {"work",
              Json{
                  {"splits", summaryJson(bench::summarize(c_splits))},
                  {"merges", summaryJson(bench::summarize(c_merges))},
                  {"evaluations", summaryJson(bench::summarize(c_evaluations))},
                  {"blocks_rebounded", summaryJson(bench::summarize(c_blocks))},
                  {"delta_kib", summaryJson(bench::summarize(c_kib))}}},
             {"us_per",
              Json{
                  {"block_rebound", summaryJson(bench::summarize(per_block_us))},
                  {"split_or_merge", summaryJson(bench::summarize(per_split_merge_us))},
                  {"evaluation", summaryJson(bench::summarize(per_evaluation_us))},
                  {"delta_kib", summaryJson(bench::summarize(per_collect_kib_us))}}}}},
        {"ops_waited_frames_max", t.max_delay_frames},
        {"memory_mib",
         Json{
             {"rss_after_flight", t.rss_mib},
             {"drawn_mesh", t.drawn_mesh_mib},
             {"world",
              Json{
                  {"samples", bench::mib(t.world.sample_bytes)},
                  {"original", bench::mib(t.world.original_bytes)},
                  {"patches", bench::mib(t.world.patch_bytes)},
                  {"tiles", bench::mib(t.world.tile_bytes)}}},
             {"tessellator", bench::mib(tess_memory.total())},
             {"tessellator_parts", tessellatorParts(tess_memory)},
             {"hand_over", t.steps.empty() ? 0.0 : bench::mib(t.steps.back().collector_bytes)},
             {"drawn_vertices", t.steps.empty() ? 0 : t.steps.back().drawn_vertices},
             {"tessellator_vertices", t.steps.empty() ? 0 : t.steps.back().tessellator_vertices}}},
        {"craters",
         Json{
             {"frames_to_drawn", summaryJson(drawn)},
             {"frames_to_converged", summaryJson(converged)},
             {"not_converged_at_end",
              static_cast<double>(battle.sent.size()) - static_cast<double>(converged.n)},
             {"error_bound_until_converged_px", summaryJson(bound_meanwhile)},
             {"moves_per_crater", moves * per_op},
             {"evaluations_per_crater", evaluations * per_op},
             {"blocks_rebounded_per_crater", rebounds * per_op},
             {"worker_ms_per_crater", busy_ms * per_op},
             {"worker_ms_per_crater_by_part",
              Json{
                  {"apply", part_ms[0] * per_op},
                  {"absorb", part_ms[1] * per_op},
                  {"stale_bounds", part_ms[2] * per_op},
                  {"rebuild", part_ms[3] * per_op},
                  {"split_merge", part_ms[4] * per_op},
                  {"finish_frame", part_ms[5] * per_op},
                  {"pool_upkeep", part_ms[6] * per_op},
                  {"collect", part_ms[7] * per_op}}},
             {"moves_in_footprint_per_crater", in_footprint * per_op},
             {"moves_elsewhere_per_crater", (moves - in_footprint) * per_op},
             {"moves_undone_per_crater", undone * per_op},
             {"moves_in_footprint_percent", in_footprint * share},
             {"moves_undone_percent", undone * share}}},
        {"measured_error_px",
         Json{
             {"every_frames", s.measure_every},
             {"samples", measured.p99.size()},
             {"sample_copy_ms", summaryJson(bench::summarize(t.sample_ms))},
             {"frame_p99", summaryJson(measured_p99)},
             {"frame_max", summaryJson(measured_max)},
             {"triangles_over_tau_share", summaryJson(bench::summarize(measured.over_tau_share))},
             {"per_sample",
              Json{{"frame", measured.frames}, {"p99", measured.p99}, {"max", measured.max}}}}},
        {"goals", Json{
                      {"crater_drawn_next_frame_p99", drawn.p99 <= 1.0},
                      {"crater_converged_p99_le_10_frames", converged.p99 <= 10.0},
                      {"measured_error_p99_le_3px", measured_p99.p99 <= 3.0},
                      {"frame_thread_p99_le_2ms", frame.p99 <= 2.0},
                      {"error_bound_p50_le_1_2px", error.p50 <= 1.2},
                      {"error_bound_p99_le_3px", error.p99 <= 3.0},
                      {"lag_p99_le_3_frames", lag.p99 <= 3.0},
                      {"worker_crater_p50_le_3ms", crater.p50 <= 3.0},
                      {"worker_crater_p99_le_8ms", crater.p99 <= 8.0}}}};
    std::printf(
        "client_battle_bench --async%s%s (worker on %u threads): %zu ops, %zu frames at %.0f fps, "
        "%s flight, tau %.2g px, %d x %d%s\n",
        s.lockstep ? " --lockstep" : "", s.apply_thread ? " --apply-thread" : "", worker_threads,
        battle.sent.size(), t.frame_thread.size(), s.lockstep ? 0.0 : s.fps, s.flight.c_str(),
        s.tau, s.width, s.height, s.render ? ", rendered (OSMesa)" : "");
    std::printf(
        "  frame thread ms: p50 %.3f p99 %.3f max %.3f (burst frames p99 %.3f; apply p99 %.3f, "
        "post p99 %.3f, take p99 %.3f)\n",
        frame.p50, frame.p99, frame.max, bench::summarize(t.burst_frame_thread).p99,
        bench::summarize(t.apply).p99, bench::summarize(t.post).p99, bench::summarize(t.take).p99);
    std::printf(
        "  worker: %zu steps, step p50 %.2f p99 %.2f ms; one-crater steps p50 %.2f p99 %.2f ms; "
        "per op p50 %.2f ms; delta p50 %.0f KiB\n",
        t.steps.size(), bench::summarize(step_ms).p50, bench::summarize(step_ms).p99, crater.p50,
        crater.p99, bench::summarize(per_op_ms).p50, bench::summarize(delta_kib).p50);
    std::printf(
        "  drawn mesh: lag p50 %.0f p99 %.0f max %.0f frames; error bound p50 %.2f p99 %.2f px; "
        "triangles p50 %.0f; hashes %s\n",
        lag.p50, lag.p99, lag.max, error.p50, error.p99, bench::summarize(t.triangles).p50,
        t.hashes_agree ? "agree" : "DIFFER");
    std::printf(
        "  craters: drawn after p50 %.0f p99 %.0f max %.0f frames, converged after p50 %.0f p99 "
        "%.0f max %.0f (%zu of %zu), error bound until then p50 %.2f p99 %.2f px; moves per "
        "crater %.0f: %.0f in its footprint, %.0f elsewhere, %.0f undoing one (%.0f %%); per "
        "crater all told: worker %.2f ms, %.0f evaluations, %.0f blocks re-bounded\n",
        drawn.p50, drawn.p99, drawn.max, converged.p50, converged.p99, converged.max, converged.n,
        battle.sent.size(), bound_meanwhile.p50, bound_meanwhile.p99, moves * per_op,
        in_footprint * per_op, (moves - in_footprint) * per_op, undone * per_op, undone * share,
        busy_ms * per_op, evaluations * per_op, rebounds * per_op);
    std::printf(
        "  worker ms per crater all told: apply %.2f, absorb %.2f, stale bounds %.2f, rebuild "
        "%.2f, split/merge %.2f, finish %.2f, pool %.2f, collect %.2f\n",
        part_ms[0] * per_op, part_ms[1] * per_op, part_ms[2] * per_op, part_ms[3] * per_op,
        part_ms[4] * per_op, part_ms[5] * per_op, part_ms[6] * per_op, part_ms[7] * per_op);
    std::printf(
        "  memory after the flight: RSS %.1f MiB (the frame's copy of the tiles %.1f, the "
        "worker's tessellator %.1f, its hand-over %.1f); vertices drawn %llu of the "
        "tessellator's %llu\n",
        t.rss_mib, t.drawn_mesh_mib, bench::mib(tess_memory.total()),
        t.steps.empty() ? 0.0 : bench::mib(t.steps.back().collector_bytes),
        static_cast<unsigned long long>(t.steps.empty() ? 0 : t.steps.back().drawn_vertices),
        static_cast<unsigned long long>(t.steps.empty() ? 0 : t.steps.back().tessellator_vertices));
    if (!measured.p99.empty())
        std::printf(
            "  measured error of %zu drawn frames (every %d): per-frame p99 px p50 %.2f p99 %.2f "
            "max %.2f; per-frame max px p50 %.2f max %.2f; copying each %.1f ms\n",
            measured.p99.size(), s.measure_every, measured_p99.p50, measured_p99.p99,
            measured_p99.max, measured_max.p50, measured_max.max,
            bench::summarize(t.sample_ms).p50);
    std::printf(
        "  steps with craters (%zu), p50 ms: apply %.2f, absorb %.2f, stale bounds %.2f (%.0f "
        "blocks, %.1f us each), split/merge %.2f (%.0f splits, %.0f merges, %.0f evaluations; "
        "%.2f us per split or merge), finish %.2f, pool %.2f, collect %.2f (%.0f KiB, %.1f us "
        "per KiB)\n",
        c_apply.size(), bench::summarize(c_apply).p50, bench::summarize(c_absorb).p50,
        bench::summarize(c_bounds).p50, bench::summarize(c_blocks).p50,
        bench::summarize(per_block_us).p50, bench::summarize(c_policy).p50,
        bench::summarize(c_splits).p50, bench::summarize(c_merges).p50,
        bench::summarize(c_evaluations).p50, bench::summarize(per_split_merge_us).p50,
        bench::summarize(c_finish).p50, bench::summarize(c_pool).p50,
        bench::summarize(c_collect).p50, bench::summarize(c_kib).p50,
        bench::summarize(per_collect_kib_us).p50);
    if (!t.render_ms.empty())
        std::printf(
            "  render (sync + draw) ms: p50 %.1f p99 %.1f\n", bench::summarize(t.render_ms).p50,
            bench::summarize(t.render_ms).p99);
    return report;
}

/// The JSON report and the summary on stdout.
Json reportOf(
    const Settings& s,
    const Battle& battle,
    const Tally& t,
    const roam::Tessellator& tess,
    const Renderer& renderer,
    double first_frame_ms) {
    const bench::Summary single = bench::summarize(t.single_total);
    const bench::Summary bursts = bench::summarize(t.burst_total);
    const bench::Summary catch_up = bench::summarize(t.catch_up_total);
    const bench::Summary quiet = bench::summarize(t.quiet_total);
    const bench::Summary frames = bench::summarize(t.frame_total);
    const double tess_mib = bench::mib(tess.memoryBytes());
    const double rss_mib = bench::mib(bench::residentBytes());
    const double burst_ratio = frames.p50 > 0 ? bursts.p50 / frames.p50 : 0.0;
    Json report{
        {"benchmark", "client_battle_bench"},
        {"date", bench::isoNow()},
        {"cpu", bench::cpuModel()},
        {"map", "procedural " + std::to_string(s.map.width) + " x " + std::to_string(s.map.width)},
        {"flight", s.flight},
        {"viewport", std::to_string(s.width) + " x " + std::to_string(s.height)},
        {"tau_pixels", s.tau},
        {"max_triangles", s.max_triangles},
        {"shots", s.shots},
        {"join_after", s.join_after},
        {"frames", t.frame_total.size()},
        {"render", s.render},
        {"frame_target_ms", s.frame_target_ms},
        {"render_ms", summaryJson(bench::summarize(t.render_ms))},
        {"gpu_and_shadow_mib",
         renderer.terrain
             ? bench::mib(renderer.terrain->gpuBytes() + renderer.terrain->shadowBytes())
             : 0.0},
        {"ops", battle.sent.size()},
        {"hashes_agree", t.hashes_agree},
        {"first_frame_ms", first_frame_ms},
        {"crater_frame_ms",
         Json{
             {"total", summaryJson(single)},
             {"apply", summaryJson(bench::summarize(t.single_apply))},
             {"feed", summaryJson(bench::summarize(t.single_feed))},
             {"update", summaryJson(bench::summarize(t.single_update))}}},
        {"burst",
         Json{
             {"ops", s.burst},
             {"frame_ms", summaryJson(bursts)},
             {"ratio", burst_ratio},
             {"ops_per_frame", s.pacing.ops_per_frame},
             {"catch_up_frame_ms", summaryJson(catch_up)},
             {"catch_up_ratio_max", frames.p50 > 0 ? catch_up.max / frames.p50 : 0.0},
             {"max_delay_frames", t.max_delay_frames}}},
        {"frame_ms", summaryJson(frames)},
        {"quiet_frame_ms", summaryJson(quiet)},
        {"work_budget", s.work_budget},
        {"upload_budget_bytes", s.upload_budget},
        {"triangles", summaryJson(bench::summarize(t.triangles))},
        {"error_bound_pixels", summaryJson(bench::summarize(t.error_bound))},
        {"threshold_moves", t.threshold_moves},
        {"rebuild_frames", t.rebuilds},
        {"capped_frames", t.capped_frames},
        {"detail_cells", tess.detailCellCount()},
        {"detail_blocks",
         Json{
             {"pool", s.max_blocks},
             {"stale_budget", s.stale_budget},
             {"resident", tess.blockCount()},
             {"in_use", summaryJson(bench::summarize(t.in_use))},
             {"materialised", t.materialised},
             {"evicted", t.evicted},
             {"refusals", t.pool_refusals}}},
        {"tessellator_mib", tess_mib},
        {"tessellator_memory_mib", bench::tessellatorMemoryJson(tess)},
        {"rss_mib", rss_mib},
        {"goals", Json{
                      {"crater_p50_le_1ms", single.p50 <= 1.0},
                      {"crater_p99_le_3ms", single.p99 <= 3.0},
                      {"burst_le_2x_median_frame", burst_ratio <= 2.0},
                      {"no_rebuild", t.rebuilds == 0},
                      {"tessellator_le_32mb", tess_mib <= 32.0}}}};
    std::printf(
        "client_battle_bench: %zu ops after %d shots in the snapshot, %zu frames, %s flight, "
        "tau %.2g px, %d x %d%s\n",
        battle.sent.size(), s.join_after, t.frame_total.size(), s.flight.c_str(), s.tau, s.width,
        s.height, s.render ? ", rendered (OSMesa)" : "");
    std::printf(
        "  crater frame ms: p50 %.2f p99 %.2f max %.2f (apply p50 %.2f, feed p50 %.2f, update "
        "p50 %.2f)\n",
        single.p50, single.p99, single.max, bench::summarize(t.single_apply).p50,
        bench::summarize(t.single_feed).p50, bench::summarize(t.single_update).p50);
    std::printf(
        "  burst of %d: p50 %.2f ms (%.1fx the median frame %.2f ms); rebuild frames %d, capped "
        "frames %d\n",
        s.burst, bursts.p50, burst_ratio, frames.p50, t.rebuilds, t.capped_frames);
    std::printf(
        "  paced at %d ops a frame: catch-up frames p50 %.2f max %.2f ms (%.1fx the median), "
        "ops waited up to %d frames\n",
        s.pacing.ops_per_frame, catch_up.p50, catch_up.max,
        frames.p50 > 0 ? catch_up.max / frames.p50 : 0.0, t.max_delay_frames);
    if (quiet.n > 0)
        std::printf(
            "  frames with no op (the flight alone): %zu, p50 %.2f p99 %.2f max %.2f ms\n", quiet.n,
            quiet.p50, quiet.p99, quiet.max);
    std::printf(
        "  error bound px: p50 %.2f max %.2f (threshold moved in %d frames)\n"
        "  triangles p50 %.0f max %.0f; tessellator %.1f MiB, RSS %.1f MiB; first frame %.0f "
        "ms; hashes %s\n",
        bench::summarize(t.error_bound).p50, bench::summarize(t.error_bound).max, t.threshold_moves,
        bench::summarize(t.triangles).p50, bench::summarize(t.triangles).max, tess_mib, rss_mib,
        first_frame_ms, t.hashes_agree ? "agree" : "DIFFER");
    if (renderer.terrain)
        std::printf(
            "  render (sync + draw) ms: p50 %.1f p99 %.1f; GPU buffers and CPU copies %.1f MiB\n",
            bench::summarize(t.render_ms).p50, bench::summarize(t.render_ms).p99,
            bench::mib(renderer.terrain->gpuBytes() + renderer.terrain->shadowBytes()));
    bench::printTessellatorMemory(tess);
    std::printf(
        "  detail blocks: %d cells, pool %d, resident %d, in use p50 %.0f max %.0f; "
        "materialised %lld, evicted %lld, refusals %lld\n",
        tess.detailCellCount(), s.max_blocks, tess.blockCount(), bench::summarize(t.in_use).p50,
        bench::summarize(t.in_use).max, static_cast<long long>(t.materialised),
        static_cast<long long>(t.evicted), static_cast<long long>(t.pool_refusals));
    return report;
}

} // namespace

int main(int argc, char** argv) {
    Settings s;
    if (const std::optional<int> stop = parseSettings(argc, argv, s))
        return *stop;
    Battle battle = fightBattle(s);

    client::Replica replica;
    replica.loadSnapshot(std::move(*decodeSnapshot(battle.snapshot)));
    std::vector<std::uint8_t> first_state; // the measures' world starts from it
    if (s.measure_every > 0)
        first_state = battle.snapshot;
    std::vector<std::uint8_t>().swap(battle.snapshot);
    replica.takeDirty();
    roam::TessellatorOptions to;
    to.tau_pixels = s.tau;
    to.max_triangles = s.max_triangles;
    to.max_detail_blocks = s.max_blocks;
    to.work_budget = s.work_budget;
    to.stale_block_budget = s.stale_budget;
    to.upload_budget_bytes = s.upload_budget;
    to.count_moves_by_place = true;
    to.merge_band = s.merge_band;
    if (s.async) {
        Result<Renderer> renderer = makeRenderer(s);
        if (!renderer) {
            std::fprintf(stderr, "client_battle_bench: %s\n", renderer.error().message.c_str());
            return 2;
        }
        client::TessellationWorkerOptions wo;
        wo.view.tessellation = to;
        wo.view.budget.target_ms = s.frame_target_ms;
        wo.view.budget.max_triangles = s.max_triangles;
        wo.keep_step_log = true;
        wo.lockstep = s.lockstep;
        wo.threads = s.threads;
        wo.step_ms = s.step_ms;
        client::TessellationWorker worker(replica, wo);
        std::optional<bench::OpApplyThread> applier;
        if (s.apply_thread)
            applier.emplace(replica);
        const AsyncTally t =
            flyAsync(s, battle, replica, worker, *renderer, applier ? &*applier : nullptr);
        const MeasuredError measured =
            s.measure_every > 0 ? measureSamples(t.samples, first_state, battle.sent, s.tau)
                                : MeasuredError{};
        const Json json = asyncReportOf(s, battle, t, measured, worker.threads());
        if (!s.out.empty()) {
            std::ofstream file(s.out);
            if (!file) {
                std::fprintf(stderr, "client_battle_bench: cannot write %s\n", s.out.c_str());
                return 2;
            }
            file << json.dump(2) << "\n";
        }
        return t.hashes_agree ? 0 : 1;
    }
    const auto build_start = bench::Clock::now();
    roam::Tessellator tess(replica.terrain(), to);
    tess.update(flightCamera(s.flight, 0, replica.terrain(), battle.options, s.width, s.height));
    const double first_frame_ms = bench::msSince(build_start);

    Result<Renderer> renderer = makeRenderer(s);
    if (!renderer) {
        std::fprintf(stderr, "client_battle_bench: %s\n", renderer.error().message.c_str());
        return 2;
    }
    const Tally t = fly(s, battle, replica, tess, *renderer);
    const Json json = reportOf(s, battle, t, tess, *renderer, first_frame_ms);
    if (!s.out.empty()) {
        std::ofstream file(s.out);
        if (!file) {
            std::fprintf(stderr, "client_battle_bench: cannot write %s\n", s.out.c_str());
            return 2;
        }
        file << json.dump(2) << "\n";
    }
    return t.hashes_agree ? 0 : 1;
}
