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

struct GridPoint {
    std::uint8_t k = 0;
    std::uint8_t l = 0;
};

// the 17 x 17 grid ordered by the coarsest power of two dividing both coordinates: the centre,
// then the points a quarter apart, an eighth, .. (any order gives the same answer)
const std::array<GridPoint, kPatchGridVertices>& coarseToFine() {
    static const std::array<GridPoint, kPatchGridVertices> order = [] {
        std::array<GridPoint, kPatchGridVertices> o{};
        std::size_t n = 0;
        for (int step = kGridSteps / 2; step >= 1; step /= 2)
            for (int l = 0; l < kGridSamples; ++l)
                for (int k = 0; k < kGridSamples; ++k) {
                    const bool here = k % step == 0 && l % step == 0;
                    const bool coarser =
                        step < kGridSteps / 2 && k % (2 * step) == 0 && l % (2 * step) == 0;
                    if (here && !coarser)
                        o[n++] = {static_cast<std::uint8_t>(k), static_cast<std::uint8_t>(l)};
                }
        return o;
    }();
    return order;
}

} // namespace

bool patchNeeded(const DetailPatch& p, const CellCorners& c, Diagonal d, std::int64_t tolerance) {
    const std::int64_t limit = tolerance * kGridSteps * kGridDenominator;
    // nine interior points first: a patch that holds detail nearly always shows it at one of
    // them, for an eighth of the full grid's work
    for (int l = 4; l <= 12; l += 4)
        for (int k = 4; k <= 12; k += 4) {
            const std::int64_t diff = gridNumerator(p, k, l) * kGridSteps -
                                      baseHeightScaled(c, d, k, l, kGridSteps) * kGridDenominator;
            if (absI64(diff) > limit)
                return true;
        }
    std::array<std::int64_t, kPatchGridVertices> g{};
    gridNumerators(p, g);
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

namespace {

// A crater cell: with A = S - z, the change is -limit (A <= -limit), A (-limit <= A <= 0),
// share * A (0 <= A <= limit) or share * limit (A >= limit). Wherever the bounds below put the
// whole cell in one of these regimes, the change is the old (linear) surface's plus a smooth
// term, and that term's curvature bound decides. The bounds are exact for the fixed-point terms:
// t, the relief and the limit are monotone in the distance on each side of the rim, and the plane
// and the old triangles take their extremes over the cell at its corners.
bool craterCellFits(
    const PointwiseOp& f,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t room) {
    const DeformOp& op = f.op();
    const std::int64_t r = op.radius;
    const std::int64_t cap = 2 * r + 1;
    const std::int64_t fx =
        std::min(cap, std::max(absI64(cx * h - op.center_x), absI64((cx + 1) * h - op.center_x)));
    const std::int64_t fy =
        std::min(cap, std::max(absI64(cy * h - op.center_y), absI64((cy + 1) * h - op.center_y)));
    constexpr std::int64_t kOne = kUnitStrength;
    const std::int64_t near2 = nearestSquared(op, cx, cy, h);
    if (near2 >= 4 * r * r)
        return true; // beyond the footprint
    const std::int64_t t_lo = radiusRatio(op, near2 * kFineScale * kFineScale);
    const std::int64_t t_hi =
        std::min(2 * kOne, radiusRatio(op, (fx * fx + fy * fy) * kFineScale * kFineScale));
    const bool crosses_rim = t_lo < kOne && t_hi > kOne;
    std::int64_t s_lo = 0;
    std::int64_t s_hi = 0;
    if (t_hi <= kOne) {
        s_lo = f.relief48(t_lo);
        s_hi = f.relief48(t_hi);
    } else if (t_lo >= kOne) {
        s_lo = f.relief48(t_hi);
        s_hi = f.relief48(t_lo);
    } else {
        s_lo = std::min(f.relief48(t_lo), f.relief48(t_hi));
        s_hi = f.relief48(kOne);
    }
    const std::int64_t limit_lo = f.limit48(t_hi);
    const std::int64_t limit_hi = f.limit48(t_lo);
    // A = S - z = (plane - z) + s
    const std::int64_t h48 = h * kFineScale;
    const std::int64_t x0 = cx * h48;
    const std::int64_t y0 = cy * h48;
    const std::array<std::int64_t, 4> d = {
        f.plane48(x0, y0) - co.h00 * kFineScale, f.plane48(x0 + h48, y0) - co.h10 * kFineScale,
        f.plane48(x0, y0 + h48) - co.h01 * kFineScale,
        f.plane48(x0 + h48, y0 + h48) - co.h11 * kFineScale};
    // the anchor's share is monotone in t as well
    const std::int64_t anchor_near = f.anchor48(t_lo);
    const std::int64_t anchor_far = f.anchor48(t_hi);
    const std::int64_t a_lo =
        *std::min_element(d.begin(), d.end()) + s_lo + std::min(anchor_near, anchor_far) - 1;
    const std::int64_t a_hi =
        *std::max_element(d.begin(), d.end()) + s_hi + std::max(anchor_near, anchor_far) + 1;

    const std::int64_t depth = op.height;
    const std::int64_t rim = ceilDiv(f.rim48(), kFineScale);
    const std::int64_t anchor = ceilDiv(absI64(f.ground().anchor48), kFineScale);
    const auto h2 = static_cast<std::uint64_t>(h * h);
    const auto uroom = static_cast<std::uint64_t>(room);
    // M h^2 / 4 <= room. The relief: M = 2 (depth + rim) / r^2 in the bowl, 2 rim / r^2 beyond
    // the rim (never across it: the crease). A term a (1 - r^2 / 4R^2)^2 (the anchor, the
    // limit): M <= 2 |a| / r^2. Scaling by the share (<= 1) only lowers them.
    auto reliefFits = [&] {
        if (crosses_rim)
            return false;
        const std::int64_t scale = (t_hi <= kOne ? depth + rim + 1 : rim + 1) + anchor;
        return productLessEqual(
            static_cast<std::uint64_t>(scale), h2, static_cast<std::uint64_t>(2 * r * r), uroom);
    };
    auto limitFits = [&] {
        return productLessEqual(
            static_cast<std::uint64_t>(depth + rim + 1), h2, static_cast<std::uint64_t>(2 * r * r),
            uroom);
    };
    // the floor and the ceiling must not bind anywhere in the cell (their clamps are further
    // regime boundaries): displacement z - original is linear on each triangle, so its
    // extremes are at the corners
    const std::array<std::int64_t, 4> disp = {
        (co.h00 - oc.h00) * kFineScale, (co.h10 - oc.h10) * kFineScale,
        (co.h01 - oc.h01) * kFineScale, (co.h11 - oc.h11) * kFineScale};
    const std::int64_t disp_lo = *std::min_element(disp.begin(), disp.end());
    const std::int64_t disp_hi = *std::max_element(disp.begin(), disp.end());
    // z' >= z - limit >= original + disp_lo - limit_hi >= floor; z' <= z + fill <= ceiling
    if (disp_lo - limit_hi < f.floor48(0))
        return false;
    if (disp_hi + std::max<std::int64_t>(0, std::min(limit_hi, a_hi)) > f.ceiling48(0))
        return false;
    const bool whole_share = f.ground().ejecta_share == kUnitStrength;
    if (a_hi + limit_hi <= 0)
        return limitFits(); // carved by the limit everywhere
    if (a_lo - limit_hi >= 0)
        return f.ground().ejecta_share == 0 || limitFits(); // filled by the limit everywhere
    // towards the profile everywhere, on one side of it (or both, when nothing scales the fill)
    const bool carved = a_lo + limit_lo >= 0 && a_hi <= 0;
    const bool filled = a_lo >= 0 && a_hi - limit_lo <= 0;
    const bool either = whole_share && a_lo + limit_lo >= 0 && a_hi - limit_lo <= 0;
    if (filled && f.ground().ejecta_share == 0)
        return true; // nothing to fill with: untouched
    if (carved || filled || either)
        return reliefFits();
    return false; // a regime boundary may cross the cell
}

} // namespace

bool curvatureFitsTolerance(
    const PointwiseOp& f,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t tolerance) {
    const DeformOp& op = f.op();
    // slack for the fixed-point profile (16.16 radius ratio and tapers: about 3 (|height| + rim
    // + |anchor|) / 2^16 at a point, twice that through the corners' interpolation; 16 leaves a
    // margin) and the rounding of the corner samples
    const std::int64_t rim_bound = op.kind == OpKind::kCrater
                                       ? ceilDiv(f.rim48(), kFineScale)
                                       : absI64((std::int64_t{op.height} * op.strength) >> 16);
    const std::int64_t anchor_bound = ceilDiv(absI64(f.ground().anchor48), kFineScale);
    const std::int64_t slack =
        2 + ceilDiv(16 * (2 * absI64(op.height) + rim_bound + anchor_bound), 65536);
    if (tolerance <= slack)
        return false;
    const std::int64_t room = tolerance - slack;
    const std::int64_t r = op.radius;
    const auto h2 = static_cast<std::uint64_t>(h * h);
    if (op.kind == OpKind::kCrater) {
        // |change| <= limit <= depth + rim, and so is the corners' interpolation of it
        if (2 * (absI64(op.height) + rim_bound + 1) <= room)
            return true;
        return craterCellFits(f, cx, cy, co, oc, h, room);
    }
    if (op.kind == OpKind::kRaise) {
        // |change - linear interpolation of change| <= 2 |height|
        if (2 * (absI64(op.height) + 1) <= room)
            return true;
        // M = 8 |height| / r^2 (largest at the edge of the mound)
        return productLessEqual(
            static_cast<std::uint64_t>(2 * absI64(op.height)), h2,
            static_cast<std::uint64_t>(r * r), static_cast<std::uint64_t>(room));
    }
    return false;
}

bool baseCellNeedsPatchExhaustive(
    const PointwiseOp& f,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t tolerance) {
    if (f.op().kind == OpKind::kSmooth)
        return false; // smoothing a base cell leaves it a base cell
    const Diagonal d = cellDiagonal(cx, cy);
    const CellCorners delta{cn.h00 - co.h00, cn.h10 - co.h10, cn.h01 - co.h01, cn.h11 - co.h11};
    const std::int64_t h48 = h * kFineScale;
    const std::int64_t step48 = h * (kFineScale / kGridSteps);
    const std::int64_t to48 = kFineScale / kGridSteps;
    // coarse to fine, so that a cell which needs a patch is usually found within a few points
    for (const GridPoint& p : coarseToFine()) {
        const std::int64_t old48 = to48 * baseHeightScaled(co, d, p.k, p.l, kGridSteps);
        const std::int64_t original48 = to48 * baseHeightScaled(oc, d, p.k, p.l, kGridSteps);
        const std::int64_t next48 =
            f.height(cx * h48 + p.k * step48, cy * h48 + p.l * step48, old48, original48);
        const std::int64_t linear48 = to48 * baseHeightScaled(delta, d, p.k, p.l, kGridSteps);
        if (absI64(next48 - old48 - linear48) > tolerance * kFineScale)
            return true;
    }
    return false;
}

bool baseCellNeedsPatch(
    const PointwiseOp& f,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    const CellCorners& oc,
    std::int64_t h,
    std::int64_t tolerance) {
    const DeformOp& op = f.op();
    if (op.kind == OpKind::kSmooth)
        return false;
    // nothing changes beyond the footprint
    const std::int64_t reach = footprintRadius(op);
    if (nearestSquared(op, cx, cy, h) >= reach * reach)
        return false;
    if (curvatureFitsTolerance(f, cx, cy, co, oc, h, tolerance))
        return false;
    return baseCellNeedsPatchExhaustive(f, cx, cy, co, cn, oc, h, tolerance);
}

} // namespace terrain
