#pragma once

// How long an op takes to reach the picture, counted in frames: from the frame that applied it
// to the first that drew it (a drawn mesh at or past its seq: the heights-first delta) and to
// the first whose drawn mesh had it converged (every split and bound it called for made:
// WorkerStep::settled_seq), with the largest error bound drawn meanwhile. The benchmarks and the
// bot's report read it; a game may too. Ops converge in order; the history older than the oldest
// op not converged is dropped (the results are one number per op). Pure: frames are numbers the
// caller counts.

#include <cstdint>
#include <deque>
#include <vector>

namespace terrain::client {

class CraterLatency {
  public:
    /// Ops up to `seq` are the starting state's (a snapshot, the seq a late joiner starts at):
    /// not counted. Called before the first applied(); later calls start over.
    void start(std::uint64_t seq);
    /// Frame `frame` applied the ops up to `seq` (the replica's seq after it).
    void applied(std::int64_t frame, std::uint64_t seq);
    /// Frame `frame` draws a mesh made at `drawn_seq`, converged up to `settled_seq`, within
    /// `bound_px` of the surface (its error bound).
    void
    drawn(std::int64_t frame, std::uint64_t drawn_seq, std::uint64_t settled_seq, double bound_px);

    /// One entry per op drawn (converged), in seq order.
    const std::vector<double>& framesToDrawn() const { return to_drawn_; }
    const std::vector<double>& framesToConverged() const { return to_converged_; }
    /// Per op converged: the largest error bound drawn from the frame that applied it to the
    /// one that drew it converged.
    const std::vector<double>& boundUntilConverged() const { return bound_until_converged_; }
    /// Entries of history held: ops not yet converged and the frames since the oldest's apply.
    std::size_t heldEntries() const { return applied_at_.size() + bounds_.size(); }

  private:
    /// The frame that applied seq `s` (s in [first_seq_, applied_seq_]).
    std::int64_t appliedAt(std::uint64_t s) const {
        return applied_at_[static_cast<std::size_t>(s - first_seq_)];
    }

    std::uint64_t first_seq_ = 1;   ///< applied_at_'s first seq
    std::uint64_t applied_seq_ = 0; ///< the last seq applied
    std::uint64_t next_drawn_ = 1;
    std::uint64_t next_converged_ = 1;
    std::deque<std::int64_t> applied_at_;
    struct FrameBound {
        std::int64_t frame = 0;
        double bound_px = 0.0;
    };
    std::deque<FrameBound> bounds_; ///< from the frame that applied next_converged_ on
    std::vector<double> to_drawn_;
    std::vector<double> to_converged_;
    std::vector<double> bound_until_converged_;
};

} // namespace terrain::client
