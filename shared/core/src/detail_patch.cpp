// Detail patch evaluation and bounds.
// Basis and knots: bspline.h. Bounds use the convex-hull property of B-splines (a spline lies
// within the range of its controls, and bilinear functions are reproduced by their Greville
// samples), and the interpolation error bound |f - Lf| <= M R^2 / 2 for a triangle of
// circumradius R and second-derivative bound M.

#include <terrain/detail_patch.h>
#include <terrain/fixed_point.h>

#include <algorithm>
#include <cmath>

namespace terrain {
namespace {

using bspline::kGrevilleSixths;

constexpr int kLast = bspline::kControls - 1;

void edgeIndex(Edge e, int k, int& i, int& j) {
    switch (e) {
    case Edge::kMinV:
        i = k;
        j = 0;
        return;
    case Edge::kMaxV:
        i = k;
        j = kLast;
        return;
    case Edge::kMinU:
        i = 0;
        j = k;
        return;
    case Edge::kMaxU:
        i = kLast;
        j = k;
        return;
    }
}

// corner heights at the two ends of edge e, in increasing parameter order
void edgeEnds(Edge e, const CellCorners& c, std::int64_t& a, std::int64_t& b) {
    switch (e) {
    case Edge::kMinV:
        a = c.h00;
        b = c.h10;
        return;
    case Edge::kMaxV:
        a = c.h01;
        b = c.h11;
        return;
    case Edge::kMinU:
        a = c.h00;
        b = c.h01;
        return;
    case Edge::kMaxU:
        a = c.h10;
        b = c.h11;
        return;
    }
}

std::int32_t straightControl(std::int64_t a, std::int64_t b, int k) {
    const std::int64_t g = kGrevilleSixths[static_cast<size_t>(k)];
    return static_cast<std::int32_t>((6 - g) * a + g * b);
}

// knot differences t_{i+4} - t_{i+1} (first derivative) and t'_{k+3} - t'_{k+1} (second), in
// halves of the parameter range so that everything stays integral: {1,2,2,1} and {1,2,1}
// reciprocals, exact (the spans are powers of two): multiplications instead of divisions
constexpr std::array<double, 4> kInvFirstSpan = {2.0, 1.0, 1.0, 2.0};
constexpr std::array<double, 3> kInvSecondSpan = {2.0, 1.0, 2.0};

} // namespace

std::int32_t& edgeControl(DetailPatch& p, Edge e, int k) {
    int i = 0;
    int j = 0;
    edgeIndex(e, k, i, j);
    return p.at(i, j);
}

std::int32_t edgeControl(const DetailPatch& p, Edge e, int k) {
    int i = 0;
    int j = 0;
    edgeIndex(e, k, i, j);
    return p.at(i, j);
}

DetailPatch patchFromBase(const CellCorners& c, Diagonal d) {
    DetailPatch p;
    for (int j = 0; j < bspline::kControls; ++j)
        for (int i = 0; i < bspline::kControls; ++i)
            p.at(i, j) = static_cast<std::int32_t>(baseHeightScaled(
                c, d, kGrevilleSixths[static_cast<size_t>(i)],
                kGrevilleSixths[static_cast<size_t>(j)], kControlScale));
    updateBounds(p, c);
    return p;
}

void pinCorners(DetailPatch& p, const CellCorners& c) {
    p.at(0, 0) = static_cast<std::int32_t>(kControlScale * c.h00);
    p.at(kLast, 0) = static_cast<std::int32_t>(kControlScale * c.h10);
    p.at(0, kLast) = static_cast<std::int32_t>(kControlScale * c.h01);
    p.at(kLast, kLast) = static_cast<std::int32_t>(kControlScale * c.h11);
}

void straightenEdge(DetailPatch& p, Edge e, const CellCorners& c) {
    std::int64_t a = 0;
    std::int64_t b = 0;
    edgeEnds(e, c, a, b);
    for (int k = 0; k < bspline::kControls; ++k)
        edgeControl(p, e, k) = straightControl(a, b, k);
}

bool isEdgeStraight(const DetailPatch& p, Edge e, const CellCorners& c) {
    std::int64_t a = 0;
    std::int64_t b = 0;
    edgeEnds(e, c, a, b);
    for (int k = 0; k < bspline::kControls; ++k)
        if (edgeControl(p, e, k) != straightControl(a, b, k))
            return false;
    return true;
}

bool areCornersPinned(const DetailPatch& p, const CellCorners& c) {
    return p.at(0, 0) == kControlScale * c.h00 && p.at(kLast, 0) == kControlScale * c.h10 &&
           p.at(0, kLast) == kControlScale * c.h01 && p.at(kLast, kLast) == kControlScale * c.h11;
}

double patchHeight(const DetailPatch& p, double u, double v) {
    const bspline::Basis bu = bspline::evaluate(u);
    const bspline::Basis bv = bspline::evaluate(v);
    double z = 0.0;
    for (int j = 0; j < bspline::kControls; ++j) {
        double row = 0.0;
        for (int i = 0; i < bspline::kControls; ++i)
            row += bu.value[static_cast<size_t>(i)] * p.at(i, j);
        z += bv.value[static_cast<size_t>(j)] * row;
    }
    return z / kControlScale;
}

Gradient patchGradient(const DetailPatch& p, double u, double v) {
    const bspline::Basis bu = bspline::evaluate(u);
    const bspline::Basis bv = bspline::evaluate(v);
    Gradient g;
    for (int j = 0; j < bspline::kControls; ++j) {
        for (int i = 0; i < bspline::kControls; ++i) {
            const double c = p.at(i, j);
            g.du += bu.derivative[static_cast<size_t>(i)] * bv.value[static_cast<size_t>(j)] * c;
            g.dv += bu.value[static_cast<size_t>(i)] * bv.derivative[static_cast<size_t>(j)] * c;
        }
    }
    g.du /= kControlScale;
    g.dv /= kControlScale;
    return g;
}

std::int64_t gridNumerator(const DetailPatch& p, int k, int l) {
    const auto& w = bspline::gridWeights();
    const auto& wu = w[static_cast<size_t>(k)];
    const auto& wv = w[static_cast<size_t>(l)];
    std::int64_t z = 0;
    for (int j = 0; j < bspline::kControls; ++j) {
        if (wv[static_cast<size_t>(j)] == 0)
            continue;
        std::int64_t row = 0;
        for (int i = 0; i < bspline::kControls; ++i)
            row += wu[static_cast<size_t>(i)] * p.at(i, j);
        z += wv[static_cast<size_t>(j)] * row;
    }
    return z;
}

void gridNumerators(
    const DetailPatch& p, std::array<std::int64_t, kPatchGridVertices>& out, int stride) {
    const auto& w = bspline::gridWeights();
    // rows first: 5 x 17 partial sums, then columns
    std::array<std::int64_t, bspline::kControls * bspline::kGridSamples> partial{};
    for (int j = 0; j < bspline::kControls; ++j)
        for (int k = 0; k < bspline::kGridSamples; k += stride) {
            std::int64_t s = 0;
            for (int i = 0; i < bspline::kControls; ++i)
                s += w[static_cast<size_t>(k)][static_cast<size_t>(i)] * p.at(i, j);
            partial[static_cast<size_t>(j * bspline::kGridSamples + k)] = s;
        }
    for (int l = 0; l < bspline::kGridSamples; l += stride)
        for (int k = 0; k < bspline::kGridSamples; k += stride) {
            std::int64_t z = 0;
            for (int j = 0; j < bspline::kControls; ++j)
                z += w[static_cast<size_t>(l)][static_cast<size_t>(j)] *
                     partial[static_cast<size_t>(j * bspline::kGridSamples + k)];
            out[static_cast<size_t>(l * bspline::kGridSamples + k)] = z;
        }
}

void grevilleHeights48(const DetailPatch& p, std::array<std::int64_t, kPatchControls>& out) {
    using bspline::kCollocation;
    using bspline::kControls;
    std::array<std::int64_t, kPatchControls> rows{}; // along u first
    for (int j = 0; j < kControls; ++j)
        for (int i = 0; i < kControls; ++i) {
            std::int64_t sum = 0;
            for (int a = 0; a < kControls; ++a)
                sum += kCollocation[static_cast<size_t>(i)][static_cast<size_t>(a)] * p.at(a, j);
            rows[static_cast<size_t>(j * kControls + i)] = sum;
        }
    constexpr std::int64_t kScale = bspline::kCollocationScale * bspline::kCollocationScale;
    for (int j = 0; j < kControls; ++j)
        for (int i = 0; i < kControls; ++i) {
            std::int64_t sum = 0;
            for (int b = 0; b < kControls; ++b)
                sum += kCollocation[static_cast<size_t>(j)][static_cast<size_t>(b)] *
                       rows[static_cast<size_t>(b * kControls + i)];
            // sum is in 1/6 quanta times kScale; 1/48 = 1/6 / 8
            out[static_cast<size_t>(j * kControls + i)] =
                roundDiv((kFineScale / kControlScale) * sum, kScale);
        }
}

void evaluateGrid(const DetailPatch& p, std::array<std::int32_t, kPatchGridVertices>& out) {
    std::array<std::int64_t, kPatchGridVertices> numerators{};
    gridNumerators(p, numerators);
    for (size_t n = 0; n < numerators.size(); ++n)
        out[n] = static_cast<std::int32_t>(roundDiv(numerators[n], kGridDenominator));
}

void evaluateGridGradients(const DetailPatch& p, std::array<Gradient, kPatchGridVertices>& out) {
    std::array<bspline::Basis, bspline::kGridSamples> basis{};
    for (int k = 0; k < bspline::kGridSamples; ++k)
        basis[static_cast<size_t>(k)] =
            bspline::evaluate(static_cast<double>(k) / bspline::kGridSteps);
    for (int l = 0; l < bspline::kGridSamples; ++l)
        for (int k = 0; k < bspline::kGridSamples; ++k) {
            const bspline::Basis& bu = basis[static_cast<size_t>(k)];
            const bspline::Basis& bv = basis[static_cast<size_t>(l)];
            Gradient g;
            for (int j = 0; j < bspline::kControls; ++j)
                for (int i = 0; i < bspline::kControls; ++i) {
                    const double c = p.at(i, j);
                    g.du += bu.derivative[static_cast<size_t>(i)] *
                            bv.value[static_cast<size_t>(j)] * c;
                    g.dv += bu.value[static_cast<size_t>(i)] *
                            bv.derivative[static_cast<size_t>(j)] * c;
                }
            g.du /= kControlScale;
            g.dv /= kControlScale;
            out[static_cast<size_t>(l * bspline::kGridSamples + k)] = g;
        }
}

void updateBounds(DetailPatch& p, const CellCorners& c) {
    // patch - bilinear: its controls are C - 6 * bilinear(Greville), in 1/36 quanta
    std::int64_t worst36 = 0;
    for (int j = 0; j < bspline::kControls; ++j) {
        const std::int64_t gv = kGrevilleSixths[static_cast<size_t>(j)];
        for (int i = 0; i < bspline::kControls; ++i) {
            const std::int64_t gu = kGrevilleSixths[static_cast<size_t>(i)];
            const std::int64_t bilinear36 = (6 - gu) * (6 - gv) * c.h00 + gu * (6 - gv) * c.h10 +
                                            (6 - gu) * gv * c.h01 + gu * gv * c.h11;
            worst36 = std::max(worst36, absI64(6 * std::int64_t{p.at(i, j)} - bilinear36));
        }
    }
    const std::int64_t twist = absI64(std::int64_t{c.h00} - c.h10 - c.h01 + std::int64_t{c.h11});
    p.deviation_bound = static_cast<std::int32_t>(ceilDiv(worst36, 36) + ceilDiv(twist, 4));

    // second-derivative control nets, in sixths of a quantum per unit parameter squared (the
    // nets are linear in the controls, so the division by kControlScale is done once, at the end;
    // per control it was a fifth of a snapshot decode)
    auto ctrl = [&](int i, int j) { return static_cast<double>(p.at(i, j)); };
    double m_uu = 0.0;
    double m_vv = 0.0;
    double m_uv = 0.0;
    for (int row = 0; row < bspline::kControls; ++row) {
        std::array<double, 4> qu{};
        std::array<double, 4> qv{};
        for (int k = 0; k < 4; ++k) {
            qu[static_cast<size_t>(k)] =
                3.0 * (ctrl(k + 1, row) - ctrl(k, row)) * kInvFirstSpan[static_cast<size_t>(k)];
            qv[static_cast<size_t>(k)] =
                3.0 * (ctrl(row, k + 1) - ctrl(row, k)) * kInvFirstSpan[static_cast<size_t>(k)];
        }
        for (int k = 0; k < 3; ++k) {
            m_uu = std::max(
                m_uu, std::abs(
                          2.0 * (qu[static_cast<size_t>(k + 1)] - qu[static_cast<size_t>(k)]) *
                          kInvSecondSpan[static_cast<size_t>(k)]));
            m_vv = std::max(
                m_vv, std::abs(
                          2.0 * (qv[static_cast<size_t>(k + 1)] - qv[static_cast<size_t>(k)]) *
                          kInvSecondSpan[static_cast<size_t>(k)]));
        }
    }
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const double d = ctrl(i + 1, j + 1) - ctrl(i, j + 1) - ctrl(i + 1, j) + ctrl(i, j);
            m_uv = std::max(
                m_uv, std::abs(
                          9.0 * d * kInvFirstSpan[static_cast<size_t>(i)] *
                          kInvFirstSpan[static_cast<size_t>(j)]));
        }
    // Frobenius norm bounds the Hessian's spectral norm; legs w = 1/16 give R^2 = w^2 / 2
    const double m =
        std::sqrt(m_uu * m_uu + 2.0 * m_uv * m_uv + m_vv * m_vv) / kControlScale; // quanta
    const double w = 1.0 / bspline::kGridSteps;
    // 1e-6 relative margin covers the rounding of this double computation itself
    p.grid_error_bound = static_cast<float>((m * w * w / 4.0 + 0.5) * (1.0 + 1e-6));
}

HeightRange controlRange(const DetailPatch& p) {
    const auto [lo, hi] = std::minmax_element(p.control.begin(), p.control.end());
    return {
        static_cast<std::int32_t>(floorDiv(*lo, kControlScale)),
        static_cast<std::int32_t>(ceilDiv(*hi, kControlScale))};
}

} // namespace terrain
