#include "support/surface_checks.h"
#include "support/terrain_builders.h"

#include <terrain/battle.h>
#include <terrain/deform_op.h>
#include <terrain/patch_decision.h>
#include <terrain/pointwise_op.h>
#include <terrain/surface_query.h>
#include <terrain/terrain.h>

#include <gtest/gtest.h>

#include <random>

namespace terrain {
namespace {

Result<OpEffect> applyRequest(Terrain& t, const OpRequest& r) {
    auto op = quantizeOp(r, t.spec());
    if (!op)
        return op.error();
    return t.apply(*op);
}

TEST(Deformation, smallCraterOnOneMetreGridGetsPatchesOnlyNearIt) {
    Terrain t = testing::makeFlat(129, 129);
    auto e = applyRequest(t, {OpKind::kCrater, 40.3, 50.7, 3.0, 1.2, 0.25});
    ASSERT_TRUE(e.ok());
    EXPECT_GT(t.patchCount(), 0u);
    // every patch lies within the crater's footprint (2R) plus one cell
    for (std::int32_t tile = 0; tile < t.spec().tileCount(); ++tile)
        for (const PatchEntry& p : t.tilePatches(tile)) {
            const double cx = (tile % t.spec().tilesX()) * 64 + p.cell % 64 + 0.5;
            const double cy = (tile / t.spec().tilesX()) * 64 + p.cell / 64 + 0.5;
            EXPECT_LT(std::hypot(cx - 40.3, cy - 50.7), 6.0 + 1.5);
        }
    EXPECT_EQ(e->patches_created, static_cast<int>(t.patchCount()));
    EXPECT_EQ(e->dirty_tiles, (std::vector<std::int32_t>{0}));
}

TEST(Deformation, broadGentleRaiseIsHeldByTheGridWithoutPatches) {
    // a 40 m mound of 1 m on a 1 m grid: curvature far below the tolerance
    Terrain t = testing::makeFlat(129, 129);
    auto e = applyRequest(t, {OpKind::kRaise, 64, 64, 40, 1.0, 1});
    ASSERT_TRUE(e.ok());
    EXPECT_GT(e->vertices_changed, 1000);
    EXPECT_EQ(t.patchCount(), 0u);
    EXPECT_EQ(t.memoryUsage().patch_bytes, 0u); // unchanged cells cost nothing beyond the grid
}

TEST(Deformation, surfaceFollowsTheAnalyticCraterWithinTheTolerance) {
    // the same crater with a loose and two tight tolerances: away from the cells that the rim
    // crease crosses (no C2 patch follows a crease inside a cell) the represented surface is within
    // the tolerance of the analytic crater, and tighter tolerances buy more patches
    std::size_t previous_patches = 0;
    for (double tol : {0.5, 1.0 / 32.0, 1.0 / 128.0}) {
        WorldSpec spec;
        spec.width = spec.height = 65;
        spec.patch_tolerance = static_cast<std::int32_t>(tol * 1024);
        std::vector<std::int32_t> flat(65 * 65, 10 * 1024);
        Terrain tt = std::move(*Terrain::create(spec, flat));
        ASSERT_TRUE(applyRequest(tt, {OpKind::kCrater, 30.5, 30.5, 4.0, 1.6, 0.25}).ok());
        double worst = 0.0;
        for (double y = 21.5; y <= 39.5; y += 1.0 / 16)
            for (double x = 21.5; x <= 39.5; x += 1.0 / 16) {
                const double r = std::hypot(x - 30.5, y - 30.5);
                if (std::abs(r - 4.0) <= 1.5)
                    continue;
                const double t = r / 4.0;
                const double expect =
                    10.0 + (t < 1 ? -1.6 + 2.0 * t * t : (t < 2 ? 0.4 * (2 - t) * (2 - t) : 0.0));
                worst = std::max(worst, std::abs(surfaceHeight(tt, x, y) - expect));
            }
        EXPECT_LE(worst, tol * 1.1 + 0.001) << "tolerance " << tol;
        if (tol == 0.5)
            EXPECT_EQ(tt.patchCount(), 0u);
        else
            EXPECT_GT(tt.patchCount(), previous_patches);
        previous_patches = tt.patchCount();
    }
}

TEST(Deformation, smoothingAndFlatteningRemovePatchesAgain) {
    Terrain t = testing::makeFlat(129, 129);
    ASSERT_TRUE(applyRequest(t, {OpKind::kCrater, 60, 60, 3.0, 1.2, 0.25}).ok());
    const std::size_t created = t.patchCount();
    ASSERT_GT(created, 0u);
    int removed = 0;
    for (int i = 0; i < 30 && t.patchCount() > 0; ++i) {
        auto e = applyRequest(t, {OpKind::kSmooth, 60, 60, 9.0, 0, 1.0});
        ASSERT_TRUE(e.ok());
        removed += e->patches_removed;
    }
    EXPECT_LT(t.patchCount(), created);
    EXPECT_GT(removed, 0);
    testing::expectWatertight(t);

    auto f = applyRequest(t, {OpKind::kFlatten, 60, 60, 12.0, 10.0, 1.0});
    ASSERT_TRUE(f.ok());
    auto g = applyRequest(t, {OpKind::kFlatten, 60, 60, 12.0, 10.0, 1.0});
    ASSERT_TRUE(g.ok());
    EXPECT_EQ(t.patchCount(), 0u) << "a flattened area needs no patches";
    EXPECT_NEAR(surfaceHeight(t, 60, 60), 10.0, 1e-3);
}

TEST(Deformation, onlyTouchedTilesChangeTheirHash) {
    Terrain t = testing::makeHills(21, 300, 300);
    std::vector<std::uint64_t> before;
    for (std::int32_t i = 0; i < t.spec().tileCount(); ++i)
        before.push_back(t.tileHash(i));
    // a crater on the seam between tiles (1,1) and (2,1) of a 5 x 5 tile grid
    auto e = applyRequest(t, {OpKind::kCrater, 128.2, 100, 2.5, 1.0, 0.3});
    ASSERT_TRUE(e.ok());
    for (std::int32_t i = 0; i < t.spec().tileCount(); ++i) {
        const bool dirty = std::binary_search(e->dirty_tiles.begin(), e->dirty_tiles.end(), i);
        EXPECT_EQ(t.tileHash(i) != before[static_cast<std::size_t>(i)], dirty) << "tile " << i;
    }
    EXPECT_EQ(e->dirty_tiles, (std::vector<std::int32_t>{6, 7})); // 5 tiles per row
    EXPECT_EQ(testing::freshHash(t), t.worldHash());
}

TEST(Deformation, theChangedCellsCoverEveryCellWhoseSurfaceChanged) {
    // OpEffect::cells is what a client re-derives after an op (detail blocks, bounds): a cell
    // whose patch changed outside it (border enforcement straightens or drops patches one ring
    // past the footprint) would be drawn stale. Shots of a battle, each compared cell by cell.
    Terrain t = testing::makeHills(5, 160, 160);
    BattleOptions o;
    o.seed = 3;
    o.zone_x = 80;
    o.zone_y = 80;
    BattleGenerator generator(o);
    int outside_footprint = 0;
    for (int shot = 0; shot < 150; ++shot) {
        const BattleShot s = generator.next(t);
        if (!s.crater)
            continue;
        const Terrain before = t;
        auto e = applyRequest(t, *s.crater);
        ASSERT_TRUE(e.ok()) << e.error().message;
        for (std::int32_t cy = 0; cy < t.spec().cellsY(); ++cy)
            for (std::int32_t cx = 0; cx < t.spec().cellsX(); ++cx) {
                const DetailPatch* a = before.findPatch(cx, cy);
                const DetailPatch* b = t.findPatch(cx, cy);
                const CellCorners ca = before.corners(cx, cy);
                const CellCorners cb = t.corners(cx, cy);
                const bool changed = (a == nullptr) != (b == nullptr) ||
                                     (a != nullptr && a->control != b->control) ||
                                     ca.h00 != cb.h00 || ca.h10 != cb.h10 || ca.h01 != cb.h01 ||
                                     ca.h11 != cb.h11;
                if (!changed)
                    continue;
                const CellRect& r = e->cells;
                EXPECT_TRUE(cx >= r.x0 && cx <= r.x1 && cy >= r.y0 && cy <= r.y1)
                    << "shot " << shot << ": cell " << cx << ", " << cy << " changed outside "
                    << r.x0 << ".." << r.x1 << " x " << r.y0 << ".." << r.y1;
                // the cells meeting the footprint's box, as apply() finds them
                const DeformOp op = quantizeOp(*s.crater, t.spec()).value();
                const std::int64_t reach = footprintRadius(op);
                const std::int64_t h = t.spec().spacing;
                const bool in_box =
                    cx >= (op.center_x - reach) / h && cx <= (op.center_x + reach) / h &&
                    cy >= (op.center_y - reach) / h && cy <= (op.center_y + reach) / h;
                outside_footprint += in_box ? 0 : 1;
            }
    }
    EXPECT_GT(outside_footprint, 0) << "the battle must reach the ring past the footprint";
}

TEST(Deformation, incrementalHashEqualsRecomputedHashAfterManyOps) {
    Terrain t = testing::makeHills(22);
    CraterSeries s;
    s.seed = 3;
    s.count = 150;
    testing::applyAll(t, randomCraters(t.spec(), s));
    for (std::int32_t tile = 0; tile < t.spec().tileCount(); ++tile)
        EXPECT_EQ(t.tileHash(tile), t.computeTileHash(tile)) << tile;
    EXPECT_EQ(t.computeWorldHash(), t.worldHash());
    EXPECT_EQ(testing::freshHash(t), t.worldHash());
}

TEST(Deformation, opOnACoarseGridNeedsPatchesOnlyWhenTheToleranceAsksForThem) {
    // 30 m DEM-like spacing, a 400 m mound of 30 m: linear interpolation on the grid misses it by
    // at most M h^2 / 4 = (8 * 30 / 400^2) * 30^2 / 4 = 0.34 m
    for (double tol : {1.0, 0.1}) {
        WorldSpec spec;
        spec.width = spec.height = 129;
        spec.spacing = 30 * 1024;
        spec.patch_tolerance = static_cast<std::int32_t>(tol * 1024);
        std::vector<std::int32_t> flat(129 * 129, 500 * 1024);
        Terrain t = std::move(*Terrain::create(spec, flat));
        ASSERT_TRUE(applyRequest(t, {OpKind::kRaise, 1900, 1900, 400, 30, 1}).ok());
        if (tol == 1.0)
            EXPECT_EQ(t.patchCount(), 0u);
        else
            EXPECT_GT(t.patchCount(), 0u);
    }
}

TEST(Deformation, opsAtMapCornersAndEdgesClipAndStayValid) {
    Terrain t = testing::makeHills(23);
    const double ex = t.spec().extentX();
    const double ey = t.spec().extentY();
    for (auto [x, y] :
         {std::pair{0.0, 0.0}, {ex, 0.0}, {0.0, ey}, {ex, ey}, {ex / 2, 0.0}, {0.0, ey / 2}}) {
        auto e = applyRequest(t, {OpKind::kCrater, x, y, 4.0, 1.5, 0.3});
        ASSERT_TRUE(e.ok()) << e.error().message;
        EXPECT_GT(e->vertices_changed, 0);
    }
    EXPECT_TRUE(t.checkInvariants().ok());
    testing::expectWatertight(t);
    EXPECT_EQ(testing::freshHash(t), t.worldHash());
}

} // namespace
} // namespace terrain

