#pragma once

// GPU time of a frame's work (GL_TIME_ELAPSED queries around what the frame sends: the uploads'
// copies and the draws), read without waiting: each frame starts a query and collects those
// that have finished, a few frames late. The frame budget steers on it where the CPU's own frame
// time hides the GPU's (the GPU works behind the CPU).

#include <terrain/render/gl_api.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>

namespace terrain::render {

class GpuTimer {
  public:
    static constexpr std::size_t kQueries = 4;

    /// The context current.
    explicit GpuTimer(const GlApi& gl);
    ~GpuTimer() = default;
    GpuTimer(const GpuTimer&) = delete;
    GpuTimer& operator=(const GpuTimer&) = delete;
    /// Gives the queries back (the context current); a context that goes frees them anyway.
    void release();

    /// Around a frame's GL work; one frame at a time. A frame that finds every query still
    /// pending is not timed (counted in skipped()).
    void begin();
    void end();
    /// Milliseconds of the frames finished since the last call, oldest first (none yet: empty).
    /// Never waits. A result longer than the wall time from the frame's begin() to now cannot be
    /// the frame's and is dropped (counted in invalid(): llvmpipe reports its clock when a query
    /// saw no rasterizer work).
    std::size_t collect(std::array<double, kQueries>& out);
    /// The latest frame's GPU time seen by collect(), if any.
    std::optional<double> latestMs() const { return latest_; }
    std::uint64_t skipped() const { return skipped_; }
    std::uint64_t invalid() const { return invalid_; }

  private:
    const GlApi& gl_;
    std::array<unsigned, kQueries> queries_{};
    std::array<bool, kQueries> pending_{};
    std::array<std::chrono::steady_clock::time_point, kQueries> began_{};
    std::size_t next_ = 0;   ///< where the next frame's query goes
    std::size_t oldest_ = 0; ///< the oldest pending one
    std::size_t in_flight_ = 0;
    bool running_ = false;
    std::optional<double> latest_;
    std::uint64_t skipped_ = 0;
    std::uint64_t invalid_ = 0;
};

} // namespace terrain::render
