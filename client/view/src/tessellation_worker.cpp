#include <terrain/client/tessellation_worker.h>

#include <algorithm>
#include <chrono>
#include <utility>

namespace terrain::client {

namespace {

double msSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
}

} // namespace

/// The end of a short step, for the tessellator's budgets: its time, or a post that brought ops.
class TessellationWorker::StepClock final : public roam::StepDeadline {
  public:
    StepClock(double step_ms, const std::atomic<bool>& news) : step_ms_(step_ms), news_(&news) {}
    void start() { started_ = std::chrono::steady_clock::now(); }
    bool spent(double share) const override {
        if (news_->load(std::memory_order_relaxed))
            return true;
        return std::chrono::duration<double, std::milli>(
                   std::chrono::steady_clock::now() - started_)
                   .count() >= share * step_ms_;
    }

  private:
    double step_ms_;
    const std::atomic<bool>* news_;
    std::chrono::steady_clock::time_point started_{};
};

/// Times update()'s passes into the step being made (the tessellator reads no clock).
class TessellationWorker::PhaseClock final : public roam::UpdatePhaseObserver {
  public:
    void begin(WorkerStep& step) {
        step_ = &step;
        current_ = -1;
    }
    void enter(roam::UpdatePhase phase) override {
        const auto now = std::chrono::steady_clock::now();
        if (current_ >= 0 && step_ != nullptr)
            step_->phase_ms[static_cast<std::size_t>(current_)] +=
                std::chrono::duration<double, std::milli>(now - started_).count();
        current_ = phase == roam::UpdatePhase::kDone ? -1 : static_cast<int>(phase);
        started_ = now;
    }

  private:
    WorkerStep* step_ = nullptr;
    int current_ = -1;
    std::chrono::steady_clock::time_point started_{};
};

unsigned TessellationWorkerOptions::defaultThreads() {
    const unsigned hardware = ThreadPool::hardwareThreads();
    return std::clamp(hardware > 1 ? hardware - 1 : 1u, 1u, 4u);
}

TessellationWorker::TessellationWorker(Replica& replica, const TessellationWorkerOptions& options)
    : options_(options), replica_(&replica) {
    // the worker's world: a copy of the replica's now, which follows it by changed tiles
    world_.follow(replica.takeSync(synced_versions_, {}));
    view_.emplace(world_, options.view);
    const unsigned threads =
        options.threads > 0 ? options.threads : TessellationWorkerOptions::defaultThreads();
    if (threads > 1) {
        pool_ = std::make_unique<ThreadPool>(threads);
        collector_.setTaskRunner(pool_.get());
        view_->tessellator().setTaskRunner(pool_.get());
    }
    phase_clock_ = std::make_unique<PhaseClock>();
    view_->tessellator().setPhaseObserver(phase_clock_.get());
    if (!options.lockstep && options.step_ms > 0.0) {
        step_clock_ = std::make_unique<StepClock>(options.step_ms, news_);
        view_->tessellator().setStepDeadline(step_clock_.get());
    }
    // from here the replica's changes are the worker's: recorded for it, and its dirty set
    // (the synchronous path's feed) dropped, every post
    replica.takeDirty();
    replica.recordChanges(true);
    try {
        thread_ = std::thread([this] { run(); });
    } catch (...) {
        replica.recordChanges(false);
        throw;
    }
}

TessellationWorker::~TessellationWorker() {
    {
        std::lock_guard lock(in_mutex_);
        stop_ = true;
    }
    in_cv_.notify_one();
    thread_.join();
    replica_->recordChanges(false);
}

