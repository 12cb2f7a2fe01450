#pragma once

// The split/merge policy: which diamonds to split and merge this frame, and when to look at each
// candidate again. ROAM's two priority queues, kept as one CandidateHeap keyed by the eye travel
// at which a candidate's priority may cross the threshold, so a frame touches only what the eye's
// movement can have changed (Duchaineau et al. 1997; the key is the distance form of their
// deferred priority recomputation). Merges go lowest priority first, splits highest first, both
// within the frame's budget; what is left is due next frame. A candidate culled by the frustum
// but wanting a split is watched (looked at every frame); merge candidates kept for being in
// view are re-checked by a sweep as the view turns. The threshold is tau, or higher while the
// triangle cap binds: followCap moves it a step at a time and the candidates are re-keyed
// against it over a few frames.
//
// Owns: the heap, the due / watched / deferred lists, the eye travel, the cull sweep, the
// threshold and its moves. Reads and writes: the candidate and watched bits of DiamondSpace's
// states (never kActive). Does its splits and merges, and reads a candidate's extent, through a
// SplitMergeMesh (the tessellator's lattice walk): it knows no lattice points, tiles or blocks.
// Pure, single-threaded.

#include <terrain/roam/camera.h>
#include <terrain/roam/candidate_heap.h>
#include <terrain/roam/diamond_space.h>
#include <terrain/roam/frame_stats.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace terrain::roam {

/// What the policy needs of the mesh it steers.
class SplitMergeMesh {
  public:
    /// A candidate's box (lo.x > hi.x: empty, wholly in the padding) and error bound (metres).
    struct Extent {
        Box box;
        double delta = 0.0;
    };
    virtual Extent extentOf(DiamondId id) const = 0;
    /// Splits the diamond (forcing its parents); false if the cap or the block pool refused.
    virtual bool split(DiamondId id, FrameStats& stats) = 0;
    /// Merges the diamond unless a child of it is split.
    virtual void merge(DiamondId id, FrameStats& stats) = 0;
    /// The frame's work or upload budget is spent (what is left waits for the next frame).
    virtual bool budgetSpent(FrameStats& stats) const = 0;
    /// The mesh nears its triangle cap: merges must make room before the splits.
    virtual bool needsRoom() const { return true; }
    /// A round of splits is done: what they made is ready to be priced (the mesh may finish
    /// work it left for this moment).
    virtual void splitsDone() {}
    /// The share of a short step that pricing may take is spent (the moves need the rest).
    virtual bool pricingBudgetSpent(FrameStats& stats) const { return budgetSpent(stats); }
    /// The share of the frame's budget merges may spend is: a mesh whose threshold rose (the
    /// cap binds) has thousands of merges due, and merged first they would leave the splits the
    /// view needs waiting frame after frame. The whole budget unless the mesh says otherwise.
    virtual bool mergeBudgetSpent(FrameStats& stats) const { return budgetSpent(stats); }

  protected:
    ~SplitMergeMesh() = default;
};

class SplitMerge {
  public:
    /// `cull_sweep_degrees`: TessellatorOptions::cull_sweep_degrees.
    SplitMerge(DiamondSpace& space, double tau_pixels, double cull_sweep_degrees)
        : space_(&space), tau_(tau_pixels), threshold_(tau_pixels),
          sweep_degrees_(cull_sweep_degrees) {}

    // ids (the diamond space's ranges)
    void resizeIds(std::size_t eager, const std::array<std::size_t, kGrains>& pooled) {
        heap_.resizeIds(eager, pooled);
    }
    /// A new world: the heap forgets every id and its memory (clearCandidates() empties the
    /// lists kept across frames).
    void forgetIds() { heap_.reset(); }

    // candidates, as the mesh splits and merges
    /// Forgets every candidate (their state bits are the caller's to clear).
    void clearCandidates();
    /// `id` becomes a candidate of `kind` (DiamondSpace::kSplitCandidate or kMergeCandidate),
    /// due this frame.
    void offer(DiamondId id, std::uint8_t kind) {
        setCandidate(id, kind);
        due_.push_back(id);
    }
    /// `id` is no candidate (out of the heap).
    void clearCandidate(DiamondId id) {
        space_->state(id) = static_cast<std::uint8_t>(space_->state(id) & DiamondSpace::kActive);
        if (heap_.contains(id))
            heap_.remove(id);
    }
    bool holds(DiamondId id) const { return heap_.contains(id); }

    // the threshold
    void setTau(double tau_pixels) {
        tau_ = tau_pixels;
        threshold_ = tau_pixels;
    }
    /// TessellatorOptions::merge_band: merges below this share of the threshold.
    void setMergeBand(double band) { merge_band_ = band; }
    /// tau, or higher while the cap binds.
    double threshold() const { return threshold_; }
    void setThreshold(double t) { threshold_ = t; }
    /// Moves the threshold a step when the cap refused splits this frame (stats.refused_by_cap)
    /// or the mesh has `triangles` over `max_triangles`, or back towards tau when the mesh is
    /// well under the cap and the block pool has been quiet; one move at a time.
    void followCap(
        const FrameStats& stats,
        std::int64_t triangles,
        std::int64_t max_triangles,
        bool pool_quiet);

    // frames
    /// After a top-down build (whose splits offered the candidates): prices them, and keys what
    /// the build left (a binding cap) due at once.
    void settle(const ViewMetric& m, FrameStats& stats, SplitMergeMesh& mesh);
    /// After any rebuild: the cull sweep starts from this view.
    void restartSweep(const Camera& camera);
    /// A split/merge frame: the eye moved `travelled` metres. Returns the error bound the mesh
    /// is within once it is done (the threshold, or the largest priority left waiting).
    /// `new_view` false: a short step going on with the last frame's view (nothing to sweep,
    /// re-key or watch again).
    double frame(
        const ViewMetric& m,
        double travelled,
        FrameStats& stats,
        SplitMergeMesh& mesh,
        bool new_view = true);

