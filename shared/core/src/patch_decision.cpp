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

// A rectangle of a cell, in 1/48 quanta, with the old surface (z) and the original ground at its
// corners, in the order (x0, y0), (x1, y0), (x0, y1), (x1, y1). Both are linear on each piece
// of the rectangle that the cell's diagonal leaves (whole cells, and the aligned squares that
// baseCellNeedsPatchExhaustive() splits them into), so their extremes over it are at the corners.
struct Rect48 {
    std::int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    std::array<std::int64_t, 4> z{};
    std::array<std::int64_t, 4> original{};
};

// What craterRectFits() bounded over a rectangle, for kinkFits().
struct RegimeBounds {
    std::int64_t a_lo, a_hi;         // A = S - z, 1/48 quanta
    std::int64_t limit_lo, limit_hi; // L
    std::int64_t t_hi;               // the farthest radius ratio, 16.16
    bool crosses_rim;
};

// A regime boundary may cross the rectangle (the floor and the ceiling do not bind: checked
// before). With x+ = max(x, 0) and s the share, the change is
//   -L + (A + L)+ - (1 - s) A+ - s (A - L)+,
// and each x+ term misses its interpolation over a triangle by at most its argument's own
// (M side^2 / 4) plus min(P, N), P and N the largest positive and negative values of the
// argument at the triangle's corners (the kink of x+ over a linear argument). A term whose
// argument is <= 0 over the whole rectangle is 0. The rim's crease is not bounded here.
// Where the ceiling may bind (`ceiling`), the change is min(change, C), C = ceiling - z linear:
// change - (change - C)+, whose argument misses its interpolation by the change's own bound;
// so the bound doubles, plus that kink's min(P, N). (C < 0 at a corner: not bounded here.)
bool kinkFits(
    const PointwiseOp& f,
    const Rect48& rect,
    std::int64_t room,
    const RegimeBounds& b,
    bool ceiling) {
    if (b.crosses_rim)
        return false;
    constexpr std::int64_t kOne = kUnitStrength;
    const DeformOp& op = f.op();
    const std::int64_t rim = ceilDiv(f.rim48(), kFineScale);
    const std::int64_t anchor = ceilDiv(absI64(f.ground().anchor48), kFineScale);
    // curvature scales (M = 2 scale / r^2), as reliefFits and limitFits have them
    const std::int64_t scale_a = (b.t_hi <= kOne ? op.height + rim + 1 : rim + 1) + anchor;
    const std::int64_t scale_l = op.height + rim + 1;
    // A and L at the corners: beyond the footprint L is 0 and S the plane (the terms reach 0
    // there with zero slope)
    std::array<std::int64_t, 4> a{};
    std::array<std::int64_t, 4> l{};
    const std::array<std::pair<std::int64_t, std::int64_t>, 4> at = {
        std::pair{rect.x0, rect.y0}, {rect.x1, rect.y0}, {rect.x0, rect.y1}, {rect.x1, rect.y1}};
    for (std::size_t i = 0; i < 4; ++i) {
        const CraterTerms terms = f.craterTerms(at[i].first, at[i].second);
        a[i] = (terms.inside ? terms.target : f.plane48(at[i].first, at[i].second)) - rect.z[i];
        l[i] = terms.inside ? terms.limit : 0;
    }
    const std::int64_t share = f.ground().ejecta_share;
    std::int64_t scale16 = scale_l * kOne; // the -L term
    std::int64_t gap16 = 0;                // 1/48 quanta, 16.16
    // weight (16.16) x (B = A + k L)+, with `b_hi` a bound on B over the rectangle
    auto term = [&](std::int64_t weight, std::int64_t b_hi, int k) {
        if (weight == 0 || b_hi <= 0)
            return;
        scale16 += weight * (scale_a + (k != 0 ? scale_l : 0));
        std::int64_t p = 0;
        std::int64_t n = 0;
        for (std::size_t i = 0; i < 4; ++i) {
            const std::int64_t v = a[i] + k * l[i];
            p = std::max(p, v);
            n = std::max(n, -v);
        }
        gap16 += weight * std::min(p, n);
    };
    term(kOne, b.a_hi + b.limit_hi, 1);
    term(kOne - share, b.a_hi, 0);
    term(share, b.a_hi - b.limit_lo, -1);
    // the corners' terms are the fixed-point ones: a quantum more for them (each time)
    std::int64_t corner_quanta = 1;
    if (ceiling) {
        std::int64_t p = 0;
        std::int64_t n = 0;
        for (std::size_t i = 0; i < 4; ++i) {
            const std::int64_t c = f.ceiling48(rect.original[i]) - rect.z[i];
            if (c < 0)
                return false;
            // the unclamped change at the corner, as PointwiseOp::height has it
            const std::int64_t change =
                a[i] < 0 ? -std::min(-a[i], l[i]) : (std::min(a[i], l[i]) * share) >> 16;
            p = std::max(p, change - c);
            n = std::max(n, c - change);
        }
        scale16 *= 2;
        gap16 = 2 * gap16 + kOne * std::min(p, n);
        corner_quanta = 2;
    }
    const std::int64_t gap = ceilDiv(ceilDiv(gap16, kOne), kFineScale) + corner_quanta;
    if (gap >= room)
        return false;
    const auto side48 = static_cast<std::uint64_t>(rect.x1 - rect.x0);
    const std::int64_t r48 = std::int64_t{op.radius} * kFineScale;
    return productLessEqual(
        static_cast<std::uint64_t>(ceilDiv(scale16, kOne)), side48 * side48,
        static_cast<std::uint64_t>(2 * r48 * r48), static_cast<std::uint64_t>(room - gap));
}