void TessellationWorker::post(const roam::Camera& camera, double frame_ms) {
    std::vector<ReplicaChange> changes = replica_->takeChanges();
    (void)replica_->takeDirty(); // nobody reads it beside a worker: it would only grow
    const std::uint64_t frame = ++posted_;
    ReplicaSync sync;
    if (!changes.empty())
        sync = replica_->takeSync(synced_versions_, std::move(changes));
    {
        std::lock_guard lock(in_mutex_);
        if (!sync.empty()) {
            in_syncs_.push_back(std::move(sync));
            news_.store(true, std::memory_order_relaxed);
        }
        in_camera_ = camera;
        in_frame_ = frame;
        in_frame_ms_ = frame_ms;
    }
    in_cv_.notify_one();
    if (options_.lockstep)
        waitFor(frame);
}

void TessellationWorker::waitFor(std::uint64_t frame) {
    std::unique_lock lock(done_mutex_);
    done_cv_.wait(lock, [&] { return done_frame_ >= frame; });
}

void TessellationWorker::finish(const roam::Camera& camera, roam::DrawnMesh& mesh) {
    post(camera);
    waitFor(posted_);
    take(mesh);
}

void TessellationWorker::setTau(double tau_pixels) {
    std::lock_guard lock(in_mutex_);
    in_tau_ = tau_pixels;
}

void TessellationWorker::setMaxTriangles(std::int64_t max_triangles) {
    std::lock_guard lock(in_mutex_);
    in_max_triangles_ = max_triangles;
}

bool TessellationWorker::take(roam::DrawnMesh& mesh) {
    if ((middle_.load(std::memory_order_acquire) & kFresh) == 0)
        return false;
    // the newest finished delta becomes ours; the worker gets our old slot to write into
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    const Slot& slot = slots_[front_];
    const bool changed = mesh.apply(slot.delta);
    taken_ = slot.info;
    return changed;
}

void TessellationWorker::noteFollowed(const ReplicaSync& sync) {
    // after a state the next update rebuilds: nothing before it, or after it in the same step,
    // waits to settle
    const bool rebuild = world_.peekDirty().all;
    for (const ReplicaChange& change : sync.changes)
        if (change.kind == ReplicaChange::Kind::kState)
            unsettled_.clear();
        else if (change.kind == ReplicaChange::Kind::kOp && !rebuild && !change.cells.empty())
            unsettled_.emplace_back(change.seq, change.cells);
}

std::uint64_t TessellationWorker::settledSeq() {
    const roam::Tessellator& tess = view_->tessellator();
    while (!unsettled_.empty() && tess.settled(unsettled_.front().second))
        unsettled_.pop_front();
    return unsettled_.empty() ? world_.seq() : unsettled_.front().first - 1;
}

std::vector<WorkerStep> TessellationWorker::stepLog() const {
    std::lock_guard lock(log_mutex_);
    return log_;
}

bool TessellationWorker::frameTookLast() const {
    return published_ && (middle_.load(std::memory_order_acquire) & kFresh) == 0;
}

void TessellationWorker::publish(WorkerStep& info) {
    Slot& slot = slots_[back_];
    const auto start = std::chrono::steady_clock::now();
    // the frame thread took the last delta published: what it covered is delivered
    if (frameTookLast())
        collector_.delivered();
    collector_.collect(view_->tessellator(), world_.terrain(), slot.delta);
    info.collect_ms += msSince(start);
    info.delta_bytes = slot.delta.payloadBytes();
    slot.info = info;
    back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndex;
    published_ = true;
}

