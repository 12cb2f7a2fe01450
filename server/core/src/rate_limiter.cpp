#include <terrain/assert.h>
#include <terrain/server/rate_limiter.h>

#include <algorithm>
#include <cmath>

namespace terrain::server {

Status RateLimiter::checkParameters(double rate_per_second, double burst) {
    if (!std::isfinite(rate_per_second))
        return makeError(ErrorCode::kNotFinite, "rate limit rate is not finite");
    if (!std::isfinite(burst))
        return makeError(ErrorCode::kNotFinite, "rate limit burst is not finite");
    if (rate_per_second < 0.0)
        return makeError(ErrorCode::kOutOfRange, "rate limit rate is negative");
    if (burst <= 0.0)
        return makeError(ErrorCode::kOutOfRange, "rate limit burst is not positive");
    return Ok{};
}

RateLimiter::RateLimiter(double rate_per_second, double burst)
    : rate_(rate_per_second), burst_(burst), tokens_(burst) {
    TERRAIN_ASSERT(checkParameters(rate_per_second, burst).ok());
}

bool RateLimiter::tryConsume(double now_seconds, double cost) {
    if (!std::isfinite(now_seconds) || !std::isfinite(cost) || cost < 0.0)
        return false;
    if (!has_time_) {
        has_time_ = true;
        last_seconds_ = now_seconds;
    } else if (now_seconds > last_seconds_) {
        // note: a huge gap can make the product overflow to +inf; min() still caps it at burst
        const double refill = (now_seconds - last_seconds_) * rate_;
        tokens_ = std::min(burst_, tokens_ + refill);
        last_seconds_ = now_seconds;
    }
    // backwards time: no refill, and last_seconds_ keeps its high-water mark
    if (cost > burst_ || tokens_ + kEpsilon < cost)
        return false;
    tokens_ = std::max(0.0, tokens_ - cost);
    return true;
}

} // namespace terrain::server
