#pragma once

// When does a cell need a detail patch? Exact integer tests, shared by Terrain::apply and tests.
// A cell needs one when the base triangles (over its new corners) would be more than the
// tolerance away from the deformed surface at any point of its 17 x 17 grid.
// Pure: no state, no I/O.

#include <terrain/base_cell.h>
#include <terrain/detail_patch.h>
#include <terrain/pointwise_op.h>

#include <cstdint>

namespace terrain {

/// Does patch `p` stay farther than `tolerance` quanta from the base triangles over corners `c`
/// anywhere on its grid? Exact (the grid numerators are compared without rounding).
bool patchNeeded(const DetailPatch& p, const CellCorners& c, Diagonal d, std::int64_t tolerance);

/// Does a pointwise op (crater, raise, flatten) put detail into base cell (cx, cy) that the
/// triangles over its new corners `cn` cannot hold? `co` are the old corners, `oc` the original
/// ground's, h the spacing. Smooth ops never do. Runs the exact 289-point check unless
/// curvatureFitsTolerance() says no.
bool baseCellNeedsPatch(
    const PointwiseOp& op,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t tolerance);

/// The exhaustive part of baseCellNeedsPatch alone: the answer of all 289 points. For craters
/// it measures the points where the cell's aligned squares cannot be proven to fit (the
/// prefilter's regime and curvature bounds, applied to each square with the errors measured at
/// its corners) and skips the rest: the same answer as baseCellNeedsPatchEveryPoint() (tested),
/// from a fraction of the points.
bool baseCellNeedsPatchExhaustive(
    const PointwiseOp& op,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t tolerance);

/// The reference: every one of the 289 points, coarse to fine (tests; ops other than craters).
bool baseCellNeedsPatchEveryPoint(
    const PointwiseOp& op,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t tolerance);

/// Prefilter: true when the op's bounded curvature over the cell guarantees that linear
/// interpolation holds it within the tolerance. For a crater the cell must lie in one regime
/// (carved to the profile, cut by the limit, filled by the limit, or untouched), shown by bounds
/// over the cell; cells that the rim circle or a regime boundary may cross never qualify.
bool curvatureFitsTolerance(
    const PointwiseOp& op,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t tolerance);

} // namespace terrain
