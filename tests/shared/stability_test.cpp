// The stability suite: craters under repetition and feedback, where additive craters grew needles.
// Battles come from the core's BattleGenerator (rays from moving cameras cast against the surface
// the earlier shots left); the figures from tests/support/battle_checks.h. Every bound below is
// stated in ARCHITECTURE.md ("The crater model") and fails the test when it breaks. Sanitizer
// builds fire a fifth of the shots (the same code paths, in a fifth of the time).

#include "support/battle_checks.h"
#include "support/surface_checks.h"
#include "support/terrain_builders.h"
#include "support/thread_bits.h"

#include <terrain/battle.h>
#include <terrain/io/dem_import.h>
#include <terrain/pointwise_op.h>
#include <terrain/procedural_map.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#ifndef TERRAIN_SANITIZED
#define TERRAIN_SANITIZED 0
#endif

namespace terrain {
namespace {

namespace fs = std::filesystem;

int shots(int n) {
    return TERRAIN_SANITIZED ? n / 5 : n;
}

// The bounds every battle must hold (figures as battle_checks.h measures them).
void expectBattleBounds(const testing::BattleFigures& f, const BattleOptions& o, double spacing) {
    // no point ever stands higher above its own original ground than twice the largest nominal
    // rim of the battle (rim ratio x depth ratio x radius: the ceiling), nor lower than two of
    // its largest depths (the floor); and no patch rises above the ground around it by more
    const double rim = o.max_rim_ratio * o.max_depth_ratio * o.max_radius;
    const double depth = o.max_depth_ratio * o.max_radius;
    const double quantum = 1.0 / 1024;
    EXPECT_LE(f.max_rise_own_m, 2 * rim + quantum) << "a point rose above the ceiling";
    EXPECT_LE(f.max_patch_rise_m, 2 * rim + spacing / 32) << "a patch rose above the ceiling";
    EXPECT_LE(f.deepest_m, 2 * depth + quantum) << "a point sank below the floor";
    // no needles: a vertex more than one grid step above all eight neighbours
    EXPECT_EQ(f.needles, 0) << "tallest spike " << f.tallest_spike_m << " m";
    // no wall steeper than the ground had, or than 5 (79 degrees: a crater's wall on a slope)
    EXPECT_LE(f.max_slope, std::max(f.max_slope_before, 5.0));
    EXPECT_EQ(f.refused, 0);
}

void expectSoundState(const Terrain& t) {
    const Status s = t.checkInvariants();
    EXPECT_TRUE(s.ok()) << s.error().message;
    testing::expectWatertight(t);
    EXPECT_EQ(testing::freshHash(t), t.worldHash());
}

// ---- one op at a time ---------------------------------------------------------------------

TEST(CraterModel, hitsOnOneSpotDigLessEachTimeAndConverge) {
    Terrain t = testing::makeHills(5, 129, 129);
    const DeformOp op = *quantizeOp({OpKind::kCrater, 64.3, 63.7, 4.0, 2.0, 0.3}, t.spec());
    const double depth = 2.0;
    const double plane = surveyGround(t, op).level48 / 48.0 / 1024.0;
    std::vector<double> dug;
    for (int i = 0; i < 40; ++i) {
        const double before = surfaceHeight(t, 64.3, 63.7);
        ASSERT_TRUE(t.apply(op).ok());
        dug.push_back(before - surfaceHeight(t, 64.3, 63.7));
    }
    for (std::size_t i = 1; i < dug.size(); ++i)
        EXPECT_LE(dug[i], dug[i - 1] + 1e-3) << "hit " << i << " dug more than the one before";
    EXPECT_LT(dug.back(), 0.01 * depth);
    // at most 2 depths under the ground around it (the plane through the circle at 2R, which
    // the rim's last taper moves by a few centimetres)
    EXPECT_GE(surfaceHeight(t, 64.3, 63.7), plane - 2.0 * depth - 0.05);
    expectSoundState(t);
}

TEST(CraterModel, noPointRisesAboveItsOriginalGroundAndTheRimNorSinksBelowTheFloor) {
    Terrain t = testing::makeHills(9, 150, 140);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int n = 0; n < 300; ++n) {
        // clustered, so that later craters land on earlier ones
        OpRequest r{OpKind::kCrater, 60 + 30 * unit(rng), 60 + 30 * unit(rng), 1 + 7 * unit(rng)};
        r.height = r.radius * (0.2 + 0.8 * unit(rng));
        r.strength = unit(rng);
        const DeformOp op = *quantizeOp(r, t.spec());
        const PointwiseOp f(op, t);
        // the rim grows to at most twice its nominal height
        EXPECT_LE(f.rim48(), 2 * ((std::int64_t{op.height} * 48 * op.strength) >> 16) + 2);
        const std::vector<std::int32_t> before(t.paddedSamples().begin(), t.paddedSamples().end());
        ASSERT_TRUE(t.apply(op).ok());
        const std::int32_t w = t.spec().paddedWidth();
        for (std::size_t i = 0; i < before.size(); ++i) {
            const auto x = static_cast<std::int32_t>(i % static_cast<std::size_t>(w));
            const auto y = static_cast<std::int32_t>(i / static_cast<std::size_t>(w));
            const std::int64_t now48 = std::int64_t{t.paddedSamples()[i]} * 48;
            const std::int64_t was48 = std::int64_t{before[i]} * 48;
            const std::int64_t original48 = std::int64_t{t.original(x, y)} * 48;
            // one quantum of rounding either way
            ASSERT_LE(now48, std::max(was48, f.ceiling48(original48)) + 48)
                << describe(op, t.spec());
            ASSERT_GE(now48, std::min(was48, f.floor48(original48)) - 48) << describe(op, t.spec());
            // and no point moves by more than the limit at the centre: depth + rim
            ASSERT_LE(std::abs(now48 - was48), op.height * 48 + f.rim48() + 48);
        }
    }
    expectSoundState(t);
}

TEST(CraterModel, aCrestBehindAFlankShotIsCutNotRaised) {
    // a ridge along y at x = 64, flanks of slope 0.6; shots on the near flank, the crest at 1.3 R
    WorldSpec spec;
    spec.width = spec.height = 129;
    std::vector<std::int32_t> z(129 * 129);
    for (int y = 0; y < 129; ++y)
        for (int x = 0; x < 129; ++x)
            z[static_cast<std::size_t>(y * 129 + x)] =
                static_cast<std::int32_t>((40.0 - 0.6 * std::abs(x - 64)) * 1024);
    Terrain t = std::move(*Terrain::create(spec, z));
    for (int i = 0; i < 12; ++i) {
        const double y = 30.0 + 6.0 * i;
        ASSERT_TRUE(t.apply(*quantizeOp({OpKind::kCrater, 64 - 1.3 * 4, y, 4, 2, 0.4}, spec)).ok());
    }
    for (int y = 0; y < 129; ++y)
        EXPECT_LE(t.sample(64, y), z[static_cast<std::size_t>(y * 129 + 64)]) << "crest at y " << y;
    expectSoundState(t);
}

TEST(CraterModel, aShotIntoASixtyDegreeWallCutsANotch) {
    // flat at 0 up to x = 60, a 60 degree wall to x = 80, a plateau at 34.6 m
    WorldSpec spec;
    spec.width = spec.height = 129;
    const double tan60 = std::sqrt(3.0);
    std::vector<std::int32_t> z(129 * 129);
    for (int y = 0; y < 129; ++y)
        for (int x = 0; x < 129; ++x)
            z[static_cast<std::size_t>(y * 129 + x)] =
                static_cast<std::int32_t>(std::clamp(x - 60.0, 0.0, 20.0) * tan60 * 1024);
    Terrain t = std::move(*Terrain::create(spec, z));
    testing::BattleWatch watch(t, 10.0);
    for (int i = 0; i < 5; ++i) {
        const DeformOp op = *quantizeOp({OpKind::kCrater, 70.0, 50.0 + 0.3 * i, 5, 3, 0.375}, spec);
        auto e = t.apply(op);
        ASSERT_TRUE(e.ok());
        watch.observe(t, *e);
    }
    const testing::BattleFigures f = watch.figures(t, 1.0, 70, 50);
    EXPECT_GT(f.deepest_m, 1.0);                       // a notch was cut into the wall
    EXPECT_LE(f.max_rise_m, 0.01);                     // nothing rose above the plateau's edge
    EXPECT_LE(f.max_rise_own_m, 2 * 0.375 * 3 + 0.01); // nor by more than the grown rim
    EXPECT_EQ(f.needles, 0);
    EXPECT_LE(f.max_slope, std::max(f.max_slope_before, 5.0));
    expectSoundState(t);
}

TEST(CraterModel, theSmallestAndLargestRadiiHoldTheirBounds) {
    Terrain t = testing::makeHills(13, 300, 300);
    const RadiusRange rr = radiusRange(t.spec());
    for (const std::int32_t radius : {rr.min, rr.min * 3, rr.max / 2, rr.max}) {
        DeformOp op{OpKind::kCrater, 150 * 1024 + 333, 149 * 1024 + 77,
                    radius,          radius / 2,       kUnitStrength * 3 / 10};
        if (op.height < 1)
            op.height = 1;
        const PointwiseOp f(op, t);
        const std::vector<std::int32_t> before(t.paddedSamples().begin(), t.paddedSamples().end());
        ASSERT_TRUE(t.apply(op).ok()) << describe(op, t.spec());
        for (std::size_t i = 0; i < before.size(); ++i)
            ASSERT_LE(
                std::abs(t.paddedSamples()[i] - before[i]) * std::int64_t{48},
                op.height * 48 + f.rim48() + 48);
    }
    expectSoundState(t);
}

// ---- battles --------------------------------------------------------------------------------

BattleOptions battleAt(double x, double y, std::uint64_t seed) {
    BattleOptions o;
    o.seed = seed;
    o.zone_x = x;
    o.zone_y = y;
    return o;
}

TEST(Stability, tenThousandShotsOnTheDefaultMapHoldEveryBound) {
    Terrain t = std::move(*makeProceduralMap({}));
    const BattleOptions o = battleAt(512, 512, 1);
    BattleGenerator generator(o);
    testing::BattleWatch watch(t, 2 * o.max_radius);
    testing::BattleFigures counts = testing::runBattle(t, generator, shots(10000), watch);
    testing::BattleFigures f = watch.figures(t, 1.0, o.zone_x, o.zone_y);
    f.refused = counts.refused;
    expectBattleBounds(f, o, 1.0);
    EXPECT_EQ(counts.craters + counts.missed, shots(10000));
    EXPECT_GT(counts.craters, shots(10000) * 9 / 10);
    std::printf(
        "default map, %d shots: rise %.2f m above the original ground (%.2f above the highest "
        "near it, patches %.2f), deepest %.2f m, spike %.2f m, slope %.2f (before %.2f), "
        "patches %zu\n",
        counts.shots, f.max_rise_own_m, f.max_rise_m, f.max_patch_rise_m, f.deepest_m,
        f.tallest_spike_m, f.max_slope, f.max_slope_before, f.patches);
    expectSoundState(t);
}

TEST(Stability, repeatedHitsOnOnePointConverge) {
    // one camera, one pixel: each ray lands on what the last crater left (first the ground, then
    // the far wall, then the floor)
    for (const auto& [range, altitude] : {std::pair{60.0, 30.0}, {100.0, 3.0}}) {
        Terrain t = std::move(*makeProceduralMap({.width = 257, .height = 257}));
        BattleOptions o = battleAt(128, 128, 2);
        o.zone_radius = 0;
        o.players = 1;
        o.orbit_degrees_per_shot = 0;
        o.follow_share = 0;
        o.min_range = o.max_range = range;
        o.min_altitude = o.max_altitude = altitude;
        o.min_radius = o.max_radius = 4;
        o.min_depth_ratio = o.max_depth_ratio = 0.5;
        o.min_rim_ratio = o.max_rim_ratio = 0.3;
        BattleGenerator generator(o);
        testing::BattleWatch watch(t, 8);
        const int n = shots(1000);
        testing::runBattle(t, generator, n / 2, watch);
        const double half = watch.figures(t, 1.0, 128, 128).deepest_m;
        testing::runBattle(t, generator, n - n / 2, watch);
        const testing::BattleFigures f = watch.figures(t, 1.0, 128, 128);
        EXPECT_NEAR(f.deepest_m, half, 0.05) << "still digging after " << n / 2 << " hits";
        // the hit point walks into the hole as it forms; the hole settles on the floor, two
        // depths under the original ground
        EXPECT_LE(f.deepest_m, 2 * 2.0 + 1.0 / 1024) << "below the floor";
        EXPECT_EQ(f.needles, 0);
        expectSoundState(t);
    }
}

TEST(Stability, cornersEdgesAndTileSeamsHoldEveryBound) {
    Terrain t = testing::makeHills(17, 200, 200);
    const double e = t.spec().extentX();
    int round = 0;
    for (const auto& [x, y] :
         {std::pair{0.0, 0.0}, {e, e}, {e, 100.0}, {100.0, 0.0}, {64.0, 64.0}, {128.0, 100.0}}) {
        BattleOptions o = battleAt(x, y, 40 + static_cast<std::uint64_t>(round++));
        o.zone_radius = 12;
        o.max_range = 60;
        BattleGenerator generator(o);
        testing::BattleWatch watch(t, 2 * o.max_radius);
        testing::BattleFigures counts = testing::runBattle(t, generator, shots(500), watch);
        testing::BattleFigures f = watch.figures(t, 1.0, x, y);
        f.refused = counts.refused;
        expectBattleBounds(f, o, 1.0);
    }
    expectSoundState(t);
}

TEST(Stability, patchesStayInTheZoneAndStopGrowingOnceItIsSaturated) {
    // steep shots from close by: every crater lands in the zone
    Terrain t = std::move(*makeProceduralMap({.width = 257, .height = 257}));
    BattleOptions o = battleAt(128, 128, 3);
    o.zone_radius = 20;
    o.min_range = 5;
    o.max_range = 15;
    o.min_altitude = 40;
    o.max_altitude = 60;
    BattleGenerator generator(o);
    testing::BattleWatch watch(t, 2 * o.max_radius);
    testing::runBattle(t, generator, shots(3000), watch);
    const std::size_t half = t.patchCount();
    testing::runBattle(t, generator, shots(3000), watch);
    const testing::BattleFigures f = watch.figures(t, 1.0, 128, 128);
    // within the zone, its spread and a footprint: never more cells than that disc holds, and
    // the second half of the battle adds a small fraction of what the first made
    const double reach = o.zone_radius + o.follow_spread + 2 * o.max_radius + 2.0;
    EXPECT_LE(f.patch_extent_m, reach);
    EXPECT_LE(static_cast<double>(t.patchCount()), 3.1416 * reach * reach);
    EXPECT_LE(t.patchCount(), half + half / 5)
        << "patches keep growing: " << half << " -> " << t.patchCount();
    expectBattleBounds(f, o, 1.0);
    expectSoundState(t);
}

// The steepest spot of a DEM: the vertex whose 5 x 5 neighbourhood has the largest mean slope.
std::pair<double, double> steepestSpot(const Terrain& t) {
    const WorldSpec& s = t.spec();
    double best = -1.0;
    std::pair<double, double> at{0, 0};
    for (std::int32_t y = 8; y < s.height - 8; y += 4)
        for (std::int32_t x = 8; x < s.width - 8; x += 4) {
            double sum = 0.0;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx)
                    sum += std::abs(t.sample(x + dx + 1, y + dy) - t.sample(x + dx, y + dy)) +
                           std::abs(t.sample(x + dx, y + dy + 1) - t.sample(x + dx, y + dy));
            if (sum > best) {
                best = sum;
                at = {x * s.spacingMetres(), y * s.spacingMetres()};
            }
        }
    return at;
}