namespace terrain {
namespace {

// A base cell's corners after a pointwise op, as Terrain::apply computes them.
CellCorners cornersAfter(const PointwiseOp& f, const Terrain& t, std::int32_t cx, std::int32_t cy) {
    const std::int64_t h = t.spec().spacing;
    auto moved = [&](std::int32_t x, std::int32_t y) {
        return clampHeight(roundDiv(
            f.height(
                x * h * 48, y * h * 48, std::int64_t{t.sample(x, y)} * 48,
                std::int64_t{t.original(x, y)} * 48),
            48));
    };
    return {moved(cx, cy), moved(cx + 1, cy), moved(cx, cy + 1), moved(cx + 1, cy + 1)};
}

// The prefilter may only skip cells that the exhaustive 289-point check would also leave
// without a patch; it must also actually skip cells on a broad crater.
TEST(PatchDecision, curvaturePrefilterNeverSkipsACellThatNeedsAPatch) {
    std::mt19937 rng(77);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    Terrain t = testing::makeHills(61, 130, 130);
    const WorldSpec& spec = t.spec();
    // half the ground already cratered: the regimes, the floor and the ceiling all come into play
    CraterSeries earlier;
    earlier.seed = 9;
    earlier.count = 80;
    earlier.min_radius = 2;
    earlier.max_radius = 8;
    earlier.depth_ratio = 0.6;
    earlier.rim_ratio = 0.4;
    testing::applyAll(t, randomCraters(spec, earlier));
    int skipped = 0;
    int needed = 0;
    for (int n = 0; n < 400; ++n) {
        const bool crater = n % 2 == 0;
        OpRequest r{
            crater ? OpKind::kCrater : OpKind::kRaise,
            20 + unit(rng) * 90,
            20 + unit(rng) * 90,
            0.5 + unit(rng) * 24,
            0.0,
            crater ? unit(rng) * 0.5 : 1.0};
        r.height = crater ? r.radius * (0.05 + 0.5 * unit(rng)) : (unit(rng) - 0.5) * r.radius;
        if (std::abs(r.height) < 0.01)
            r.height = 0.05;
        const DeformOp op = *quantizeOp(r, spec);
        const PointwiseOp f(op, t);
        const std::int64_t tol = 4 + static_cast<std::int64_t>(unit(rng) * 200);
        const std::int64_t h = spec.spacing;
        for (int k = 0; k < 12; ++k) {
            const std::int32_t cx = static_cast<std::int32_t>(
                (op.center_x / h) + (unit(rng) - 0.5) * 2.2 * op.radius / h);
            const std::int32_t cy = static_cast<std::int32_t>(
                (op.center_y / h) + (unit(rng) - 0.5) * 2.2 * op.radius / h);
            if (cx < 0 || cy < 0 || cx >= spec.cellsX() || cy >= spec.cellsY())
                continue;
            if (t.findPatch(cx, cy) != nullptr)
                continue; // the prefilter is for base cells
            const CellCorners co = t.corners(cx, cy);
            const CellCorners oc = t.originalCorners(cx, cy);
            const CellCorners cn = cornersAfter(f, t, cx, cy);
            const bool exhaustive = baseCellNeedsPatchExhaustive(f, cx, cy, co, cn, oc, h, tol);
            needed += exhaustive;
            if (curvatureFitsTolerance(f, cx, cy, co, oc, h, tol)) {
                ++skipped;
                EXPECT_FALSE(exhaustive)
                    << describe(op, spec) << " cell " << cx << "," << cy << " tol " << tol;
            }
        }
    }
    EXPECT_GT(skipped, 500);
    EXPECT_GT(needed, 200);
}

// The square-by-square exhaustive check must give the answer of all 289 points on every cell:
// rough ground, half of it cratered (regimes, rims, floors and ceilings cross cells), craters of
// every size, tight and loose tolerances, the default one included. The same answer keeps every
// world hash (the golden tests guard that too); here the decision itself is compared.
TEST(PatchDecision, squaresGiveTheAnswerOfEveryPoint) {
    std::mt19937 rng(91);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    Terrain t = testing::makeHills(17, 130, 130);
    const WorldSpec& spec = t.spec();
    CraterSeries earlier;
    earlier.seed = 4;
    earlier.count = 120;
    earlier.min_radius = 1;
    earlier.max_radius = 10;
    earlier.depth_ratio = 0.5;
    earlier.rim_ratio = 0.4;
    testing::applyAll(t, randomCraters(spec, earlier));
    int needed = 0;
    int fits = 0;
    for (int n = 0; n < 300; ++n) {
        OpRequest r{
            OpKind::kCrater, 15 + unit(rng) * 100, 15 + unit(rng) * 100, 0.6 + unit(rng) * 20, 0.0,
            unit(rng) * 0.6};
        r.height = r.radius * (0.05 + 0.6 * unit(rng));
        const DeformOp op = *quantizeOp(r, spec);
        const PointwiseOp f(op, t);
        const std::int64_t tol =
            n % 3 == 0 ? spec.patch_tolerance : 2 + static_cast<std::int64_t>(unit(rng) * 300);
        const std::int64_t h = spec.spacing;
        for (int k = 0; k < 20; ++k) {
            const std::int32_t cx = static_cast<std::int32_t>(
                (op.center_x / h) + (unit(rng) - 0.5) * 4.4 * op.radius / h);
            const std::int32_t cy = static_cast<std::int32_t>(
                (op.center_y / h) + (unit(rng) - 0.5) * 4.4 * op.radius / h);
            if (cx < 0 || cy < 0 || cx >= spec.cellsX() || cy >= spec.cellsY())
                continue;
            const CellCorners co = t.corners(cx, cy);
            const CellCorners oc = t.originalCorners(cx, cy);
            const CellCorners cn = cornersAfter(f, t, cx, cy);
            const bool every = baseCellNeedsPatchEveryPoint(f, cx, cy, co, cn, oc, h, tol);
            ASSERT_EQ(baseCellNeedsPatchExhaustive(f, cx, cy, co, cn, oc, h, tol), every)
                << describe(op, spec) << " cell " << cx << "," << cy << " tol " << tol;
            (every ? needed : fits) += 1;
        }
    }
    // both answers, many times each
    EXPECT_GT(needed, 500);
    EXPECT_GT(fits, 1500);
}

} // namespace
} // namespace terrain