void TessellationWorker::run() {
    std::vector<ReplicaSync> syncs;
    std::uint64_t seen = 0; // the last post taken in
    std::uint64_t steps = 0;
    const bool sliced = !options_.lockstep && options_.step_ms > 0.0;
    bool more = false; // the last step left work (bounds, splits, merges) for the next
    for (;;) {
        roam::Camera camera;
        std::uint64_t frame = 0;
        double frame_ms = 0.0;
        std::optional<double> tau;
        std::optional<std::int64_t> max_triangles;
        {
            std::unique_lock lock(in_mutex_);
            in_cv_.wait(lock, [&] { return stop_ || in_frame_ != seen || more; });
            if (stop_)
                return;
            syncs.swap(in_syncs_);
            news_.store(false, std::memory_order_relaxed);
            camera = in_camera_;
            frame = in_frame_;
            if (frame != seen)
                frame_ms = in_frame_ms_;
            tau = std::exchange(in_tau_, std::nullopt);
            max_triangles = std::exchange(in_max_triangles_, std::nullopt);
        }
        seen = frame;
        WorkerStep info;

        auto start = std::chrono::steady_clock::now();
        for (const ReplicaSync& sync : syncs) {
            // its own patch lists: the frame's replica, which applies the ops, then writes its
            // lists in place rather than cloning a battle tile's thousands of patches per op
            world_.follow(sync, Terrain::PatchLists::kOwnCopies);
            noteFollowed(sync);
            for (const ReplicaChange& change : sync.changes)
                info.ops += change.kind == ReplicaChange::Kind::kOp ? 1 : 0;
        }
        const bool changed = !syncs.empty();
        syncs.clear();
        info.apply_ms = msSince(start);
        start = std::chrono::steady_clock::now();
        view_->absorb();
        if (tau)
            view_->tessellator().setTau(*tau);
        if (max_triangles)
            view_->tessellator().setMaxTriangles(*max_triangles);
        if (frame_ms > 0.0)
            view_->steer(frame_ms);
        info.absorb_ms = msSince(start);
        info.step = ++steps;
        info.frame = frame;
        info.seq = world_.seq();
        info.world_hash = world_.worldHash();
        info.threshold = view_->tessellator().threshold();
        info.max_triangles = view_->tessellator().options().max_triangles;

        double heights_collect_ms = 0.0;
        if (sliced && changed && published_) {
            // the heights first: the ops' new surface at the triangles drawn now (absorb moved
            // their vertices), handed over before any split or merge they call for
            WorkerStep heights = info;
            heights.heights_only = true;
            heights.stats = view_->lastStats();
            heights.stats.stale_blocks = view_->tessellator().staleBlockCount();
            heights.settled_seq = settledSeq();
            publish(heights);
            heights_collect_ms = heights.collect_ms;
            info.heights_first = true;
        }

        if (sliced)
            step_clock_->start();
        start = std::chrono::steady_clock::now();
        phase_clock_->begin(info);
        info.stats = view_->update(camera);
        info.update_ms = msSince(start);
        info.threshold = view_->tessellator().threshold();
        info.settled_seq = settledSeq();
        if (options_.keep_step_log) {
            // walks every tile: for the benchmarks' log only
            info.tessellator_memory = view_->tessellator().memory();
            info.collector_bytes = collector_.memoryBytes();
            info.drawn_vertices = roam::DeltaCollector::slotCount(view_->tessellator());
            info.tessellator_vertices =
                roam::DeltaCollector::tessellatorVertexCount(view_->tessellator());
        }
        // ops came in during the step and cut it short: their heights go first, and the next
        // step's heights-first delta carries this step's moves too (whatever no delta took
        // stays pending), so this one is not collected
        const bool preempted = sliced && news_.load(std::memory_order_relaxed);
        if (sliced) {
            // more to do: the step ended at its deadline with work left, or left a backlog it
            // could act on (one the cap refused waits for the threshold, not another step)
            const roam::FrameStats& st = info.stats;
            more = preempted || st.budget_exhausted || st.stale_blocks > 0 ||
                   (st.backlog > 0 && st.splits + st.merges > 0);
        }
        // a delta the frame has not taken yet would be collected again in the next: publish
        // when it took the last, when the mesh is done, and in lockstep always
        if (!published_ || (!preempted && (!sliced || !more || frameTookLast())))
            publish(info);
        info.collect_ms += heights_collect_ms;
        if (options_.keep_step_log) {
            std::lock_guard lock(log_mutex_);
            log_.push_back(info);
        }
        if (!more) {
            {
                std::lock_guard lock(done_mutex_);
                done_frame_ = frame;
            }
            done_cv_.notify_all();
        }
    }
}

} // namespace terrain::client
