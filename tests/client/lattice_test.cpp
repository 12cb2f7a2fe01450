// The lattice's diamonds alone: cell-level triangles, parents and children, and how far a
// cell's full refinement reaches.

#include <terrain/base_cell.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/lattice.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <vector>

namespace terrain::testing {
namespace {

TEST(RoamLattice, CellLevelTrianglesFollowTheBaseCellDiagonal) {
    for (std::int32_t cy = 0; cy < 8; ++cy)
        for (std::int32_t cx = 0; cx < 8; ++cx) {
            const roam::LatticePoint centre{cx * 16 + 8, cy * 16 + 8};
            const roam::Diamond d = roam::diamondAt(centre);
            ASSERT_EQ(d.level, roam::kCellTriangleLevel);
            const auto ends = roam::hypotenuseEnds(d);
            const bool main = (ends[0].x - ends[1].x) * (ends[0].y - ends[1].y) > 0;
            EXPECT_EQ(main, cellDiagonal(cx, cy) == Diagonal::kMain) << cx << "," << cy;
        }
}

TEST(RoamLattice, ParentsAndChildrenAgree) {
    // every child of a diamond lists it as a parent, over two tiles of every level
    for (std::int32_t y = 0; y <= 2 * roam::kLatticePerTile; ++y)
        for (std::int32_t x = 0; x <= 2 * roam::kLatticePerTile; ++x) {
            const roam::Diamond d = roam::diamondAt({x, y});
            if (!d.valid())
                continue;
            std::array<roam::LatticePoint, 4> kids{};
            const int n = roam::children(d, kids);
            for (int i = 0; i < n; ++i) {
                const roam::Diamond c = roam::diamondAt(kids[i]);
                ASSERT_EQ(c.level, d.level + 1);
                const auto parents = roam::apexes(c);
                EXPECT_TRUE(parents[0] == d.centre || parents[1] == d.centre);
            }
        }
}

TEST(RoamLattice, FullRefinementOfACellReachesOnlyItsNeighbours) {
    // the closure (every forced parent) of splitting every sub-cell diamond of one cell: the
    // cells its triangles lie in must be within kDetailHaloCells, or a split would find no block
    for (std::int32_t cy = 4; cy < 6; ++cy)
        for (std::int32_t cx = 4; cx < 6; ++cx) {
            std::set<std::pair<std::int32_t, std::int32_t>> split;
            std::function<void(roam::LatticePoint)> force = [&](roam::LatticePoint p) {
                if (roam::isGridVertex(p) || !split.insert({p.x, p.y}).second)
                    return; // grid vertices need no block
                for (const roam::LatticePoint a : roam::apexes(roam::diamondAt(p)))
                    force(a);
            };
            for (std::int32_t l = 0; l <= 16; ++l)
                for (std::int32_t k = 0; k <= 16; ++k)
                    force({cx * 16 + k, cy * 16 + l});
            std::int32_t reach = 0;
            for (const auto& [x, y] : split) {
                const roam::Diamond d = roam::diamondAt({x, y});
                for (const roam::LatticePoint a : roam::apexes(d)) {
                    const roam::LatticePoint c3 = roam::centroidTimes3(roam::triangleOf(d, a));
                    reach = std::max({reach, std::abs(c3.x / 48 - cx), std::abs(c3.y / 48 - cy)});
                }
            }
            EXPECT_GT(split.size(), 255u);
            EXPECT_EQ(reach, roam::kDetailHaloCells) << "cell " << cx << "," << cy;
        }
}

} // namespace
} // namespace terrain::testing
