#pragma once

// Holds a frame-time target by steering the tessellator's triangle cap from what frames cost.
//
// The cost of a frame grows with its triangles (drawing, on llvmpipe above all; tessellation
// too), so the cap is the one knob: a frame over the target shrinks it in proportion, frames
// well under it grow it again, up to the configured cap. The measure is the median of the frames
// since the last move (a one-off frame, a crater's upload or the first frame's, moves nothing),
// and the cap moves at most every `settle_frames` frames, because the tessellator follows a new
// cap over a few frames (Tessellator::followCap) and its cost should show before the next move.
// Pure: the caller measures the time and passes it in.

#include <cstdint>
#include <vector>

namespace terrain::client {

struct FrameBudgetOptions {
    /// Milliseconds per frame to hold; 0 turns steering off (the cap stays max_triangles).
    double target_ms = 0.0;
    std::int64_t max_triangles = 400'000; ///< the ceiling (the configured cap)
    std::int64_t min_triangles = 20'000;  ///< the floor: below it a view looks broken
    int settle_frames = 10;               ///< at least 1; the median is over this many frames
};

class FrameBudget {
  public:
    explicit FrameBudget(const FrameBudgetOptions& options);

    /// After a frame that took `frame_ms` and drew `triangles`: the cap for the next frames.
    std::int64_t observe(double frame_ms, std::int64_t triangles);

    std::int64_t cap() const { return cap_; }
    /// The median frame time the last decision looked at (0 before the first).
    double measuredMs() const { return measured_ms_; }
    const FrameBudgetOptions& options() const { return options_; }

  private:
    FrameBudgetOptions options_;
    std::int64_t cap_ = 0;
    double measured_ms_ = 0.0;
    std::vector<double> window_; ///< frame times since the last decision
    std::vector<double> sorted_;
};

} // namespace terrain::client
