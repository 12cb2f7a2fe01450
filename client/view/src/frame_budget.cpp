#include <terrain/client/frame_budget.h>

#include <algorithm>

namespace terrain::client {

namespace {

// Frames under this share of the target may grow the cap; between it and the target it holds,
// so that a cap just right does not hunt up and down.
constexpr double kGrowBelow = 0.8;
// A move changes the cap by at most these factors: the cost is not quite proportional to the
// triangles (a fixed part per frame), so a measured ratio overshoots if taken whole.
constexpr double kMaxShrink = 0.6;
constexpr double kMaxGrow = 1.25;

} // namespace

FrameBudget::FrameBudget(const FrameBudgetOptions& options)
    : options_(options), cap_(options.max_triangles) {
    options_.min_triangles = std::min(options_.min_triangles, options_.max_triangles);
    options_.settle_frames = std::max(options_.settle_frames, 1);
    window_.reserve(static_cast<std::size_t>(options_.settle_frames));
    sorted_.reserve(static_cast<std::size_t>(options_.settle_frames));
}

std::int64_t FrameBudget::observe(double frame_ms, std::int64_t triangles) {
    if (options_.target_ms <= 0.0)
        return cap_;
    window_.push_back(frame_ms);
    if (static_cast<int>(window_.size()) < options_.settle_frames)
        return cap_;
    sorted_.assign(window_.begin(), window_.end());
    window_.clear();
    const auto middle = sorted_.begin() + static_cast<std::ptrdiff_t>(sorted_.size() / 2);
    std::nth_element(sorted_.begin(), middle, sorted_.end());
    measured_ms_ = *middle;
    if (measured_ms_ <= 0.0)
        return cap_;
    const double ratio = options_.target_ms / measured_ms_;
    double next = static_cast<double>(cap_);
    if (ratio < 1.0) {
        // over the target: what the frame drew, scaled to the target
        next = static_cast<double>(std::min(cap_, triangles)) * std::max(ratio, kMaxShrink);
    } else if (ratio > 1.0 / kGrowBelow && triangles >= cap_ / 4 * 3) {
        // well under it, and the cap was what held the mesh back
        next = static_cast<double>(cap_) * std::min(ratio * kGrowBelow, kMaxGrow);
    }
    cap_ =
        std::clamp(static_cast<std::int64_t>(next), options_.min_triangles, options_.max_triangles);
    return cap_;
}

} // namespace terrain::client