// A crater over a rectangle: with A = S - z, the change is -limit (A <= -limit), A (-limit <=
// A <= 0), share * A (0 <= A <= limit) or share * limit (A >= limit). Wherever the bounds below
// put the whole rectangle in one of these regimes, the change is the old (linear) surface's plus
// a smooth term, and that term's curvature bound decides: it misses its linear interpolation
// over the rectangle's triangles (legs `side`) by at most M side^2 / 4 <= room. The bounds are
// exact for the fixed-point terms: t, the relief and the limit are monotone in the distance on
// each side of the rim, and the plane and the old triangles take their extremes at the corners.
bool craterRectFits(const PointwiseOp& f, const Rect48& rect, std::int64_t room) {
    const DeformOp& op = f.op();
    const std::int64_t r = op.radius;
    const std::int64_t cap48 = (2 * r + 1) * kFineScale;
    const std::int64_t ox = op.center_x * kFineScale;
    const std::int64_t oy = op.center_y * kFineScale;
    const std::int64_t fx = std::min(cap48, std::max(absI64(rect.x0 - ox), absI64(rect.x1 - ox)));
    const std::int64_t fy = std::min(cap48, std::max(absI64(rect.y0 - oy), absI64(rect.y1 - oy)));
    constexpr std::int64_t kOne = kUnitStrength;
    // capped like squaredDistance48: a capped side is beyond the footprint either way, and the
    // square cannot overflow at the largest spacing
    const std::int64_t nx = std::min(cap48, absI64(std::clamp(ox, rect.x0, rect.x1) - ox));
    const std::int64_t ny = std::min(cap48, absI64(std::clamp(oy, rect.y0, rect.y1) - oy));
    const std::int64_t near2 = nx * nx + ny * ny;
    const std::int64_t r48 = r * kFineScale;
    if (near2 >= 4 * r48 * r48)
        return true; // beyond the footprint
    const std::int64_t t_lo = f.ratio(near2);
    const std::int64_t t_hi = std::min(2 * kOne, f.ratio(fx * fx + fy * fy));
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
    const std::array<std::int64_t, 4> d = {
        f.plane48(rect.x0, rect.y0) - rect.z[0], f.plane48(rect.x1, rect.y0) - rect.z[1],
        f.plane48(rect.x0, rect.y1) - rect.z[2], f.plane48(rect.x1, rect.y1) - rect.z[3]};
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
    // M side^2 / 4 <= room with side^2 = side48^2 / 48^2: scale side48^2 <= 2 r^2 48^2 room
    const auto side48 = static_cast<std::uint64_t>(rect.x1 - rect.x0);
    const std::uint64_t side2 = side48 * side48; // up to 2^63.2 at the largest spacing
    const auto r2 = static_cast<std::uint64_t>(2 * r48 * r48);
    const auto uroom = static_cast<std::uint64_t>(room);
    // The relief: M = 2 (depth + rim) / r^2 in the bowl, 2 rim / r^2 beyond the rim (never
    // across it: the crease). A term a (1 - r^2 / 4R^2)^2 (the anchor, the limit): M <= 2 |a| /
    // r^2. Scaling by the share (<= 1) only lowers them.
    auto reliefFits = [&] {
        if (crosses_rim)
            return false;
        const std::int64_t scale = (t_hi <= kOne ? depth + rim + 1 : rim + 1) + anchor;
        return productLessEqual(static_cast<std::uint64_t>(scale), side2, r2, uroom);
    };
    auto limitFits = [&] {
        return productLessEqual(static_cast<std::uint64_t>(depth + rim + 1), side2, r2, uroom);
    };
    // the floor and the ceiling must not bind anywhere in the rectangle (their clamps are
    // further regime boundaries): displacement z - original is linear on each piece, so its
    // extremes are at the corners
    const std::array<std::int64_t, 4> disp = {
        rect.z[0] - rect.original[0], rect.z[1] - rect.original[1], rect.z[2] - rect.original[2],
        rect.z[3] - rect.original[3]};
    const std::int64_t disp_lo = *std::min_element(disp.begin(), disp.end());
    const std::int64_t disp_hi = *std::max_element(disp.begin(), disp.end());
    // z' >= z - carve >= original + disp_lo - carve_hi >= floor, the carve being min(-A,
    // limit) where A < 0; z' <= z + fill <= ceiling, the fill share * min(A, limit) (rounded
    // down)
    const std::int64_t carve_hi = std::min(limit_hi, std::max<std::int64_t>(0, -a_lo));
    if (disp_lo - carve_hi < f.floor48(0))
        return false;
    const std::int64_t fill_hi =
        (std::max<std::int64_t>(0, std::min(limit_hi, a_hi)) * f.ground().ejecta_share) >> 16;
    if (disp_hi + fill_hi > f.ceiling48(0)) // a kink more
        return kinkFits(f, rect, room, {a_lo, a_hi, limit_lo, limit_hi, t_hi, crosses_rim}, true);
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
    return kinkFits(f, rect, room, {a_lo, a_hi, limit_lo, limit_hi, t_hi, crosses_rim}, false);
}