namespace terrain {
namespace {

// Regression: on a valid 10 km grid at 4096 units per metre, a maximum-radius crater used to
// overflow the squared distance at far Greville points and write a -1.8 km control.
TEST(Deformation, largeSpacingAndMaximumRadiusStayInRange) {
    WorldSpec s;
    s.width = s.height = 257;
    s.units_per_metre = 4096;
    s.spacing = 4096 * 10000;
    s.patch_tolerance = 128;
    ASSERT_TRUE(s.validate().ok());
    Terrain t = std::move(*Terrain::create(s, std::vector<std::int32_t>(257 * 257, 0)));
    const std::int64_t h = s.spacing;
    DeformOp op;
    op.kind = OpKind::kCrater;
    op.radius = radiusRange(s).max;
    op.height = 100 * 4096;
    op.strength = kUnitStrength / 4;
    op.center_x = 2 * h - 2 * std::int64_t{op.radius} + 1;
    op.center_y = h + 1;
    ASSERT_TRUE(t.apply(op).ok());
    // the bowl's floor, and the rim at most twice its nominal height
    const std::int64_t lo = -std::int64_t{op.height} - 4096;
    const std::int64_t hi = op.height / 2 + 4096;
    for (std::int32_t tile = 0; tile < s.tileCount(); ++tile)
        for (const PatchEntry& e : t.tilePatches(tile))
            for (std::int32_t c : e.patch.control) {
                EXPECT_GE(c, lo * kControlScale);
                EXPECT_LE(c, hi * kControlScale);
            }
    for (std::int32_t v : t.paddedSamples()) {
        EXPECT_GE(v, lo);
        EXPECT_LE(v, hi);
    }
    EXPECT_TRUE(t.checkInvariants().ok());
}

TEST(WorldSpecRules, spacingThatWouldEmptyTheRadiusRangeIsRefused) {
    WorldSpec s;
    s.width = s.height = 65;
    s.units_per_metre = 65536;
    s.spacing = 300'000'000; // 4.6 km, but beyond 2^26 quanta
    const Status st = s.validate();
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(st.error().message.find("spacing"), std::string::npos);
    s.spacing = 1 << 26;
    ASSERT_TRUE(s.validate().ok());
    const RadiusRange rr = radiusRange(s);
    EXPECT_LE(rr.min, rr.max);
}

// Regression: 16.16 profile errors grow with depth; the prefilter's slack must follow.
// The footprint loops compute a crater's radius ratio from a double estimate corrected in
// integers (no 64-bit division); it must be radiusRatio's exact value for every radius and
// distance, above all where (isqrt(r2) << 16) / R is an integer or just below one.
TEST(PointwiseOp, radiusRatioWithoutDivisionIsExact) {
    std::mt19937_64 rng(21);
    // up to the largest radius any world allows (radiusRange: 2^23 quanta)
    std::vector<std::int32_t> radii = {1, 2, 3, 47, 1024, 1536, 65535, 65536, 1 << 20, 1 << 23};
    for (int n = 0; n < 40; ++n)
        radii.push_back(static_cast<std::int32_t>(1 + rng() % (1 << 23)));
    int checked = 0;
    for (const std::int32_t radius : radii) {
        DeformOp op;
        op.center_x = 7;
        op.center_y = 11;
        op.radius = radius;
        op.height = 1;
        const PointwiseOp f(op, BlastGround{});
        const std::int64_t r48 = std::int64_t{radius} * kFineScale;
        auto check = [&](std::int64_t dx, std::int64_t dy) {
            const std::int64_t x48 = op.center_x * kFineScale + dx;
            const std::int64_t y48 = op.center_y * kFineScale + dy;
            const std::int64_t r2 = squaredDistance48(op, x48, y48);
            if (r2 >= 4 * r48 * r48)
                return;
            ASSERT_EQ(f.craterTerms(x48, y48).ratio, radiusRatio(op, r2))
                << "radius " << radius << ", offset " << dx << ", " << dy;
            ++checked;
        };
        for (int k = 0; k < 400; ++k) {
            // roots where the ratio m / 2^16 is met exactly or missed by one unit
            const std::int64_t m = static_cast<std::int64_t>(rng() % (2 * 65536));
            const std::int64_t root = (m * r48 + 65535) / 65536;
            for (std::int64_t s : {root - 1, root, root + 1})
                if (s >= 0) {
                    check(s, 0);
                    check(-s, 1); // r2 = s^2 + 1: the same root, just past it
                }
            check(
                static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(2 * r48)),
                static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(r48)));
        }
    }
    EXPECT_GT(checked, 40000);
}

