#pragma once

// How many of the ops that arrived a client applies in one frame. A burst (20 craters in one
// network read) applied at once costs the frame it lands in several times a normal frame (the
// replica's apply, the tessellator's feed and the re-tessellation of every footprint); spread
// over a few frames each one stays close to a normal frame, and the backlog still drains within
// a bounded number of frames however fast ops arrive. Pure: the caller owns the queue and the
// frames.

#include <algorithm>
#include <cstddef>

namespace terrain::client {

/// The bot's and the viewer's default: 4 battle craters in one frame cost 1.6x a frame with one
/// (20 at once: 3.0x; client_battle_bench, BENCHMARKS.md "Ops paced over frames").
inline constexpr int kDefaultOpsPerFrame = 4;

struct OpPacing {
    /// Ops applied per frame at least; 0: every op as soon as it arrives (no queue).
    int ops_per_frame = 0;
    /// A backlog is applied within this many frames at most: a frame takes more than
    /// ops_per_frame when the backlog needs it.
    int catch_up_frames = 8;

    bool paced() const { return ops_per_frame > 0; }
};

/// Decides, frame by frame, how many of the waiting ops to apply (the caller's queue is first in,
/// first out). The rate is ops_per_frame, raised to waiting / catch_up_frames (rounded up) when a
/// backlog needs it and kept there until the queue is empty: every op is applied within
/// catch_up_frames frames of the frame it was waiting in, however fast ops arrive.
class OpPacer {
  public:
    explicit OpPacer(OpPacing pacing = {}) : pacing_(pacing) {}

    const OpPacing& pacing() const { return pacing_; }
    /// Ops to apply this frame out of `waiting` (all of them when unpaced).
    std::size_t take(std::size_t waiting) {
        if (!pacing_.paced())
            return waiting;
        const auto frames = static_cast<std::size_t>(std::max(1, pacing_.catch_up_frames));
        rate_ = std::max(
            {rate_, static_cast<std::size_t>(pacing_.ops_per_frame),
             (waiting + frames - 1) / frames});
        const std::size_t n = std::min(waiting, rate_);
        if (n == waiting)
            rate_ = 0; // caught up: the next backlog sets its own rate
        return n;
    }
    /// The queue was emptied some other way (a snapshot, a lost link).
    void reset() { rate_ = 0; }

  private:
    OpPacing pacing_;
    std::size_t rate_ = 0;
};

} // namespace terrain::client
