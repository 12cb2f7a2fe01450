#include <terrain/fixed_point.h>
#include <terrain/result.h>

#include <cmath>

namespace terrain {

std::uint64_t isqrt(std::uint64_t n) {
    // IEEE sqrt is correctly rounded, and the fix-up loops make the result exact whatever the
    // starting guess, so the answer is the same on every platform.
    auto r = static_cast<std::uint64_t>(std::sqrt(static_cast<double>(n)));
    while (r > 0 && r * r > n)
        --r;
    while ((r + 1) * (r + 1) <= n)
        ++r;
    return r;
}

const char* toString(ErrorCode code) {
    switch (code) {
    case ErrorCode::kNotFinite:
        return "not-finite";
    case ErrorCode::kOutOfRange:
        return "out-of-range";
    case ErrorCode::kOutsideMap:
        return "outside-map";
    case ErrorCode::kBadFormat:
        return "bad-format";
    case ErrorCode::kTruncated:
        return "truncated";
    case ErrorCode::kSizeMismatch:
        return "size-mismatch";
    case ErrorCode::kUnsupported:
        return "unsupported";
    case ErrorCode::kInvariantBroken:
        return "invariant-broken";
    case ErrorCode::kHashMismatch:
        return "hash-mismatch";
    case ErrorCode::kIo:
        return "io";
    }
    return "unknown";
}

} // namespace terrain
