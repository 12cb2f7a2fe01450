#include "support/surface_checks.h"

#include <terrain/detail_patch.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace terrain {
namespace {

CellCorners randomCorners(std::mt19937& rng, int spread) {
    std::uniform_int_distribution<int> d(-spread, spread);
    return {d(rng), d(rng), d(rng), d(rng)};
}

DetailPatch randomPatch(std::mt19937& rng, const CellCorners& c, int spread) {
    std::uniform_int_distribution<int> d(-spread, spread);
    DetailPatch p;
    for (auto& v : p.control)
        v = d(rng) * static_cast<int>(kControlScale) + d(rng) % 6;
    pinCorners(p, c);
    updateBounds(p, c);
    return p;
}

TEST(DetailPatch, baseSampledPatchHasStraightBordersAndPinnedCorners) {
    std::mt19937 rng(1);
    for (int n = 0; n < 200; ++n) {
        const CellCorners c = randomCorners(rng, 100000);
        for (Diagonal d : {Diagonal::kMain, Diagonal::kAnti}) {
            const DetailPatch p = patchFromBase(c, d);
            EXPECT_TRUE(areCornersPinned(p, c));
            for (Edge e : kAllEdges)
                EXPECT_TRUE(isEdgeStraight(p, e, c));
        }
    }
}

TEST(DetailPatch, straightBorderGridEqualsRoundedBaseEdgeExactly) {
    std::mt19937 rng(2);
    for (int n = 0; n < 500; ++n) {
        const CellCorners c = randomCorners(rng, 1 << 26);
        DetailPatch p = randomPatch(rng, c, 1 << 20);
        for (Edge e : kAllEdges)
            straightenEdge(p, e, c);
        std::array<std::int32_t, kPatchGridVertices> grid{};
        evaluateGrid(p, grid);
        for (Diagonal d : {Diagonal::kMain, Diagonal::kAnti})
            for (int k = 0; k <= 16; ++k) {
                EXPECT_EQ(grid[k], roundDiv(baseHeightScaled(c, d, k, 0, 16), 16));
                EXPECT_EQ(grid[16 * 17 + k], roundDiv(baseHeightScaled(c, d, k, 16, 16), 16));
                EXPECT_EQ(grid[k * 17], roundDiv(baseHeightScaled(c, d, 0, k, 16), 16));
                EXPECT_EQ(grid[k * 17 + 16], roundDiv(baseHeightScaled(c, d, 16, k, 16), 16));
            }
    }
}

TEST(DetailPatch, integerGridMatchesFloatEvaluation) {
    std::mt19937 rng(3);
    for (int n = 0; n < 100; ++n) {
        const CellCorners c = randomCorners(rng, 1 << 20);
        const DetailPatch p = randomPatch(rng, c, 1 << 20);
        std::array<std::int32_t, kPatchGridVertices> grid{};
        evaluateGrid(p, grid);
        for (int l = 0; l <= 16; ++l)
            for (int k = 0; k <= 16; ++k) {
                const double z = patchHeight(p, k / 16.0, l / 16.0);
                EXPECT_NEAR(grid[l * 17 + k], z, 0.5 + 1e-6);
                EXPECT_EQ(gridNumerator(p, k, l) % 1, 0);
            }
    }
}

TEST(DetailPatch, gradientMatchesFiniteDifference) {
    std::mt19937 rng(4);
    const CellCorners c = randomCorners(rng, 5000);
    const DetailPatch p = randomPatch(rng, c, 5000);
    for (double u : {0.1, 0.3, 0.6, 0.9})
        for (double v : {0.2, 0.45, 0.55, 0.8}) {
            const double e = 1e-6;
            const Gradient g = patchGradient(p, u, v);
            EXPECT_NEAR(
                g.du, (patchHeight(p, u + e, v) - patchHeight(p, u - e, v)) / (2 * e), 1e-3);
            EXPECT_NEAR(
                g.dv, (patchHeight(p, u, v + e) - patchHeight(p, u, v - e)) / (2 * e), 1e-3);
        }
}

TEST(DetailPatch, gridGradientsEqualTheAnalyticGradient) {
    std::mt19937 rng(8);
    const CellCorners c = randomCorners(rng, 50000);
    const DetailPatch p = randomPatch(rng, c, 50000);
    std::array<Gradient, kPatchGridVertices> grid{};
    evaluateGridGradients(p, grid);
    for (int l = 0; l <= 16; ++l)
        for (int k = 0; k <= 16; ++k) {
            const Gradient g = patchGradient(p, k / 16.0, l / 16.0);
            EXPECT_NEAR(grid[l * 17 + k].du, g.du, 1e-9 * (1 + std::abs(g.du)));
            EXPECT_NEAR(grid[l * 17 + k].dv, g.dv, 1e-9 * (1 + std::abs(g.dv)));
        }
}

// The stored bounds must hold against dense sampling of the true surface, not merely against
// the method's own estimate.
TEST(DetailPatch, storedBoundsAreTrueBoundsUnderDenseSampling) {
    std::mt19937 rng(5);
    double tightest_deviation = 1e9;
    for (int n = 0; n < 160; ++n) {
        const CellCorners c = randomCorners(rng, 4000);
        const DetailPatch p = randomPatch(rng, c, n % 2 == 0 ? 4000 : 300);
        for (Diagonal d : {Diagonal::kMain, Diagonal::kAnti}) {
            double worst = 0.0;
            for (int j = 0; j <= 96; ++j)
                for (int i = 0; i <= 96; ++i) {
                    const double u = i / 96.0;
                    const double v = j / 96.0;
                    worst =
                        std::max(worst, std::abs(patchHeight(p, u, v) - baseHeight(c, d, u, v)));
                }
            EXPECT_LE(worst, p.deviation_bound) << n;
            tightest_deviation =
                std::min(tightest_deviation, p.deviation_bound / std::max(worst, 1.0));
        }
        // piecewise-linear over the rounded 17 x 17 grid, 4-8 diagonals
        std::array<std::int32_t, kPatchGridVertices> grid{};
        evaluateGrid(p, grid);
        double worst_grid = 0.0;
        for (int j = 0; j < 16 * 8; ++j)
            for (int i = 0; i < 16 * 8; ++i) {
                const double u = (i + 0.37) / 128.0;
                const double v = (j + 0.61) / 128.0;
                const int k = std::min(15, static_cast<int>(u * 16));
                const int l = std::min(15, static_cast<int>(v * 16));
                const CellCorners sub{
                    grid[l * 17 + k], grid[l * 17 + k + 1], grid[(l + 1) * 17 + k],
                    grid[(l + 1) * 17 + k + 1]};
                const double lin = baseHeight(sub, cellDiagonal(k, l), u * 16 - k, v * 16 - l);
                worst_grid = std::max(worst_grid, std::abs(patchHeight(p, u, v) - lin));
            }
        EXPECT_LE(worst_grid, p.grid_error_bound) << n;
    }
    // a bound that is true but useless would pass too; require it to be within 20x somewhere
    EXPECT_LT(tightest_deviation, 20.0);
}

TEST(DetailPatch, controlRangeContainsTheSurface) {
    std::mt19937 rng(6);
    for (int n = 0; n < 100; ++n) {
        const CellCorners c = randomCorners(rng, 10000);
        const DetailPatch p = randomPatch(rng, c, 10000);
        const HeightRange r = controlRange(p);
        for (int j = 0; j <= 40; ++j)
            for (int i = 0; i <= 40; ++i) {
                const double z = patchHeight(p, i / 40.0, j / 40.0);
                EXPECT_GE(z, r.min - 1e-6);
                EXPECT_LE(z, r.max + 1e-6);
            }
    }
}

} // namespace
} // namespace terrain
