#pragma once

// Integer helpers for the deterministic core. Every function here is exact and gives the same
// result on every conforming C++20 compiler (signed >> is arithmetic since C++20).

#include <cmath>
#include <cstdint>

namespace terrain {

/// Heights and horizontal positions are int quanta; the default quantum is 1/1024 m.
inline constexpr std::int32_t kDefaultUnitsPerMetre = 1024;

/// Patch control heights are stored in sixths of a quantum, so that the control values of a
/// straight border (Greville abscissae 0, 1/6, 1/2, 5/6, 1) are exact integers.
inline constexpr std::int64_t kControlScale = 6;

/// Deformation arithmetic runs in 1/48 of a quantum: 48 = lcm(6, 16), so base vertices,
/// patch controls and points of the 17 x 17 evaluation grid are all exact.
inline constexpr std::int64_t kFineScale = 48;

/// Heights are kept within +-kMaxHeightQuanta so every intermediate fits in int64.
inline constexpr std::int32_t kMaxHeightQuanta = 1 << 27;

/// floor(a / b) for b > 0.
constexpr std::int64_t floorDiv(std::int64_t a, std::int64_t b) {
    std::int64_t q = a / b;
    if ((a % b != 0) && (a < 0))
        --q;
    return q;
}

/// ceil(a / b) for b > 0.
constexpr std::int64_t ceilDiv(std::int64_t a, std::int64_t b) {
    return -floorDiv(-a, b);
}

/// a / b rounded to nearest, ties towards +infinity, for b > 0.
constexpr std::int64_t roundDiv(std::int64_t a, std::int64_t b) {
    return floorDiv(2 * a + b, 2 * b);
}

constexpr std::int64_t absI64(std::int64_t a) {
    return a < 0 ? -a : a;
}

constexpr std::int32_t clampHeight(std::int64_t q) {
    if (q > kMaxHeightQuanta)
        return kMaxHeightQuanta;
    if (q < -kMaxHeightQuanta)
        return -kMaxHeightQuanta;
    return static_cast<std::int32_t>(q);
}

/// a * b <= c * d for non-negative operands, exact for any uint64 values (128-bit products built
/// from 32-bit halves, so it needs no compiler extension).
bool productLessEqual(std::uint64_t a, std::uint64_t b, std::uint64_t c, std::uint64_t d);

/// floor(sqrt(n)), exact for all n < 2^62. Inline: it runs for every point of every footprint.
inline std::uint64_t isqrt(std::uint64_t n) {
    // IEEE sqrt is correctly rounded, and the fix-up loops make the result exact whatever the
    // starting guess, so the answer is the same on every platform.
    auto r = static_cast<std::uint64_t>(std::sqrt(static_cast<double>(n)));
    while (r > 0 && r * r > n)
        --r;
    while ((r + 1) * (r + 1) <= n)
        ++r;
    return r;
}

} // namespace terrain