    // the pool compacts chunks (BlockPool::Mover)
    /// Grain g's chunk `from` moved to `to` (the space's states moved already): heap entries
    /// follow.
    void chunkMoved(int g, std::int32_t from, std::int32_t to);
    /// Grain g's chunks from `end` are gone: ids of them in the lists kept across frames are
    /// renamed to where they moved, or dropped.
    void
    chunksCut(int g, std::size_t end, std::span<const std::pair<std::int32_t, std::int32_t>> moved);

    /// What a spent budget (or a refusal) leaves is due again at the start of the next frame,
    /// and priced again then with everything due: fine while budgets rarely bind. Where they
    /// bind frame after frame (a worker's short steps), it waits in a backlog by the priority
    /// it had, and each frame prices again only the best `per_frame` of each kind.
    static constexpr std::size_t kPullAll = ~std::size_t{0};
    void setBacklogPull(std::size_t per_frame);
    std::size_t backlogSize() const { return backlog_splits_.size() + backlog_merges_.size(); }
    std::size_t candidateCount() const { return heap_.size(); }
    /// The splits waiting for a budget (or refused by the cap): those the last frame left and
    /// the rest of the backlog, through visit(id); some may have stopped being split
    /// candidates since. (Waiting merges only keep triangles the view no longer needs.)
    template <class Visit> void forEachWaitingSplit(Visit&& visit) const {
        for (const DiamondId id : deferred_splits_)
            visit(id);
        for (const Action& a : backlog_splits_)
            visit(a.id);
    }
    std::size_t memoryBytes() const { return heap_.memoryBytes(); }

  private:
    struct Action {
        double priority = 0.0;
        DiamondId id = 0;
    };
    void setCandidate(DiamondId id, std::uint8_t kind) {
        space_->state(id) =
            static_cast<std::uint8_t>((space_->state(id) & DiamondSpace::kActive) | kind);
    }
    /// Prices a due candidate: splits_ or merges_ now, watched, or back in the heap keyed by the
    /// travel at which it may cross the threshold.
    void evaluate(const ViewMetric& m, DiamondId id, FrameStats& stats, SplitMergeMesh& mesh);
    /// Re-examines candidates keyed against the threshold before a move, a share per frame.
    void spreadRekey();
    /// Merge candidates out of view since the view turned, found by a sweep.
    void sweepCulled(const ViewMetric& m, SplitMergeMesh& mesh);
    /// This round's priced merges (lowest priority first) and splits (highest first), within
    /// the frame's budget; what it leaves is deferred.
    void doMerges(FrameStats& stats, SplitMergeMesh& mesh);
    void doSplits(FrameStats& stats, SplitMergeMesh& mesh);
    /// A priced split or merge the frame's budget (or a refusal) left: into the backlog.
    void defer(const Action& a, std::uint8_t kind);
    /// The backlog's best, due this frame (backlog_pull_ of each kind; splits only unless
    /// `merges`).
    void pullBacklog(bool merges);
    /// What this frame left (defer) into the backlog.
    void keepLeft();
    /// Orders of merges (lowest priority first) and splits (highest first); equal priorities
    /// (every culled merge is 0) by id, so the order never depends on the order of pricing.
    static bool lowerPriority(const Action& a, const Action& b) {
        return a.priority < b.priority || (a.priority == b.priority && a.id > b.id);
    }
    static bool higherPriority(const Action& a, const Action& b) {
        return a.priority > b.priority || (a.priority == b.priority && a.id > b.id);
    }

    DiamondSpace* space_;
    double tau_ = 1.0;
    double threshold_ = 1.0;
    double merge_band_ = 1.0;
    CandidateHeap heap_;             ///< candidates by the eye travel at which to re-examine them
    std::vector<DiamondId> watched_; ///< split candidates that want a split but are culled
    std::vector<DiamondId> watched_next_;
    std::vector<Action> splits_;
    std::vector<Action> merges_;
    std::vector<DiamondId> due_;
    std::vector<DiamondId> pulled_; ///< pullBacklog's scratch
    std::size_t carried_ = 0;       ///< due_'s first entries, carried over by a short step
    std::vector<DiamondId> evaluating_;
    std::vector<DiamondId> deferred_splits_; ///< this frame's, for settled()
    /// What spent budgets left: splits as a max-heap, merges as a min-heap of the priority they
    /// had when priced (their candidate bits stay set; they are in neither the heap nor due_).
    std::vector<Action> backlog_splits_;
    std::vector<Action> backlog_merges_;
    std::vector<Action> left_splits_; ///< deferred this frame (the backlog's at its end)
    std::vector<Action> left_merges_;
    std::size_t backlog_pull_ = kPullAll;
    double unmet_ = 0.0; ///< largest priority of a split the frame wanted and did not make
    std::vector<DiamondId> rekey_; ///< candidates still keyed against rekey_from_
    double rekey_from_ = 0.0;
    std::size_t rekey_quota_ = 0; ///< of rekey_, per frame
    double travel_ = 0.0;
    glm::dvec3 last_forward_{0.0};
    glm::dvec3 last_up_{0.0};
    double sweep_degrees_ = 4.0;
    double sweep_credit_ = 0.0;
    double sweep_phase_ = 0.0;
};

} // namespace terrain::roam
