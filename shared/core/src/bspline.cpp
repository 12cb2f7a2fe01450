// Clamped cubic B-spline basis.
// Reference: L. Piegl and W. Tiller, "The NURBS Book", 2nd ed., algorithms A2.1 (FindSpan) and
// A2.2 (BasisFuns). The derivative uses N'_{i,p} = p (N_{i,p-1} / (t_{i+p} - t_i)
// - N_{i+1,p-1} / (t_{i+p+1} - t_{i+1})). The lookup tables of the original thesis are not used:
// they do not sum to one near the clamped ends.

#include <terrain/assert.h>
#include <terrain/bspline.h>

#include <cmath>

namespace terrain::bspline {
namespace {

// Non-zero basis functions of `degree` on `span` at u: out[r] = N_{span-degree+r, degree}(u).
void basisFunctions(int span, double u, int degree, double* out) {
    std::array<double, kDegree + 1> left{};
    std::array<double, kDegree + 1> right{};
    out[0] = 1.0;
    for (int j = 1; j <= degree; ++j) {
        left[static_cast<size_t>(j)] = u - kKnots[static_cast<size_t>(span + 1 - j)];
        right[static_cast<size_t>(j)] = kKnots[static_cast<size_t>(span + j)] - u;
        double saved = 0.0;
        for (int r = 0; r < j; ++r) {
            const double denom =
                right[static_cast<size_t>(r + 1)] + left[static_cast<size_t>(j - r)];
            const double temp = out[r] / denom;
            out[r] = saved + right[static_cast<size_t>(r + 1)] * temp;
            saved = left[static_cast<size_t>(j - r)] * temp;
        }
        out[j] = saved;
    }
}

std::array<std::array<std::int64_t, kControls>, kGridSamples> buildGridWeights() {
    std::array<std::array<std::int64_t, kControls>, kGridSamples> table{};
    for (int k = 0; k < kGridSamples; ++k) {
        const Basis b = evaluate(static_cast<double>(k) / kGridSteps);
        std::int64_t sum = 0;
        for (int i = 0; i < kControls; ++i) {
            const double scaled = b.value[static_cast<size_t>(i)] * kWeightScale;
            const auto w = static_cast<std::int64_t>(std::llround(scaled));
            TERRAIN_ASSERT(static_cast<double>(w) == scaled); // exactness of the dyadic basis
            table[static_cast<size_t>(k)][static_cast<size_t>(i)] = w;
            sum += w;
        }
        TERRAIN_ASSERT(sum == kWeightScale);
    }
    return table;
}

} // namespace

int findSpan(double u) {
    return u < kKnots[4] ? 3 : 4;
}

Basis evaluate(double u) {
    u = u < 0.0 ? 0.0 : (u > 1.0 ? 1.0 : u);
    const int span = findSpan(u);
    std::array<double, kDegree + 1> cubic{};
    std::array<double, kDegree + 1> quadratic{};
    basisFunctions(span, u, kDegree, cubic.data());
    basisFunctions(span, u, kDegree - 1, quadratic.data());

    Basis b;
    const int first = span - kDegree;
    for (int r = 0; r <= kDegree; ++r) {
        const int i = first + r;
        b.value[static_cast<size_t>(i)] = cubic[static_cast<size_t>(r)];
        // quadratic[r'] = N_{span-2+r', 2}; N_{i,2} has r' = r - 1, N_{i+1,2} has r' = r
        double d = 0.0;
        const double den_a =
            kKnots[static_cast<size_t>(i + kDegree)] - kKnots[static_cast<size_t>(i)];
        const double den_b =
            kKnots[static_cast<size_t>(i + kDegree + 1)] - kKnots[static_cast<size_t>(i + 1)];
        if (r >= 1 && den_a > 0.0)
            d += quadratic[static_cast<size_t>(r - 1)] / den_a;
        if (r <= kDegree - 1 && den_b > 0.0)
            d -= quadratic[static_cast<size_t>(r)] / den_b;
        b.derivative[static_cast<size_t>(i)] = kDegree * d;
    }
    return b;
}

const std::array<std::array<std::int64_t, kControls>, kGridSamples>& gridWeights() {
    static const auto table = buildGridWeights();
    return table;
}

} // namespace terrain::bspline