TEST(Stability, barragesOnSteepRealReliefHoldEveryBound) {
    const fs::path dir = TERRAIN_DEM_DIR;
    if (!fs::exists(dir))
        GTEST_SKIP() << "no DEMs at " << dir << " (../shared/data/dem beside the repo)";
    int ran = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (!entry.is_directory())
            continue;
        const std::string name = entry.path().filename().string();
        io::DemImportOptions options;
        if (name == "gcanyon_hoppe_1200") {
            options.spacing_metres = 40.0; // the source states none; its notes suggest 30-45 m
            options.vertical_scale = 8.0;  // and 7-10 m per grey level
        }
        auto dem = io::importDem(entry.path(), options);
        ASSERT_TRUE(dem.ok()) << name << ": " << dem.error().message;
        Terrain& t = dem->terrain;
        const double h = t.spec().spacingMetres();
        const auto [x, y] = steepestSpot(t);
        // the battle at the grid's scale: craters of 1.5 - 6 cells, the zone 10 cells across
        BattleOptions o = battleAt(x, y, 7);
        o.zone_radius = 10 * h;
        o.min_range = 5 * h;
        o.max_range = 60 * h;
        o.min_altitude = 2 * h;
        o.max_altitude = 40 * h;
        o.follow_spread = 3 * h;
        o.min_radius = 1.5 * h;
        o.max_radius = 6 * h;
        BattleGenerator generator(o);
        testing::BattleWatch watch(t, 2 * o.max_radius);
        const Terrain before = t;
        std::vector<std::pair<DeformOp, std::uint64_t>> applied;
        testing::BattleFigures counts =
            testing::runBattle(t, generator, shots(2000), watch, &applied);
        testing::BattleFigures f = watch.figures(t, h, x, y);
        f.refused = counts.refused;
        SCOPED_TRACE(name);
        // the same bits whatever runs the op's tiles and cells (Terrain::apply's runner)
        for (unsigned threads : {2u, 8u})
            testing::expectSameBitsWithThreads(before, applied, t, threads);
        expectBattleBounds(f, o, h);
        std::printf(
            "%s (%.1f m cells) at (%.0f, %.0f) m: rise %.1f m (%.1f above the highest near it), "
            "deepest %.1f m, spike %.1f m, slope %.2f (before %.2f), patches %zu\n",
            name.c_str(), h, x, y, f.max_rise_own_m, f.max_rise_m, f.deepest_m, f.tallest_spike_m,
            f.max_slope, f.max_slope_before, f.patches);
        EXPECT_TRUE(t.checkInvariants().ok());
        EXPECT_EQ(testing::freshHash(t), t.worldHash());
        ++ran;
    }
    EXPECT_GE(ran, 6);
}

