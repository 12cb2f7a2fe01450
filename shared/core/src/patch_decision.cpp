// Patch decisions. The prefilter's bound: linear interpolation on a triangle of circumradius R
// misses a C1 function with second directional derivatives bounded by M by at most M R^2 / 2;
// a right triangle with legs h has R^2 = h^2 / 2.

#include <terrain/fixed_point.h>
#include <terrain/patch_decision.h>

#include <algorithm>
#include <array>

namespace terrain {
namespace {

using bspline::kGridSamples;
using bspline::kGridSteps;

// squared distance (quanta^2) from the op's centre to the nearest point of cell (cx, cy)
std::int64_t nearestSquared(const DeformOp& op, std::int32_t cx, std::int32_t cy, std::int64_t h) {
    const std::int64_t nx = std::clamp(op.center_x, cx * h, (cx + 1) * h) - op.center_x;
    const std::int64_t ny = std::clamp(op.center_y, cy * h, (cy + 1) * h) - op.center_y;
    return nx * nx + ny * ny;
}

} // namespace

bool patchNeeded(const DetailPatch& p, const CellCorners& c, Diagonal d, std::int64_t tolerance) {
    std::array<std::int64_t, kPatchGridVertices> g{};
    gridNumerators(p, g);
    const std::int64_t limit = tolerance * kGridSteps * kGridDenominator;
    for (int l = 0; l < kGridSamples; ++l)
        for (int k = 0; k < kGridSamples; ++k) {
            const std::int64_t base16 = baseHeightScaled(c, d, k, l, kGridSteps);
            const std::int64_t diff =
                g[static_cast<std::size_t>(l * kGridSamples + k)] * kGridSteps -
                base16 * kGridDenominator;
            if (absI64(diff) > limit)
                return true;
        }
    return false;
}

bool curvatureFitsTolerance(
    const DeformOp& op, std::int32_t cx, std::int32_t cy, std::int64_t h, std::int64_t tolerance) {
    // slack for the fixed-point profile (16.16 radius ratio: about 3 (|height| + rim) / 2^16 at a
    // point, twice that through the corners' interpolation; 16 leaves a margin) and the rounding of
    // the corner samples
    const std::int64_t rim_bound = absI64((std::int64_t{op.height} * op.strength) >> 16);
    const std::int64_t slack = 2 + ceilDiv(16 * (absI64(op.height) + rim_bound), 65536);
    if (tolerance <= slack)
        return false;
    // |change - linear interpolation of change| <= 2 max |change|: a tolerance above that is
    // never exceeded (crater: -depth .. +rim; raise: 0 .. height)
    if (op.kind != OpKind::kFlatten && 2 * (absI64(op.height) + 1) + slack <= tolerance)
        return true;
    const std::int64_t r = op.radius;
    const auto room = static_cast<std::uint64_t>(tolerance - slack);
    const auto h2 = static_cast<std::uint64_t>(h * h);
    if (op.kind == OpKind::kCrater) {
        // a cell that the rim circle crosses holds the crease: never skipped
        const std::int64_t fx =
            std::max(absI64(cx * h - op.center_x), absI64((cx + 1) * h - op.center_x));
        const std::int64_t fy =
            std::max(absI64(cy * h - op.center_y), absI64((cy + 1) * h - op.center_y));
        const bool beyond_rim = nearestSquared(op, cx, cy, h) > r * r;
        if (!beyond_rim && fx * fx + fy * fy >= r * r)
            return false;
        // M = 2 (depth + rim) / r^2 in the bowl, 2 rim / r^2 on the ejecta beyond the rim;
        // M h^2 / 4 <= room. +1: the rim's rounding
        const std::int64_t rim = (std::int64_t{op.height} * op.strength) >> 16;
        const std::int64_t scale = beyond_rim ? rim + 1 : op.height + rim + 1;
        return productLessEqual(
            static_cast<std::uint64_t>(scale), h2, static_cast<std::uint64_t>(2 * r * r), room);
    }
    if (op.kind == OpKind::kRaise) {
        // M = 8 |height| / r^2 (largest at the edge of the mound)
        return productLessEqual(
            static_cast<std::uint64_t>(2 * absI64(op.height)), h2,
            static_cast<std::uint64_t>(r * r), room);
    }
    return false;
}

bool baseCellNeedsPatchExhaustive(
    const DeformOp& op,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    std::int64_t h,
    std::int64_t tolerance) {
    if (op.kind == OpKind::kSmooth)
        return false; // smoothing a base cell leaves it a base cell
    const Diagonal d = cellDiagonal(cx, cy);
    const CellCorners delta{cn.h00 - co.h00, cn.h10 - co.h10, cn.h01 - co.h01, cn.h11 - co.h11};
    const std::int64_t h48 = h * kFineScale;
    const std::int64_t step48 = h * (kFineScale / kGridSteps);
    const std::int64_t to48 = kFineScale / kGridSteps;
    for (int l = 0; l < kGridSamples; ++l)
        for (int k = 0; k < kGridSamples; ++k) {
            const std::int64_t old48 = to48 * baseHeightScaled(co, d, k, l, kGridSteps);
            const std::int64_t next48 =
                pointwiseHeight(op, cx * h48 + k * step48, cy * h48 + l * step48, old48);
            const std::int64_t linear48 = to48 * baseHeightScaled(delta, d, k, l, kGridSteps);
            if (absI64(next48 - old48 - linear48) > tolerance * kFineScale)
                return true;
        }
    return false;
}

bool baseCellNeedsPatch(
    const DeformOp& op,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    std::int64_t h,
    std::int64_t tolerance) {
    if (op.kind == OpKind::kSmooth)
        return false;
    // nothing changes beyond the footprint
    const std::int64_t reach = footprintRadius(op);
    if (nearestSquared(op, cx, cy, h) >= reach * reach)
        return false;
    if (curvatureFitsTolerance(op, cx, cy, h, tolerance))
        return false;
    return baseCellNeedsPatchExhaustive(op, cx, cy, co, cn, h, tolerance);
}

} // namespace terrain
