#include <terrain/fixed_point.h>
#include <terrain/result.h>

#include <cmath>

namespace terrain {

namespace {

struct U128 {
    std::uint64_t hi = 0;
    std::uint64_t lo = 0;
};

U128 multiply(std::uint64_t a, std::uint64_t b) {
    const std::uint64_t a_lo = a & 0xffffffffu;
    const std::uint64_t a_hi = a >> 32;
    const std::uint64_t b_lo = b & 0xffffffffu;
    const std::uint64_t b_hi = b >> 32;
    const std::uint64_t ll = a_lo * b_lo;
    const std::uint64_t lh = a_lo * b_hi;
    const std::uint64_t hl = a_hi * b_lo;
    const std::uint64_t hh = a_hi * b_hi;
    const std::uint64_t mid = (ll >> 32) + (lh & 0xffffffffu) + (hl & 0xffffffffu);
    U128 r;
    r.lo = (mid << 32) | (ll & 0xffffffffu);
    r.hi = hh + (lh >> 32) + (hl >> 32) + (mid >> 32);
    return r;
}

} // namespace

bool productLessEqual(std::uint64_t a, std::uint64_t b, std::uint64_t c, std::uint64_t d) {
    const U128 left = multiply(a, b);
    const U128 right = multiply(c, d);
    return left.hi < right.hi || (left.hi == right.hi && left.lo <= right.lo);
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