// ---- the other kinds under repetition -------------------------------------------------------

TEST(OtherKinds, smoothConvergesAndNeverWidensTheRange) {
    Terrain t = testing::makeHills(21, 129, 129);
    testing::applyAll(
        t, {{OpKind::kCrater, 64, 64, 6, 3, 0.4}, {OpKind::kCrater, 70, 60, 4, 2, 0.4}});
    const DeformOp op = *quantizeOp({OpKind::kSmooth, 66, 62, 14, 0, 1.0}, t.spec());
    auto range = [&] { // of the footprint and the ring of neighbours it averages with
        std::int32_t lo = INT32_MAX;
        std::int32_t hi = INT32_MIN;
        for (std::int32_t y = 62 - 15; y <= 62 + 15; ++y)
            for (std::int32_t x = 66 - 15; x <= 66 + 15; ++x) {
                lo = std::min(lo, t.sample(x, y));
                hi = std::max(hi, t.sample(x, y));
            }
        return std::pair{lo, hi};
    };
    auto [lo, hi] = range();
    int last_change = 0;
    for (int i = 0; i < 1000; ++i) { // not scaled: convergence needs them all
        const std::vector<std::int32_t> before(t.paddedSamples().begin(), t.paddedSamples().end());
        ASSERT_TRUE(t.apply(op).ok());
        const auto [nlo, nhi] = range();
        ASSERT_GE(nlo, lo) << "smoothing lowered the minimum";
        ASSERT_LE(nhi, hi) << "smoothing raised the maximum";
        lo = nlo;
        hi = nhi;
        last_change = 0;
        for (std::size_t k = 0; k < before.size(); ++k)
            last_change = std::max(last_change, std::abs(t.paddedSamples()[k] - before[k]));
    }
    EXPECT_LE(last_change, 1) << "smoothing still moves vertices by more than a quantum";
    expectSoundState(t);
}

