#include <terrain/bspline.h>

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

namespace terrain::bspline {
namespace {

TEST(BSplineBasis, sumsToOneEverywhere) {
    for (int k = 0; k <= 1000; ++k) {
        const Basis b = evaluate(k / 1000.0);
        EXPECT_NEAR(std::accumulate(b.value.begin(), b.value.end(), 0.0), 1.0, 1e-14) << k;
        EXPECT_NEAR(std::accumulate(b.derivative.begin(), b.derivative.end(), 0.0), 0.0, 1e-12)
            << k;
        for (double v : b.value)
            EXPECT_GE(v, 0.0);
    }
}

TEST(BSplineBasis, isClampedAtBothEnds) {
    const Basis a = evaluate(0.0);
    const Basis b = evaluate(1.0);
    EXPECT_EQ(a.value[0], 1.0);
    EXPECT_EQ(b.value[4], 1.0);
    // end tangent runs along the first control leg: N0'(0) = -3 / (t4 - t1) = -6
    EXPECT_DOUBLE_EQ(a.derivative[0], -6.0);
    EXPECT_DOUBLE_EQ(a.derivative[1], 6.0);
    EXPECT_DOUBLE_EQ(b.derivative[4], 6.0);
}

TEST(BSplineBasis, matchesClosedFormOnFirstSpan) {
    // on [0, 1/2], N0 = (1 - 2u)^3 and, by symmetry, N4 is zero
    for (double u : {0.0, 0.1, 0.25, 0.4, 0.49}) {
        const Basis b = evaluate(u);
        EXPECT_NEAR(b.value[0], std::pow(1 - 2 * u, 3), 1e-15);
        EXPECT_EQ(b.value[4], 0.0);
    }
}

TEST(BSplineBasis, derivativeMatchesFiniteDifference) {
    for (double u : {0.05, 0.2, 0.3, 0.45, 0.55, 0.7, 0.95}) {
        const double e = 1e-6;
        const Basis lo = evaluate(u - e);
        const Basis hi = evaluate(u + e);
        const Basis b = evaluate(u);
        for (int i = 0; i < kControls; ++i)
            EXPECT_NEAR(b.derivative[i], (hi.value[i] - lo.value[i]) / (2 * e), 1e-6)
                << u << " " << i;
    }
}

TEST(BSplineBasis, grevilleControlsReproduceLinearFunctions) {
    for (int k = 0; k <= 100; ++k) {
        const double u = k / 100.0;
        const Basis b = evaluate(u);
        double s = 0.0;
        for (int i = 0; i < kControls; ++i)
            s += b.value[i] * (3.0 + 7.0 * kGrevilleSixths[i] / 6.0);
        EXPECT_NEAR(s, 3.0 + 7.0 * u, 1e-13);
    }
}

TEST(BSplineBasis, gridWeightsAreExactAndSymmetric) {
    const auto& w = gridWeights();
    for (int k = 0; k < kGridSamples; ++k) {
        std::int64_t sum = 0;
        const Basis b = evaluate(k / 16.0);
        for (int i = 0; i < kControls; ++i) {
            sum += w[k][i];
            EXPECT_EQ(static_cast<double>(w[k][i]), b.value[i] * kWeightScale);
            EXPECT_EQ(w[k][i], w[16 - k][4 - i]);
        }
        EXPECT_EQ(sum, kWeightScale);
    }
}

TEST(BSplineBasis, interpolationMatrixInvertsTheGrevilleCollocation) {
    // kInterpolation * N(g) = kInterpolationScale * I, exactly
    for (int i = 0; i < kControls; ++i)
        for (int j = 0; j < kControls; ++j) {
            double s = 0.0;
            for (int k = 0; k < kControls; ++k)
                s += kInterpolation[i][k] * evaluate(kGrevilleSixths[k] / 6.0).value[j];
            EXPECT_NEAR(s, i == j ? kInterpolationScale : 0.0, 1e-12) << i << "," << j;
        }
}

} // namespace
} // namespace terrain::bspline
