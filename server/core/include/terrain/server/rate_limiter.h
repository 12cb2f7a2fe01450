#pragma once

// Deterministic token bucket. Pure: no clocks, no globals; the caller passes the time in, so the
// same calls give the same answers on every machine.

#include <terrain/result.h>

namespace terrain::server {

/// Token bucket: holds up to `burst` tokens, refills at `rate_per_second`, starts full.
/// - Time passed in that goes backwards credits nothing; the bucket keeps the latest time it
///   has seen, so coming back up to it credits nothing either (no double refill).
/// - A gap of any length refills at most to `burst`.
/// @note Not thread safe; one per session, used on the tick thread.
class RateLimiter {
  public:
    /// Tolerance on the token count, so that e.g. a hundred costs of 0.01 fit a burst of 1.0
    /// despite rounding. Far below any cost a caller would use.
    static constexpr double kEpsilon = 1e-9;

    /// Checks limiter parameters that came from configuration (untrusted).
    /// Failures: kNotFinite (either is NaN or infinite), kOutOfRange (rate < 0 or burst <= 0).
    static Status checkParameters(double rate_per_second, double burst);

    /// Precondition (TERRAIN_ASSERT): checkParameters(rate_per_second, burst) succeeds.
    RateLimiter(double rate_per_second, double burst);

    /// Refills for the time since the latest `now_seconds` seen, then takes `cost` tokens if
    /// there are enough. Returns false, taking nothing, when there are not, or when `cost` is
    /// NaN, infinite or negative, or `now_seconds` is not finite (then nothing changes at all).
    /// A cost above `burst` never succeeds; a cost of 0 always does.
    bool tryConsume(double now_seconds, double cost = 1.0);

    /// Tokens left as of the latest time seen (no refill is computed here).
    double available() const { return tokens_; }
    double ratePerSecond() const { return rate_; }
    double burst() const { return burst_; }

  private:
    double rate_;
    double burst_;
    double tokens_;
    double last_seconds_ = 0.0;
    bool has_time_ = false; // the first call sets the reference time and credits nothing
};

} // namespace terrain::server