TEST(OtherKinds, flattenNeverOvershootsItsTarget) {
    Terrain t = testing::makeHills(23, 129, 129);
    testing::applyAll(t, {{OpKind::kCrater, 64, 64, 6, 3, 0.4}});
    const double target = surfaceHeight(t, 64, 64) + 1.0;
    const DeformOp op = *quantizeOp({OpKind::kFlatten, 64, 64, 10, target, 0.7}, t.spec());
    const std::vector<std::int32_t> start(t.paddedSamples().begin(), t.paddedSamples().end());
    for (int i = 0; i < 60; ++i) {
        ASSERT_TRUE(t.apply(op).ok());
        for (std::size_t k = 0; k < start.size(); ++k) {
            const std::int32_t now = t.paddedSamples()[k];
            // between where it started and the target, never past it
            ASSERT_LE(now, std::max(start[k], op.height));
            ASSERT_GE(now, std::min(start[k], op.height));
        }
    }
    // patch surfaces: within the tolerance of the target's side
    const double tol = t.spec().patch_tolerance * t.spec().metresPerUnit();
    for (double y = 56; y <= 72; y += 0.25)
        for (double x = 56; x <= 72; x += 0.25)
            if (std::hypot(x - 64, y - 64) < 2) {
                EXPECT_NEAR(surfaceHeight(t, x, y), target, tol + 1e-3);
            }
    expectSoundState(t);
}

TEST(OtherKinds, raiseMovesEachPointByAtMostItsHeight) {
    Terrain t = testing::makeHills(29, 129, 129);
    const DeformOp op = *quantizeOp({OpKind::kRaise, 64, 64, 8, 1.5, 1.0}, t.spec());
    for (int i = 0; i < 20; ++i) {
        const std::vector<std::int32_t> before(t.paddedSamples().begin(), t.paddedSamples().end());
        ASSERT_TRUE(t.apply(op).ok());
        for (std::size_t k = 0; k < before.size(); ++k) {
            ASSERT_GE(t.paddedSamples()[k], before[k]);
            ASSERT_LE(t.paddedSamples()[k] - before[k], op.height + 1);
        }
    }
    expectSoundState(t);
}

} // namespace
} // namespace terrain
