#pragma once

// Holds a frame-time target by steering the tessellator's triangle cap from what frames cost.
//
// The cost of a frame grows with its triangles (drawing, on llvmpipe above all; tessellation
// too), so the cap is the one knob: a frame over the target shrinks it in proportion, frames
// well under it grow it again, up to the configured cap. The measure is a moving average, and
// the cap moves at most every `settle_frames` frames, because the tessellator follows a new cap
// over a few frames (Tessellator::followCap) and its cost should show before the next move.
// Pure: the caller measures the time and passes it in.

#include <cstdint>

namespace terrain::client {

struct FrameBudgetOptions {
    /// Milliseconds per frame to hold; 0 turns steering off (the cap stays max_triangles).
    double target_ms = 0.0;
    std::int64_t max_triangles = 400'000; ///< the ceiling (the configured cap)
    std::int64_t min_triangles = 20'000;  ///< the floor: below it a view looks broken
    int settle_frames = 10;
    double smoothing = 0.25; ///< weight of the newest frame in the moving average
};

class FrameBudget {
  public:
    explicit FrameBudget(const FrameBudgetOptions& options);

    /// After a frame that took `frame_ms` and drew `triangles`: the cap for the next frames.
    std::int64_t observe(double frame_ms, std::int64_t triangles);

    std::int64_t cap() const { return cap_; }
    double averageMs() const { return average_ms_; }
    const FrameBudgetOptions& options() const { return options_; }

  private:
    FrameBudgetOptions options_;
    std::int64_t cap_ = 0;
    double average_ms_ = 0.0;
    int frames_ = 0;
    int since_move_ = 0;
};

} // namespace terrain::client
