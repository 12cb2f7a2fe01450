// Property test: thousands of random ops, biased towards the places where cracks come from
// (tile seams, map corners and edges, overlapping craters), must leave a watertight surface.

#include "support/surface_checks.h"
#include "support/terrain_builders.h"

#include <gtest/gtest.h>

#include <random>

namespace terrain {
namespace {

OpRequest randomOp(std::mt19937& rng, const WorldSpec& spec) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double ex = spec.extentX();
    const double ey = spec.extentY();
    const double h = spec.spacingMetres();
    OpRequest r;
    const double where = unit(rng);
    if (where < 0.3) { // on a tile seam, within a cell of it
        const double seam =
            kTileCells * h * (1 + static_cast<int>(unit(rng) * (spec.tilesX() - 1)));
        r.x = std::min(ex, seam + (unit(rng) - 0.5) * 2 * h);
        r.y = unit(rng) * ey;
        if (unit(rng) < 0.5)
            std::swap(r.x, r.y), r.x = std::min(r.x, ex), r.y = std::min(r.y, ey);
    } else if (where < 0.4) { // a map corner
        r.x = unit(rng) < 0.5 ? unit(rng) * h : ex - unit(rng) * h;
        r.y = unit(rng) < 0.5 ? unit(rng) * h : ey - unit(rng) * h;
    } else if (where < 0.5) { // a map edge
        r.x = unit(rng) * ex;
        r.y = unit(rng) < 0.5 ? 0.0 : ey;
    } else { // a cluster in one small area, so craters overlap
        r.x = 40.0 + unit(rng) * 25.0;
        r.y = 50.0 + unit(rng) * 25.0;
    }
    const double kind = unit(rng);
    r.radius = 0.3 + unit(rng) * 6.0;
    if (kind < 0.7) {
        r.kind = OpKind::kCrater;
        r.height = std::min(r.radius, 0.1 + unit(rng) * 2.0); // at most as deep as wide
        r.strength = unit(rng) * 0.5;
    } else if (kind < 0.8) {
        r.kind = OpKind::kRaise;
        r.height = (unit(rng) - 0.5) * 3.0;
        if (std::abs(r.height) < 0.01)
            r.height = 0.5;
    } else if (kind < 0.9) {
        r.kind = OpKind::kFlatten;
        r.height = 5.0 + unit(rng) * 20.0;
        r.strength = 0.2 + 0.8 * unit(rng);
    } else {
        r.kind = OpKind::kSmooth;
        r.height = 0.0;
        r.strength = 0.2 + 0.8 * unit(rng);
    }
    return r;
}

TEST(Watertight, thousandsOfRandomOpsNeverOpenACrack) {
    Terrain t = testing::makeHills(31, 150, 140);
    std::mt19937 rng(2024);
    int borders = 0;
    for (int i = 0; i < 2500; ++i) {
        const OpRequest r = randomOp(rng, t.spec());
        auto op = quantizeOp(r, t.spec());
        ASSERT_TRUE(op.ok()) << op.error().message;
        ASSERT_TRUE(t.apply(*op).ok());
        if (i % 50 == 49) {
            const Status s = t.checkInvariants();
            ASSERT_TRUE(s.ok()) << "after op " << i << ": " << s.error().message;
            // incremental hashing: every tile hash equals a recomputation from its bytes
            for (std::int32_t tile = 0; tile < t.spec().tileCount(); ++tile)
                ASSERT_EQ(t.tileHash(tile), t.computeTileHash(tile))
                    << "tile " << tile << " after op " << i;
            ASSERT_EQ(t.worldHash(), t.computeWorldHash()) << "after op " << i;
        }
        if (i % 500 == 499) {
            borders += testing::expectWatertight(t, static_cast<std::uint32_t>(i));
            if (::testing::Test::HasFailure())
                FAIL() << "crack after op " << i << " (" << describe(*op, t.spec()) << ")";
        }
    }
    EXPECT_GT(borders, 1000) << "the test must actually meet patch borders";
    EXPECT_GT(t.patchCount(), 50u);
    EXPECT_EQ(testing::freshHash(t), t.worldHash());
}

TEST(Watertight, patchBordersAgreeAcrossTileSeams) {
    Terrain t = testing::makeFlat(200, 200);
    // a row of craters straddling the vertical seam x = 64 and the horizontal seam y = 128
    for (int i = 0; i < 12; ++i) {
        auto a = quantizeOp(
            {OpKind::kCrater, 64.0 + (i % 3 - 1) * 0.7, 10.0 + i * 15.0, 2.5, 1.0, 0.3}, t.spec());
        auto b = quantizeOp(
            {OpKind::kCrater, 10.0 + i * 15.0, 128.0 + (i % 3 - 1) * 0.4, 2.0, 0.8, 0.3}, t.spec());
        ASSERT_TRUE(a.ok() && b.ok());
        ASSERT_TRUE(t.apply(*a).ok());
        ASSERT_TRUE(t.apply(*b).ok());
    }
    int across_seam = 0;
    for (std::int32_t cy = 0; cy < t.spec().cellsY(); ++cy)
        if (t.findPatch(63, cy) && t.findPatch(64, cy))
            ++across_seam;
    EXPECT_GT(across_seam, 5);
    EXPECT_TRUE(t.checkInvariants().ok());
    testing::expectWatertight(t);
}

} // namespace
} // namespace terrain
