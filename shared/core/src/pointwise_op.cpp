#include <terrain/pointwise_op.h>
#include <terrain/terrain.h>

#include <algorithm>
#include <array>

namespace terrain {
namespace {

constexpr std::int64_t kOne = kUnitStrength; // 1.0 in 16.16

// cos(2 pi k / 16) * 2^14, rounded: the survey's sample directions (constants, so that every
// platform samples the same points)
constexpr std::int64_t kTrigScale = 1 << 14;
constexpr std::array<std::int64_t, kRingSamples> kCos = {
    16384,  15137,  11585,  6270,  0, -6270, -11585, -15137,
    -16384, -15137, -11585, -6270, 0, 6270,  11585,  15137};
constexpr std::int64_t sinAt(int k) {
    return kCos[static_cast<std::size_t>((k + 12) % kRingSamples)];
}

} // namespace

std::int64_t squaredDistance48(const DeformOp& op, std::int64_t x48, std::int64_t y48) {
    const std::int64_t cap = 2 * std::int64_t{op.radius} * kFineScale + 1;
    const std::int64_t dx = std::min(absI64(x48 - op.center_x * kFineScale), cap);
    const std::int64_t dy = std::min(absI64(y48 - op.center_y * kFineScale), cap);
    return dx * dx + dy * dy;
}

std::int64_t radiusRatio(const DeformOp& op, std::int64_t r2) {
    const std::int64_t radius48 = std::int64_t{op.radius} * kFineScale;
    return static_cast<std::int64_t>(isqrt(static_cast<std::uint64_t>(r2)) << 16) / radius48;
}

std::int64_t fadeWeight(const DeformOp& op, std::int64_t x48, std::int64_t y48) {
    const std::int64_t radius48 = std::int64_t{op.radius} * kFineScale;
    const std::int64_t r2 = squaredDistance48(op, x48, y48);
    if (r2 >= radius48 * radius48)
        return 0;
    const std::int64_t t = radiusRatio(op, r2);
    const std::int64_t w = kOne - ((t * t) >> 16);
    return (w * w) >> 16;
}

namespace {

// the cell and lattice point (k, l) of the 1/16-cell lattice nearest to (x, y) quanta
struct LatticePoint {
    std::int32_t cx = 0;
    std::int32_t cy = 0;
    int k = 0;
    int l = 0;
};

LatticePoint nearestLatticePoint(const WorldSpec& spec, std::int64_t x, std::int64_t y) {
    const std::int64_t h = spec.spacing;
    const std::int64_t lx = std::clamp<std::int64_t>(
        roundDiv(bspline::kGridSteps * x, h), 0, std::int64_t{bspline::kGridSteps} * spec.cellsX());
    const std::int64_t ly = std::clamp<std::int64_t>(
        roundDiv(bspline::kGridSteps * y, h), 0, std::int64_t{bspline::kGridSteps} * spec.cellsY());
    LatticePoint p;
    p.cx = static_cast<std::int32_t>(
        std::min<std::int64_t>(lx / bspline::kGridSteps, spec.cellsX() - 1));
    p.cy = static_cast<std::int32_t>(
        std::min<std::int64_t>(ly / bspline::kGridSteps, spec.cellsY() - 1));
    p.k = static_cast<int>(lx - std::int64_t{p.cx} * bspline::kGridSteps);
    p.l = static_cast<int>(ly - std::int64_t{p.cy} * bspline::kGridSteps);
    return p;
}

} // namespace

std::int64_t latticeHeight48(const Terrain& t, std::int64_t x, std::int64_t y) {
    const LatticePoint p = nearestLatticePoint(t.spec(), x, y);
    if (const DetailPatch* patch = t.findPatch(p.cx, p.cy))
        return roundDiv(kFineScale * gridNumerator(*patch, p.k, p.l), kGridDenominator);
    return (kFineScale / bspline::kGridSteps) *
           baseHeightScaled(
               t.corners(p.cx, p.cy), cellDiagonal(p.cx, p.cy), p.k, p.l, bspline::kGridSteps);
}

std::int64_t latticeOriginal48(const Terrain& t, std::int64_t x, std::int64_t y) {
    const LatticePoint p = nearestLatticePoint(t.spec(), x, y);
    return (kFineScale / bspline::kGridSteps) * baseHeightScaled(
                                                    t.originalCorners(p.cx, p.cy),
                                                    cellDiagonal(p.cx, p.cy), p.k, p.l,
                                                    bspline::kGridSteps);
}

BlastGround surveyGround(const Terrain& t, const DeformOp& op) {
    BlastGround g;
    // the plane through the circle at 2R: its mean, and the first Fourier terms as the tilt
    const std::int64_t rho = 2 * std::int64_t{op.radius};
    std::int64_t sum = 0;
    std::int64_t gx = 0;
    std::int64_t gy = 0;
    g.ring_min48 = INT64_MAX;
    g.ring_max48 = INT64_MIN;
    for (int k = 0; k < kRingSamples; ++k) {
        const std::int64_t z = latticeHeight48(
            t, op.center_x + roundDiv(rho * kCos[static_cast<std::size_t>(k)], kTrigScale),
            op.center_y + roundDiv(rho * sinAt(k), kTrigScale));
        sum += z;
        gx += z * kCos[static_cast<std::size_t>(k)];
        gy += z * sinAt(k);
        g.ring_min48 = std::min(g.ring_min48, z);
        g.ring_max48 = std::max(g.ring_max48, z);
    }
    g.level48 = floorDiv(sum, kRingSamples);
    // slope = (2 / N) sum z cos / rho; in 16.16 with the 2^14 table that is sum / (2 rho)
    const std::int64_t rho48 = rho * kFineScale;
    g.slope_x = floorDiv(gx, 2 * rho48);
    g.slope_y = floorDiv(gy, 2 * rho48);
    // keep the plane within the ring's range over the footprint: a single high sample tilts
    // the plane a little, it cannot lift the far side above the highest ground
    const std::int64_t allowed = std::min(g.ring_max48 - g.level48, g.level48 - g.ring_min48);
    const std::int64_t reach = ((absI64(g.slope_x) + absI64(g.slope_y)) * rho48) >> 16;
    if (reach > allowed) {
        const std::int64_t f = (allowed << 16) / reach;
        g.slope_x = (g.slope_x * f) / kOne;
        g.slope_y = (g.slope_y * f) / kOne;
    }
    // the anchor: the bowl hangs from the ground where the shot struck, blending into the plane
    // by 2R, so a hit in a valley digs into the valley floor and one on a knoll into the knoll.
    // What ops have dug there since the world began counts softly, d K D / (K D + |d|): hits on
    // one spot dig a depth, then 2/3, 1/4, ... of it, and settle two depths under the original
    // ground (which the floor enforces for every point)
    const std::int64_t depth48 = std::int64_t{op.height} * kFineScale;
    const std::int64_t here = latticeHeight48(t, op.center_x, op.center_y);
    const std::int64_t original = latticeOriginal48(t, op.center_x, op.center_y);
    const std::int64_t dug = here - original;
    const std::int64_t reach48 = kAnchorDepths * depth48;
    const std::int64_t share = (reach48 << 16) / (reach48 + absI64(dug)); // K D / (K D + |d|)
    g.anchor48 = (original - g.level48) + (dug < 0 ? -((-dug * share) >> 16) : (dug * share) >> 16);

    // the ejecta: what the blast carves against the room there is to fill, sampled on rings
    // t = 1/8, 3/8, .. 15/8 over the footprint and weighted by t (the area each stands for)
    struct Sample {
        std::int64_t x48, y48, z48, original48, weight;
    };
    std::array<Sample, kSurveyRings * kRingSamples> samples{};
    for (int i = 0; i < kSurveyRings; ++i)
        for (int k = 0; k < kRingSamples; ++k) {
            const std::int64_t weight = 2 * i + 1;
            const std::int64_t x = op.center_x + roundDiv(
                                                     std::int64_t{op.radius} * weight *
                                                         kCos[static_cast<std::size_t>(k)],
                                                     kSurveyRings * kTrigScale);
            const std::int64_t y =
                op.center_y +
                roundDiv(std::int64_t{op.radius} * weight * sinAt(k), kSurveyRings * kTrigScale);
            samples[static_cast<std::size_t>(i * kRingSamples + k)] = {
                x * kFineScale, y * kFineScale, latticeHeight48(t, x, y),
                latticeOriginal48(t, x, y), weight};
        }
    struct Balance {
        std::int64_t carved = 0;  // above the profile, within the limit
        std::int64_t room = 0;    // below it, within the limit
        std::int64_t nominal = 0; // carved - room on flat ground (the plane): the crater's own
    };
    auto balance = [&](std::int32_t growth) {
        BlastGround trial = g;
        trial.rim_growth = growth;
        const PointwiseOp f(op, trial);
        Balance b;
        for (const Sample& s : samples) {
            const CraterTerms terms = f.craterTerms(s.x48, s.y48);
            const std::int64_t gap = terms.target - s.z48;
            // within the limit, above the floor and below the ceiling
            const std::int64_t cut = std::min(
                std::clamp<std::int64_t>(-gap, 0, terms.limit),
                std::max<std::int64_t>(0, s.z48 - f.floor48(s.original48)));
            const std::int64_t fill = std::min(
                std::clamp<std::int64_t>(gap, 0, terms.limit),
                std::max<std::int64_t>(0, f.ceiling48(s.original48) - s.z48));
            b.carved += s.weight * cut;
            b.room += s.weight * fill;
            b.nominal += s.weight * std::clamp(-terms.relief, -terms.limit, terms.limit);
        }
        return b;
    };
    // Every blast keeps the volume balance its profile has on flat ground (bowl against rim:
    // with a rim of 0.375 x depth they match): one that carves more (a hit on high ground)
    // raises its rim, up to kMaxRimGrowth, to hold the excess; one that carves less (a hit in a
    // hole) scales every fill down
    const Balance b = balance(0);
    const std::int64_t target = b.nominal;
    if (b.carved - b.room > target && op.strength > 0) {
        std::int32_t lo = 0;
        std::int32_t hi = kMaxRimGrowth;
        if (const Balance top = balance(hi); top.carved - top.room > target) {
            lo = hi;
        } else {
            for (int step = 0; step < 10; ++step) {
                const std::int32_t mid = lo + (hi - lo) / 2;
                const Balance m = balance(mid);
                (m.carved - m.room > target ? lo : hi) = mid;
            }
            lo = hi;
        }
        g.rim_growth = lo;
    } else if (b.carved - b.room < target && b.room > 0) {
        const std::int64_t fill = std::max<std::int64_t>(0, b.carved - target);
        g.ejecta_share = static_cast<std::int32_t>((fill << 16) / b.room);
    }
    return g;
}

PointwiseOp::PointwiseOp(const DeformOp& op, const BlastGround& ground)
    : op_(op), ground_(ground), radius48_(std::int64_t{op.radius} * kFineScale) {
    if (radius48_ > 0)
        ratio_per_root_ = 65536.0 / static_cast<double>(radius48_);
    if (op.kind == OpKind::kCrater) {
        depth48_ = std::int64_t{op.height} * kFineScale;
        rim48_ = (((depth48_ * op.strength) >> 16) * (kOne + ground.rim_growth)) >> 16;
    }
}

PointwiseOp::PointwiseOp(const DeformOp& op, const Terrain& before)
    : PointwiseOp(op, op.kind == OpKind::kCrater ? surveyGround(before, op) : BlastGround{}) {}

std::int64_t PointwiseOp::relief48(std::int64_t t) const {
    if (t >= 2 * kOne)
        return 0;
    if (t < kOne) // the bowl: a paraboloid from -depth at the centre to +rim at R
        return -depth48_ + (((depth48_ + rim48_) * ((t * t) >> 16)) >> 16);
    const std::int64_t u = 2 * kOne - t; // the rim falling to 0 with zero slope at 2R
    return (rim48_ * ((u * u) >> 16)) >> 16;
}

std::int64_t PointwiseOp::taper(std::int64_t t) {
    if (t >= 2 * kOne)
        return 0;
    const std::int64_t w = kOne - ((t * t) >> 18);
    return (w * w) >> 16;
}

std::int64_t PointwiseOp::limit48(std::int64_t t) const {
    // (depth + rim) (1 - t^2 / 4)^2: the crater's full height at the centre, tapering with zero
    // slope to 0 at 2R; on flat ground it never binds (the profile is reached everywhere)
    return ((depth48_ + rim48_) * taper(t)) >> 16;
}

std::int64_t PointwiseOp::anchor48(std::int64_t t) const {
    return (ground_.anchor48 * taper(t)) >> 16;
}

std::int64_t PointwiseOp::plane48(std::int64_t x48, std::int64_t y48) const {
    return ground_.level48 + floorDiv(
                                 ground_.slope_x * (x48 - op_.center_x * kFineScale) +
                                     ground_.slope_y * (y48 - op_.center_y * kFineScale),
                                 kOne);
}

std::int64_t PointwiseOp::ratio(std::int64_t r2) const {
    // floor(a / R) from a double estimate: within 2^-50 of a / R relative, and every ratio used
    // is below 2^19, so it is off by one at most; the integer checks make it exact
    const auto root = static_cast<std::int64_t>(isqrt(static_cast<std::uint64_t>(r2)));
    const std::int64_t a = root << 16;
    auto q = static_cast<std::int64_t>(static_cast<double>(root) * ratio_per_root_);
    while (q > 0 && q * radius48_ > a)
        --q;
    while ((q + 1) * radius48_ <= a)
        ++q;
    return q;
}

CraterTerms PointwiseOp::craterTerms(std::int64_t x48, std::int64_t y48) const {
    CraterTerms c;
    const std::int64_t radius48 = std::int64_t{op_.radius} * kFineScale;
    const std::int64_t r2 = squaredDistance48(op_, x48, y48);
    if (r2 >= 4 * radius48 * radius48)
        return c;
    c.inside = true;
    c.ratio = ratio(r2);
    c.relief = relief48(c.ratio);
    // anchor48() and limit48() with the taper computed once (this runs for every point of
    // every footprint)
    const std::int64_t w = taper(c.ratio);
    c.target = plane48(x48, y48) + ((ground_.anchor48 * w) >> 16) + c.relief;
    c.limit = ((depth48_ + rim48_) * w) >> 16;
    return c;
}

std::int64_t PointwiseOp::height(
    std::int64_t x48, std::int64_t y48, std::int64_t z48, std::int64_t original48) const {
    switch (op_.kind) {
    case OpKind::kCrater: {
        const CraterTerms c = craterTerms(x48, y48);
        if (!c.inside)
            return z48;
        const std::int64_t gap = c.target - z48;
        const std::int64_t next =
            gap < 0 ? z48 - std::min(-gap, c.limit)
                    : z48 + ((std::min(gap, c.limit) * ground_.ejecta_share) >> 16);
        // never below the floor nor above the ceiling (ground already beyond them stays)
        return std::clamp(
            next, std::min(z48, floor48(original48)), std::max(z48, ceiling48(original48)));
    }
    case OpKind::kRaise: {
        const std::int64_t radius48 = std::int64_t{op_.radius} * kFineScale;
        const std::int64_t r2 = squaredDistance48(op_, x48, y48);
        if (r2 >= radius48 * radius48)
            return z48;
        const std::int64_t t = ratio(r2);
        const std::int64_t w = kOne - ((t * t) >> 16);
        return z48 + ((std::int64_t{op_.height} * kFineScale * ((w * w) >> 16)) >> 16);
    }
    case OpKind::kFlatten: {
        // a blend towards the target by a weight in [0, 1]: never past it
        const std::int64_t a = (fadeWeight(op_, x48, y48) * op_.strength) >> 16;
        const std::int64_t target48 = std::int64_t{op_.height} * kFineScale;
        return z48 + (((target48 - z48) * a) >> 16);
    }
    case OpKind::kSmooth:
        break; // not pointwise; see deformation.cpp
    }
    return z48;
}

} // namespace terrain
