#pragma once

// A cubic B-spline height patch over one base cell: 5 x 5 control heights, clamped uniform knots
// {0,0,0,0,1/2,1,1,1,1} in u and v (see bspline.h), evaluated as z(u, v) over the cell, where
// x = x0 + u*h and y = y0 + v*h. Evaluated vertices sit on a regular 17 x 17 grid.
//
// Invariants kept by Terrain (and checked by the snapshot decoder):
//  - corner controls equal kControlScale * the cell's base corner samples;
//  - each border row is either identical to the facing row of the neighbouring cell's patch, or,
//    where the neighbour has no patch, lies on the straight base edge (the control values at the
//    Greville abscissae of the linear edge). Either way the surface is watertight.
// Pure: no globals, no I/O.

#include <terrain/base_cell.h>
#include <terrain/bspline.h>
#include <terrain/fixed_point.h>

#include <array>
#include <cstddef>
#include <cstdint>

namespace terrain {

enum class Edge : std::uint8_t {
    kMinV, ///< row j = 0, shared with the cell at y - 1
    kMaxV, ///< row j = 4, shared with the cell at y + 1
    kMinU, ///< column i = 0, shared with the cell at x - 1
    kMaxU, ///< column i = 4, shared with the cell at x + 1
};
inline constexpr std::array<Edge, 4> kAllEdges = {
    Edge::kMinV, Edge::kMaxV, Edge::kMinU, Edge::kMaxU};

constexpr Edge opposite(Edge e) {
    switch (e) {
    case Edge::kMinV:
        return Edge::kMaxV;
    case Edge::kMaxV:
        return Edge::kMinV;
    case Edge::kMinU:
        return Edge::kMaxU;
    case Edge::kMaxU:
        return Edge::kMinU;
    }
    return e;
}

/// Offset of the cell across edge e.
struct CellOffset {
    int dx = 0;
    int dy = 0;
};
constexpr CellOffset neighbourOffset(Edge e) {
    switch (e) {
    case Edge::kMinV:
        return {0, -1};
    case Edge::kMaxV:
        return {0, 1};
    case Edge::kMinU:
        return {-1, 0};
    case Edge::kMaxU:
        return {1, 0};
    }
    return {};
}

inline constexpr int kPatchControls = bspline::kControls * bspline::kControls;
inline constexpr int kPatchGridVertices = bspline::kGridSamples * bspline::kGridSamples;

struct DetailPatch {
    /// Control heights in sixths of a quantum (kControlScale), index j * 5 + i; i runs along x.
    std::array<std::int32_t, kPatchControls> control{};
    /// True bound (quanta) on |patch - base triangles| over the cell; derived, not hashed.
    std::int32_t deviation_bound = 0;
    /// True bound (quanta) on |patch - piecewise-linear 17 x 17 grid of rounded heights|.
    float grid_error_bound = 0.0f;

    std::int32_t& at(int i, int j) { return control[static_cast<std::size_t>(j * 5 + i)]; }
    std::int32_t at(int i, int j) const { return control[static_cast<std::size_t>(j * 5 + i)]; }

    friend bool operator==(const DetailPatch& a, const DetailPatch& b) {
        return a.control == b.control;
    }
};

/// Control (i, j) of border `e`, k-th along the edge (k = 0..4 in increasing u or v).
std::int32_t& edgeControl(DetailPatch& p, Edge e, int k);
std::int32_t edgeControl(const DetailPatch& p, Edge e, int k);

/// The patch that reproduces the base cell as closely as the spline allows: controls are the
/// base triangles sampled at the Greville points (exact in sixths), so borders are straight.
DetailPatch patchFromBase(const CellCorners& c, Diagonal d);

/// Sets the four corner controls from the base corners.
void pinCorners(DetailPatch& p, const CellCorners& c);

/// Puts border `e` on the straight base edge between its two corners.
void straightenEdge(DetailPatch& p, Edge e, const CellCorners& c);
bool isEdgeStraight(const DetailPatch& p, Edge e, const CellCorners& c);
bool areCornersPinned(const DetailPatch& p, const CellCorners& c);

/// Height (quanta) and gradient (quanta per unit u, v) at (u, v) in [0, 1]^2.
double patchHeight(const DetailPatch& p, double u, double v);
Gradient patchGradient(const DetailPatch& p, double u, double v);

/// Exact height at grid point (k/16, l/16) as a numerator over kGridDenominator (quanta).
inline constexpr std::int64_t kGridDenominator =
    kControlScale * bspline::kWeightScale * bspline::kWeightScale;
std::int64_t gridNumerator(const DetailPatch& p, int k, int l);
/// All 17 x 17 numerators at once (separable, about 5x cheaper than 289 gridNumerator calls).
/// With a `stride` of 2 or 4, only the points whose k and l are multiples of it (the others are
/// left as they were): the same integers at a fraction of the work.
void gridNumerators(
    const DetailPatch& p, std::array<std::int64_t, kPatchGridVertices>& out, int stride = 1);

/// Heights at the 25 Greville points (u, v in {0, 1/6, 1/2, 5/6, 1}), index j * 5 + i, in
/// 1/48 quanta rounded to nearest (exact sums; one rounding).
void grevilleHeights48(const DetailPatch& p, std::array<std::int64_t, kPatchControls>& out);

/// Heights (quanta, rounded to nearest) on the 17 x 17 grid, index l * 17 + k.
/// A straight border evaluates exactly to the rounded base edge, so grids of neighbouring cells
/// agree bit for bit along shared edges.
void evaluateGrid(const DetailPatch& p, std::array<std::int32_t, kPatchGridVertices>& out);

/// Analytic gradient (quanta per unit u, v) at every grid point (k/16, l/16), index l * 17 + k.
/// The basis derivatives at k/16 are exact dyadic numbers, so these equal patchGradient() there;
/// a renderer turns them into vertex normals.
void evaluateGridGradients(const DetailPatch& p, std::array<Gradient, kPatchGridVertices>& out);

/// Recomputes deviation_bound (convex-hull bound on patch - bilinear, plus the bilinear-to-
/// triangles gap |twist| / 4) and grid_error_bound (second-derivative bound for linear
/// interpolation on right triangles with legs 1/16, plus half a quantum of rounding).
void updateBounds(DetailPatch& p, const CellCorners& c);

/// Smallest and largest control height in quanta (floor/ceil): the patch lies within them.
struct HeightRange {
    std::int32_t min = 0;
    std::int32_t max = 0;
};
HeightRange controlRange(const DetailPatch& p);

} // namespace terrain
