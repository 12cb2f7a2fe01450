#pragma once

// Checks of surface properties that several suites need.

#include <terrain/base_cell.h>
#include <terrain/detail_patch.h>
#include <terrain/fixed_point.h>
#include <terrain/terrain.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

namespace terrain::testing {

/// Height in quanta of cell (cx, cy) at (u, v), patch or base.
inline double cellHeightQ(const Terrain& t, std::int32_t cx, std::int32_t cy, double u, double v) {
    if (const DetailPatch* p = t.findPatch(cx, cy))
        return patchHeight(*p, u, v);
    return baseHeight(t.corners(cx, cy), cellDiagonal(cx, cy), u, v);
}

/// Integer grid height (quanta) of cell (cx, cy) at (k/16, l/16): a patch's rounded grid, or the
/// base triangles rounded the same way.
inline std::int32_t cellGridQ(const Terrain& t, std::int32_t cx, std::int32_t cy, int k, int l) {
    if (const DetailPatch* p = t.findPatch(cx, cy))
        return static_cast<std::int32_t>(roundDiv(gridNumerator(*p, k, l), kGridDenominator));
    return static_cast<std::int32_t>(
        roundDiv(baseHeightScaled(t.corners(cx, cy), cellDiagonal(cx, cy), k, l, 16), 16));
}

/// Every interior border of every patched cell, evaluated from both sides: the integer grids
/// agree exactly, and float evaluation at random points agrees to 1e-9 of a quantum's scale.
/// Returns the number of borders checked.
inline int expectWatertight(const Terrain& t, std::uint32_t seed = 7) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int checked = 0;
    const WorldSpec& spec = t.spec();
    for (std::int32_t tile = 0; tile < spec.tileCount(); ++tile) {
        const std::int32_t tx = tile % spec.tilesX();
        const std::int32_t ty = tile / spec.tilesX();
        for (const PatchEntry& e : t.tilePatches(tile)) {
            const std::int32_t cx = tx * kTileCells + e.cell % kTileCells;
            const std::int32_t cy = ty * kTileCells + e.cell / kTileCells;
            // the right and lower neighbours; left/upper are covered from the other side or
            // below when that cell is a base cell
            for (Edge edge : kAllEdges) {
                const CellOffset off = neighbourOffset(edge);
                const std::int32_t nx = cx + off.dx;
                const std::int32_t ny = cy + off.dy;
                if (nx < 0 || ny < 0 || nx >= spec.cellsX() || ny >= spec.cellsY())
                    continue;
                ++checked;
                for (int k = 0; k <= 16; ++k) {
                    int a_k = k, a_l = k, b_k = k, b_l = k;
                    switch (edge) {
                    case Edge::kMinV:
                        a_l = 0;
                        b_l = 16;
                        break;
                    case Edge::kMaxV:
                        a_l = 16;
                        b_l = 0;
                        break;
                    case Edge::kMinU:
                        a_k = 0;
                        b_k = 16;
                        break;
                    case Edge::kMaxU:
                        a_k = 16;
                        b_k = 0;
                        break;
                    }
                    EXPECT_EQ(cellGridQ(t, cx, cy, a_k, a_l), cellGridQ(t, nx, ny, b_k, b_l))
                        << "grid crack between (" << cx << "," << cy << ") and (" << nx << "," << ny
                        << ") at k=" << k;
                }
                for (int s = 0; s < 4; ++s) {
                    const double w = unit(rng);
                    double au = w, av = w, bu = w, bv = w;
                    switch (edge) {
                    case Edge::kMinV:
                        av = 0;
                        bv = 1;
                        break;
                    case Edge::kMaxV:
                        av = 1;
                        bv = 0;
                        break;
                    case Edge::kMinU:
                        au = 0;
                        bu = 1;
                        break;
                    case Edge::kMaxU:
                        au = 1;
                        bu = 0;
                        break;
                    }
                    const double za = cellHeightQ(t, cx, cy, au, av);
                    const double zb = cellHeightQ(t, nx, ny, bu, bv);
                    EXPECT_NEAR(za, zb, 1e-9 * (1.0 + std::abs(za)))
                        << "crack between (" << cx << "," << cy << ") and (" << nx << "," << ny
                        << ")";
                }
            }
        }
    }
    return checked;
}

} // namespace terrain::testing