// The fixed-point profile's slack (quanta): 16.16 radius ratio and tapers, about 3 (|height| +
// rim + |anchor|) / 2^16 at a point, twice that through an interpolation between points (16
// leaves a margin), and the rounding of the corner samples.
std::int64_t profileSlack(const PointwiseOp& f) {
    const DeformOp& op = f.op();
    const std::int64_t rim_bound = op.kind == OpKind::kCrater
                                       ? ceilDiv(f.rim48(), kFineScale)
                                       : absI64((std::int64_t{op.height} * op.strength) >> 16);
    const std::int64_t anchor_bound = ceilDiv(absI64(f.ground().anchor48), kFineScale);
    return 2 + ceilDiv(16 * (2 * absI64(op.height) + rim_bound + anchor_bound), 65536);
}

// |change| <= limit <= depth + rim everywhere, and so is any interpolation of it
bool craterSmallEverywhere(const PointwiseOp& f, std::int64_t room) {
    const std::int64_t rim_bound = ceilDiv(f.rim48(), kFineScale);
    return 2 * (absI64(f.op().height) + rim_bound + 1) <= room;
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
    const std::int64_t slack = profileSlack(f);
    if (tolerance <= slack)
        return false;
    const std::int64_t room = tolerance - slack;
    const std::int64_t r = op.radius;
    const auto h2 = static_cast<std::uint64_t>(h * h);
    if (op.kind == OpKind::kCrater) {
        if (craterSmallEverywhere(f, room))
            return true;
        const std::int64_t h48 = h * kFineScale;
        Rect48 cell;
        cell.x0 = cx * h48;
        cell.y0 = cy * h48;
        cell.x1 = cell.x0 + h48;
        cell.y1 = cell.y0 + h48;
        cell.z = {
            co.h00 * kFineScale, co.h10 * kFineScale, co.h01 * kFineScale, co.h11 * kFineScale};
        cell.original = {
            oc.h00 * kFineScale, oc.h10 * kFineScale, oc.h01 * kFineScale, oc.h11 * kFineScale};
        return craterRectFits(f, cell, room);
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

namespace {

// What the exhaustive check asks at one grid point: the op's change there minus the base
// triangles' change (the linear interpolation of the corners' change), in 1/48 quanta.
struct CellCheck {
    const PointwiseOp& f;
    std::int32_t cx, cy;
    CellCorners co, delta, oc;
    Diagonal d;
    std::int64_t h48, step48;
    static constexpr std::int64_t kTo48 = kFineScale / kGridSteps;

    static CellCheck make(
        const PointwiseOp& f,
        std::int32_t cx,
        std::int32_t cy,
        const CellCorners& co,
        const CellCorners& cn,
        const CellCorners& oc,
        std::int64_t h) {
        return {
            f,
            cx,
            cy,
            co,
            {cn.h00 - co.h00, cn.h10 - co.h10, cn.h01 - co.h01, cn.h11 - co.h11},
            oc,
            cellDiagonal(cx, cy),
            h * kFineScale,
            h * (kFineScale / kGridSteps)};
    }

    std::int64_t old48(int k, int l) const {
        return kTo48 * baseHeightScaled(co, d, k, l, kGridSteps);
    }
    std::int64_t original48(int k, int l) const {
        return kTo48 * baseHeightScaled(oc, d, k, l, kGridSteps);
    }
    std::int64_t error48(int k, int l) const {
        const std::int64_t old = old48(k, l);
        const std::int64_t next =
            f.height(cx * h48 + k * step48, cy * h48 + l * step48, old, original48(k, l));
        return absI64(next - old - kTo48 * baseHeightScaled(delta, d, k, l, kGridSteps));
    }
};

} // namespace

bool baseCellNeedsPatchEveryPoint(
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
    const CellCheck check = CellCheck::make(f, cx, cy, co, cn, oc, h);
    // coarse to fine, so that a cell which needs a patch is usually found within a few points
    for (const GridPoint& p : coarseToFine())
        if (check.error48(p.k, p.l) > tolerance * kFineScale)
            return true;
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
    const DeformOp& op = f.op();
    const std::int64_t slack = profileSlack(f);
    if (op.kind != OpKind::kCrater || tolerance <= slack)
        return baseCellNeedsPatchEveryPoint(f, cx, cy, co, cn, oc, h, tolerance);
    // The same answer as every point, from fewer: the cell in aligned squares (8 steps, then 4),
    // each skipped when craterRectFits() proves that no point inside it can fail, given the
    // errors measured at its corners (the interpolation between them is bounded by the largest:
    // room = tolerance - slack - that). Points where a regime boundary or the rim crease runs
    // are evaluated one by one, as before. Squares stay on one side of the cell's diagonal or are
    // halved by it, so the surfaces are linear on their triangles.
    const CellCheck check = CellCheck::make(f, cx, cy, co, cn, oc, h);
    const std::int64_t limit48 = tolerance * kFineScale;
    std::array<std::int64_t, kPatchGridVertices> error{};
    std::array<bool, kPatchGridVertices> known{};
    // false when the point fails (the cell needs a patch)
    auto measure = [&](int k, int l) {
        const auto i = static_cast<std::size_t>(l * kGridSamples + k);
        if (!known[i]) {
            error[i] = check.error48(k, l);
            known[i] = true;
        }
        return error[i] <= limit48;
    };
    // the square [k0, k0 + n] x [l0, l0 + n], its corners measured: proven to fit?
    auto proven = [&](int k0, int l0, int n) {
        const int k1 = k0 + n;
        const int l1 = l0 + n;
        std::int64_t corner = 0;
        for (const auto& [k, l] : {std::pair{k0, l0}, {k1, l0}, {k0, l1}, {k1, l1}})
            corner = std::max(corner, error[static_cast<std::size_t>(l * kGridSamples + k)]);
        const std::int64_t room = tolerance - slack - ceilDiv(corner, kFineScale);
        if (room <= 0)
            return false;
        if (craterSmallEverywhere(f, room))
            return true;
        Rect48 rect;
        rect.x0 = cx * check.h48 + k0 * check.step48;
        rect.y0 = cy * check.h48 + l0 * check.step48;
        rect.x1 = cx * check.h48 + k1 * check.step48;
        rect.y1 = cy * check.h48 + l1 * check.step48;
        int c = 0;
        for (const auto& [k, l] : {std::pair{k0, l0}, {k1, l0}, {k0, l1}, {k1, l1}}) {
            rect.z[static_cast<std::size_t>(c)] = check.old48(k, l);
            rect.original[static_cast<std::size_t>(c++)] = check.original48(k, l);
        }
        return craterRectFits(f, rect, room);
    };
    // every point of the square, stride `s`; false when one fails
    auto measureAll = [&](int k0, int l0, int n, int s) {
        for (int l = l0; l <= l0 + n; l += s)
            for (int k = k0; k <= k0 + n; k += s)
                if (!measure(k, l))
                    return false;
        return true;
    };
    constexpr int kHalf = kGridSteps / 2;
    constexpr int kQuarter = kGridSteps / 4;
    if (!measureAll(0, 0, kGridSteps, kHalf))
        return true;
    for (int l0 = 0; l0 < kGridSteps; l0 += kHalf)
        for (int k0 = 0; k0 < kGridSteps; k0 += kHalf) {
            if (proven(k0, l0, kHalf))
                continue;
            if (!measureAll(k0, l0, kHalf, kQuarter))
                return true;
            for (int l1 = l0; l1 < l0 + kHalf; l1 += kQuarter)
                for (int k1 = k0; k1 < k0 + kHalf; k1 += kQuarter)
                    if (!proven(k1, l1, kQuarter) && !measureAll(k1, l1, kQuarter, 1))
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
