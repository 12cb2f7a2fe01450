#pragma once

// The tessellation off the frame thread: a worker thread keeps its own copy of the world and its
// own TerrainView; for each frame's camera it tessellates and hands the tiles' changes over as a
// MeshDelta (delta_collector.h). The ops are applied once, on the frame's replica: at post() the
// frame thread takes the tiles they changed (Replica::takeSync: samples copied, patch lists
// shared, copy-on-write) and the worker's copy follows them at the start of its next step
// (Replica::follow), without applying anything. The frame thread never waits for it: post() hands
// in the frame's changes and camera under a lock held for a move, take() applies the newest
// finished delta, reached by one atomic exchange (a triple buffer: the worker writes one delta
// while the frame thread reads another; a third holds the newest finished). A delta the frame
// thread never took is superseded by the next, which covers it. When the worker is slower than the
// frames, it skips to the newest camera and the mesh lags: lag() says by how many frames.
//
// Lockstep (tests, benchmarks): every post() waits until the worker has tessellated it, so the
// steps are the synchronous path's (absorb, update per frame) and the meshes are the same.

#include <terrain/client/replica.h>
#include <terrain/client/terrain_view.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/delta_collector.h>
#include <terrain/roam/drawn_mesh.h>
#include <terrain/roam/frame_stats.h>
#include <terrain/task_runner.h>

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace terrain::client {

struct TessellationWorkerOptions {
    TerrainViewOptions view;
    /// Each post() waits for its step (the synchronous path's steps, on the worker).
    bool lockstep = false;
    /// Keeps every step's WorkerStep for stepLog() (benchmarks: the deltas the frame thread
    /// never took count too).
    bool keep_step_log = false;
    /// Not in lockstep: the time a step's tessellation may take (ms; Tessellator::
    /// setStepDeadline says how it is shared); the work left waits for the next steps, which
    /// follow at once with the newest camera, and a step that brings ops hands their heights
    /// over before any move. 0: every post is one whole step (the old way, for comparison).
    double step_ms = 4.0;
    /// Threads a step may spread its independent work over (the worker's own included): the
    /// stale bounds pass (per square of cells) and the delta's vertices and pages (per group of
    /// tiles). 0: defaultThreads(). The meshes and deltas are the same at any count.
    unsigned threads = 0;
    /// min(hardware threads - 1, 4): one core left to the frame thread.
    static unsigned defaultThreads();
};

/// What the worker did for the delta the frame thread holds.
struct WorkerStep {
    std::uint64_t step = 0;         ///< the worker's steps so far (one per tessellation)
    std::uint64_t frame = 0;        ///< the post whose camera it tessellated (1 = the first)
    std::uint64_t seq = 0;          ///< the replica seq its world had reached
    std::uint64_t ops = 0;          ///< ops the step applied (their craters are in its mesh)
    std::int64_t max_triangles = 0; ///< the cap the step ran under (the frame budget moves it)
    std::uint64_t world_hash = 0;
    /// Every op up to this seq has converged in the step's mesh: the cells it changed are
    /// settled (Tessellator::settled: their bounds are the new surface's, and no split or merge
    /// there waits for a budget). Ops converge in order here: one that settles before an
    /// earlier one is counted when the earlier one is.
    std::uint64_t settled_seq = 0;
    double threshold = 0.0; ///< the tessellator's threshold after the step (pixels)
    roam::FrameStats stats;
    /// Worker time for the step (ms): following the frame's world (copying the changed tiles),
    /// telling the
    /// tessellator (terrainChanged: blocks and bounds marked stale), tessellating, writing the
    /// delta; and update()'s passes (UpdatePhase order: stale bounds, rebuild, split/merge,
    /// finish frame, pool upkeep).
    double apply_ms = 0.0;
    double absorb_ms = 0.0;
    double update_ms = 0.0;
    double collect_ms = 0.0;
    std::array<double, roam::kUpdatePhases> phase_ms{};
    std::uint64_t delta_bytes = 0; ///< the delta's payload (vertices and index pages)
    /// A delta handed over after the step's ops moved the heights and before its moves (the
    /// step itself follows as another delta).
    bool heights_only = false;
    /// The step handed its ops' heights over before its moves (a heights_only delta).
    bool heights_first = false;
    /// With keep_step_log: the tessellator's memory after the step, by part
    /// (Tessellator::memory), and the hand-over's (DeltaCollector::memoryBytes).
    roam::TessellatorMemory tessellator_memory;
    std::uint64_t collector_bytes = 0;
    /// Vertices in the drawn tiles' arrays (the frame's copy and the GPU's: those a triangle
    /// uses, and free slots) and places in the tessellator's arrays (every vertex it could draw).
    std::uint64_t drawn_vertices = 0;
    std::uint64_t tessellator_vertices = 0;
};

class TessellationWorker {
  public:
    /// Copies the replica's world now and starts the worker on it; the replica records its
    /// changes from now on (Replica::recordChanges), and post() hands them over (its dirty set
    /// is dropped at each post: the worker keeps its own). The replica must outlive the worker
    /// and stay on the frame thread; one worker per replica.
    TessellationWorker(Replica& replica, const TessellationWorkerOptions& options);
    /// Stops the worker (after the step it is in) and joins it.
    ~TessellationWorker();
    TessellationWorker(const TessellationWorker&) = delete;
    TessellationWorker& operator=(const TessellationWorker&) = delete;

    /// Frame thread: hands over what the replica applied since the last post and this frame's
    /// camera (the worker tessellates the newest camera it has); `frame_ms`, when > 0, is the
    /// last frame's time for the triangle budget (TerrainView::steer). Waits only in lockstep.
    void post(const roam::Camera& camera, double frame_ms = 0.0);
    /// Frame thread: a new threshold (setTau) or triangle cap for the next steps.
    void setTau(double tau_pixels);
    void setMaxTriangles(std::int64_t max_triangles);
    /// Frame thread: applies the newest finished delta to `mesh` if there is one it has not
    /// taken; whether `mesh` changed. `mesh` must be fed by this worker alone.
    bool take(roam::DrawnMesh& mesh);
    /// Posts `camera` and waits until the worker has tessellated it, then takes it: a frame that
    /// must show everything up to now (a loading screen's end, a final picture). Waits.
    void finish(const roam::Camera& camera, roam::DrawnMesh& mesh);

    /// The step behind the delta last taken (zeros before the first).
    const WorkerStep& taken() const { return taken_; }
    /// Frames posted so far.
    std::uint64_t posted() const { return posted_; }
    /// Frames the drawn mesh is behind the newest camera: posted() - taken().frame.
    std::uint64_t lag() const { return posted_ - taken_.frame; }
    /// Every step so far, taken or not (with keep_step_log; empty otherwise).
    std::vector<WorkerStep> stepLog() const;
    /// Threads a step runs on (options' threads, or the default).
    unsigned threads() const { return pool_ ? pool_->threads() : 1u; }

  private:
    struct Slot {
        roam::MeshDelta delta;
        WorkerStep info;
    };
    static constexpr std::uint32_t kFresh = 4; ///< in middle_: a delta not yet taken
    static constexpr std::uint32_t kIndex = 3;

    void run();
    /// Waits until the worker has finished frame `frame`.
    void waitFor(std::uint64_t frame);

    TessellationWorkerOptions options_;
    Replica* replica_;

    // inputs: written by post() under in_mutex_, moved out by the worker
    std::mutex in_mutex_;
    std::condition_variable in_cv_;
    /// What the frame's replica changed, post by post, for the worker's world to follow.
    std::vector<ReplicaSync> in_syncs_;
    roam::Camera in_camera_{};
    std::uint64_t in_frame_ = 0;
    double in_frame_ms_ = 0.0;
    std::optional<double> in_tau_;
    std::optional<std::int64_t> in_max_triangles_;
    bool stop_ = false;
    /// A post brought changes the worker has not taken in: a short step ends at once, so that
    /// their heights are drawn first (the step's deadline reads it without the lock).
    std::atomic<bool> news_{false};

    // the frame the worker last finished (lockstep and finish() wait for it)
    std::mutex done_mutex_;
    std::condition_variable done_cv_;
    std::uint64_t done_frame_ = 0;

    // the triple buffer: the worker writes slots_[back_], the frame thread reads slots_[front_],
    // middle_ names the third and whether it holds a delta not yet taken
    std::array<Slot, 3> slots_;
    std::atomic<std::uint32_t> middle_{2};
    std::uint32_t back_ = 0;  ///< the worker's
    std::uint32_t front_ = 1; ///< the frame thread's

    mutable std::mutex log_mutex_;
    std::vector<WorkerStep> log_;

    // the frame thread's
    std::uint64_t posted_ = 0;
    std::vector<std::uint64_t> synced_versions_; ///< the tiles as the worker's world will hold them
    WorkerStep taken_;

    // the worker's (built on the constructing thread before it starts)
    class PhaseClock;
    std::unique_ptr<PhaseClock> phase_clock_;
    Replica world_;
    std::optional<TerrainView> view_;
    roam::DeltaCollector collector_;
    std::unique_ptr<ThreadPool> pool_; ///< the step's helpers (none at one thread)
    bool published_ = false;
    /// Ops whose cells are not settled yet, in seq order, with those cells.
    std::deque<std::pair<std::uint64_t, CellRect>> unsettled_;
    /// Follows the ops the changes bring (their cells) and what has settled after a step;
    /// returns the step's settled_seq.
    void noteFollowed(const ReplicaSync& sync);
    std::uint64_t settledSeq();
    /// Collects the tessellator's changes into the back slot with `info` (its collect time and
    /// bytes added) and makes it the newest finished delta.
    void publish(WorkerStep& info);
    /// The frame thread has taken the last delta published.
    bool frameTookLast() const;
    class StepClock;
    std::unique_ptr<StepClock> step_clock_; ///< short steps' deadline (not in lockstep)

    std::thread thread_;
};

} // namespace terrain::client
