#pragma once

// Clamped uniform cubic B-spline basis on [0, 1] with knots {0,0,0,0, 1/2, 1,1,1,1}: five basis
// functions, two spans. This is the basis of every detail patch (see detail_patch.h).
// Pure: no globals beyond constant tables, no I/O.

#include <array>
#include <cstdint>

namespace terrain::bspline {

inline constexpr int kDegree = 3;
inline constexpr int kControls = 5;
inline constexpr std::array<double, 9> kKnots = {0, 0, 0, 0, 0.5, 1, 1, 1, 1};

/// Greville abscissae (mean of kDegree consecutive inner knots): 0, 1/6, 1/2, 5/6, 1.
/// Controls placed on a linear function at these parameters reproduce it exactly.
/// Stored as numerators over 6.
inline constexpr std::array<std::int64_t, kControls> kGrevilleSixths = {0, 1, 3, 5, 6};

/// Interpolation at the Greville points: controls c = kInterpolation * f / kInterpolationScale
/// make the spline pass through values f given at the five Greville points (exact inverse of
/// the 5 x 5 collocation matrix N_j(g_i); rows 0 and 4 are unit rows, so the end controls depend
/// on the end values only). Cubic interpolation reproduces polynomials up to degree 3.
inline constexpr std::int64_t kInterpolationScale = 120;
inline constexpr std::array<std::array<std::int64_t, kControls>, kControls> kInterpolation = {{
    {120, 0, 0, 0, 0},
    {-72, 243, -70, 27, -8},
    {40, -135, 310, -135, 40},
    {-8, 27, -70, 243, -72},
    {0, 0, 0, 0, 120},
}};

/// Collocation at the Greville points: N_j(g_i) = kCollocation[i][j] / kCollocationScale, exact
/// (the inverse of kInterpolation). Gives a patch's exact heights at its control points.
inline constexpr std::int64_t kCollocationScale = 108;
inline constexpr std::array<std::array<std::int64_t, kControls>, kControls> kCollocation = {{
    {108, 0, 0, 0, 0},
    {32, 61, 14, 1, 0},
    {0, 27, 54, 27, 0},
    {0, 1, 14, 61, 32},
    {0, 0, 0, 0, 108},
}};

/// Evaluation grid: 17 samples per side at u = k/16.
inline constexpr int kGridSamples = 17;
inline constexpr int kGridSteps = kGridSamples - 1;

/// Integer basis weights at the grid: weight(k, i) = N_i(k/16) * kWeightScale, exact.
inline constexpr std::int64_t kWeightScale = 4096;

/// Index of the knot span containing u (3 for u < 1/2, 4 otherwise). u is clamped to [0, 1].
int findSpan(double u);

/// Values and first derivatives (d/du) of all five basis functions at u in [0, 1].
/// Uses the span search and the triangular Cox-de Boor scheme (Piegl & Tiller A2.2), so
/// every function is exact to rounding; the functions sum to 1.
struct Basis {
    std::array<double, kControls> value{};
    std::array<double, kControls> derivative{};
};
Basis evaluate(double u);

/// Exact integer weights at u = k/16 (k in [0, 16]), computed once with evaluate() and
/// checked to be integral: the dyadic knots make every value a multiple of 1/2048.
const std::array<std::array<std::int64_t, kControls>, kGridSamples>& gridWeights();

} // namespace terrain::bspline
