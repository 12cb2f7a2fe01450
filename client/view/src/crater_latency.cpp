#include <terrain/client/crater_latency.h>

#include <algorithm>

namespace terrain::client {

void CraterLatency::start(std::uint64_t seq) {
    first_seq_ = seq + 1;
    applied_seq_ = seq;
    next_drawn_ = seq + 1;
    next_converged_ = seq + 1;
    applied_at_.clear();
    bounds_.clear();
}

void CraterLatency::applied(std::int64_t frame, std::uint64_t seq) {
    for (; applied_seq_ < seq; ++applied_seq_)
        applied_at_.push_back(frame);
}

void CraterLatency::drawn(
    std::int64_t frame, std::uint64_t drawn_seq, std::uint64_t settled_seq, double bound_px) {
    bounds_.push_back({frame, bound_px});
    for (; next_drawn_ <= std::min(drawn_seq, applied_seq_); ++next_drawn_)
        to_drawn_.push_back(static_cast<double>(frame - appliedAt(next_drawn_)));
    for (; next_converged_ <= std::min(settled_seq, applied_seq_); ++next_converged_) {
        const std::int64_t from = appliedAt(next_converged_);
        to_converged_.push_back(static_cast<double>(frame - from));
        double worst = 0.0;
        for (const FrameBound& b : bounds_)
            if (b.frame >= from)
                worst = std::max(worst, b.bound_px);
        bound_until_converged_.push_back(worst);
    }
    // what no op waiting to converge (nor to be drawn) can still need
    const std::uint64_t keep = std::min(next_drawn_, next_converged_);
    while (first_seq_ < keep && !applied_at_.empty()) {
        applied_at_.pop_front();
        ++first_seq_;
    }
    const std::int64_t oldest =
        next_converged_ <= applied_seq_ ? appliedAt(next_converged_) : frame;
    while (!bounds_.empty() && bounds_.front().frame < oldest)
        bounds_.pop_front();
}

} // namespace terrain::client
