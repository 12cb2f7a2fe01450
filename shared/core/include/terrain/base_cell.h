#pragma once

// The base surface of a cell without a detail patch: two triangles over the cell's four corner
// samples. The diagonal alternates with (x + y) parity, which is the 4-8 mesh that a bintree over
// the grid produces at its finest level; ROAM and every query use this same surface.
// Pure functions, no state.

#include <cstdint>

namespace terrain {

/// Corner heights of cell (x, y) in quanta: h00 at (x, y), h10 at (x+1, y), h01 at (x, y+1).
struct CellCorners {
    std::int32_t h00 = 0;
    std::int32_t h10 = 0;
    std::int32_t h01 = 0;
    std::int32_t h11 = 0;
};

enum class Diagonal : std::uint8_t {
    kMain, ///< from (0,0) to (1,1); used when (x + y) is even
    kAnti, ///< from (1,0) to (0,1); used when (x + y) is odd
};

constexpr Diagonal cellDiagonal(std::int32_t x, std::int32_t y) {
    return ((x + y) & 1) == 0 ? Diagonal::kMain : Diagonal::kAnti;
}

/// n * T(a/n, b/n), exact, for integer 0 <= a, b <= n: the base surface height in 1/n quanta.
/// Inline: patch decisions run it for every point of the 17 x 17 grid.
inline std::int64_t
baseHeightScaled(const CellCorners& c, Diagonal d, std::int64_t a, std::int64_t b, std::int64_t n) {
    const std::int64_t h00 = c.h00;
    const std::int64_t h10 = c.h10;
    const std::int64_t h01 = c.h01;
    const std::int64_t h11 = c.h11;
    if (d == Diagonal::kMain) {
        if (a >= b)
            return n * h00 + (h10 - h00) * a + (h11 - h10) * b;
        return n * h00 + (h11 - h01) * a + (h01 - h00) * b;
    }
    if (a + b <= n)
        return n * h00 + (h10 - h00) * a + (h01 - h00) * b;
    return n * h11 + (h01 - h11) * (n - a) + (h10 - h11) * (n - b);
}

/// T(u, v) in quanta for u, v in [0, 1].
double baseHeight(const CellCorners& c, Diagonal d, double u, double v);

/// (dT/du, dT/dv) in quanta per unit of u, v. On the diagonal the triangle with u >= v (main)
/// or u + v <= 1 (anti) is used.
struct Gradient {
    double du = 0.0;
    double dv = 0.0;
};
Gradient baseGradient(const CellCorners& c, Diagonal d, double u, double v);

} // namespace terrain
