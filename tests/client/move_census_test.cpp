// Where moves land (MoveCensus): in the footprint of an op changed lately (a cell of margin), and
// whether a move undoes a recent one of the same diamond.

#include <terrain/roam/move_census.h>

#include <gtest/gtest.h>

namespace terrain::testing {
namespace {

using roam::FrameStats;
using roam::LatticePoint;
using roam::MoveCensus;

LatticePoint inCell(std::int32_t cx, std::int32_t cy) {
    return {cx * roam::kLatticePerCell + 3, cy * roam::kLatticePerCell + 5};
}

TEST(RoamMoveCensus, AMoveCountsInTheFootprintOfAnOpChangedWithinItsWindow) {
    MoveCensus census;
    census.reset(40, 40);
    census.changed(CellRect{10, 10, 13, 12}, 5);
    FrameStats s;
    census.moved(inCell(11, 11), 1, true, 5, s);
    census.moved(inCell(9, 9), 2, true, 6, s); // the margin: one cell (a 2 x 2 square's)
    census.moved(inCell(20, 20), 3, true, 6, s);
    EXPECT_EQ(s.moves_in_footprint, 2);
    census.moved(inCell(11, 11), 4, true, 5 + MoveCensus::kRecentFrames, s);
    EXPECT_EQ(s.moves_in_footprint, 2) << "too long after the op";
}

TEST(RoamMoveCensus, AMoveUndoesARecentOppositeMoveOfTheSameDiamond) {
    MoveCensus census;
    census.reset(8, 8);
    FrameStats s;
    census.moved(inCell(1, 1), 7, true, 10, s);
    census.moved(inCell(1, 1), 7, true, 11, s); // the same way again: not an undo
    census.moved(inCell(1, 1), 7, false, 20, s);
    EXPECT_EQ(s.moves_undone, 1);
    census.moved(inCell(1, 1), 7, true, 20 + 2 * MoveCensus::kRecentFrames, s);
    EXPECT_EQ(s.moves_undone, 1) << "too long after";
    census.moved(inCell(2, 2), 8, true, 200, s);
    census.moved(inCell(2, 2), 9, false, 201, s); // another diamond
    EXPECT_EQ(s.moves_undone, 1);
    census.moved(inCell(2, 2), 8, false, 200 + MoveCensus::kRecentFrames, s); // the next window
    EXPECT_EQ(s.moves_undone, 2);
}

} // namespace
} // namespace terrain::testing