TEST(PatchDecision, prefilterHoldsForDeepWideCraters) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    // a 0.4 m tolerance: deep craters carry a large fixed-point slack, so at the default 3 cm the
    // prefilter (correctly) never skips them and the exhaustive check runs
    WorldSpec flat_spec;
    flat_spec.width = flat_spec.height = 400;
    flat_spec.patch_tolerance = 400;
    const Terrain t =
        std::move(*Terrain::create(flat_spec, std::vector<std::int32_t>(400 * 400, 10 * 1024)));
    const WorldSpec& spec = t.spec();
    const std::int64_t h = spec.spacing;
    int skipped = 0;
    for (int n = 0; n < 40; ++n) {
        // deep: up to the radius (the most a crater may be)
        OpRequest r{
            OpKind::kCrater, 150 + unit(rng) * 100, 150 + unit(rng) * 100, 64 + unit(rng) * 64, 0.0,
            unit(rng) * 0.5};
        r.height = r.radius * (0.5 + 0.5 * unit(rng));
        const DeformOp op = *quantizeOp(r, spec);
        const PointwiseOp f(op, t);
        for (int k = 0; k < 60; ++k) {
            const std::int32_t cx = static_cast<std::int32_t>(
                op.center_x / h + (unit(rng) - 0.5) * 3.8 * op.radius / h);
            const std::int32_t cy = static_cast<std::int32_t>(
                op.center_y / h + (unit(rng) - 0.5) * 3.8 * op.radius / h);
            if (cx < 0 || cy < 0 || cx >= spec.cellsX() || cy >= spec.cellsY())
                continue;
            const CellCorners co = t.corners(cx, cy);
            const CellCorners cn = cornersAfter(f, t, cx, cy);
            if (curvatureFitsTolerance(f, cx, cy, co, co, h, spec.patch_tolerance)) {
                ++skipped;
                EXPECT_FALSE(
                    baseCellNeedsPatchExhaustive(f, cx, cy, co, cn, co, h, spec.patch_tolerance))
                    << describe(op, spec) << " cell " << cx << "," << cy;
            }
        }
    }
    EXPECT_GT(skipped, 100);
}

} // namespace
} // namespace terrain
