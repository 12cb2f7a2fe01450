// The stale-block queue alone, on a cratered world's detail records: which blocks an op makes
// stale, heights before bounds, the budget's order, and blocks that went meanwhile.

#include "support/terrain_builders.h"

#include <terrain/roam/stale_blocks.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <set>
#include <vector>

namespace terrain::testing {
namespace {

using roam::DetailBlocks;
using roam::StaleBlocks;

struct StaleWorld {
    StaleWorld() {
        Terrain t = makeHills(7);
        CraterSeries s;
        s.seed = 7;
        s.count = 60;
        applyAll(t, randomCraters(t.spec(), s));
        real_x = t.spec().cellsX();
        real_y = t.spec().cellsY();
        blocks.reset(t);
        for (std::int32_t r = 0; r < blocks.recordCapacity(); ++r)
            if (blocks.recordInUse(r))
                blocks.materialise(r);
        // a cell whose 3 x 3 window is all detail cells, away from the map's edge
        for (std::int32_t cy = 1; cy + 1 < real_y && centre.x < 0; ++cy)
            for (std::int32_t cx = 1; cx + 1 < real_x && centre.x < 0; ++cx) {
                bool full = true;
                for (std::int32_t dy = -1; dy <= 1; ++dy)
                    for (std::int32_t dx = -1; dx <= 1; ++dx)
                        full = full && blocks.blockOf(cx + dx, cy + dy) >= 0;
                if (full)
                    centre = {cx, cy};
            }
        EXPECT_GE(centre.x, 0) << "no cell with a full window of detail cells";
    }
    std::set<std::int32_t> window() const {
        std::set<std::int32_t> w;
        for (std::int32_t dy = -1; dy <= 1; ++dy)
            for (std::int32_t dx = -1; dx <= 1; ++dx)
                w.insert(blocks.blockOf(centre.x + dx, centre.y + dy));
        return w;
    }
    DetailBlocks blocks;
    DetailBlocks::CellXY centre;
    std::int32_t real_x = 0;
    std::int32_t real_y = 0;
};

TEST(RoamStaleBlocks, AnOpMakesItsWindowsBoundsStaleAndItsOwnCellsHeights) {
    StaleWorld w;
    StaleBlocks stale;
    const CellRect op{w.centre.x, w.centre.y, w.centre.x, w.centre.y};
    stale.mark(op, w.blocks, w.real_x, w.real_y);
    stale.mark(op, w.blocks, w.real_x, w.real_y); // a second op there queues nothing more
    EXPECT_EQ(stale.size(), 9u);
    for (const std::int32_t b : w.window())
        EXPECT_TRUE(stale.stale(b));
    std::vector<std::int32_t> out;
    stale.takeHeights(out);
    EXPECT_EQ(out, (std::vector<std::int32_t>{w.blocks.blockOf(w.centre.x, w.centre.y)}))
        << "only the changed cell's heights moved";
    stale.takeHeights(out);
    EXPECT_TRUE(out.empty()) << "heights are new once taken";
    EXPECT_EQ(stale.size(), 9u) << "their bounds still wait";
}

TEST(RoamStaleBlocks, TheBudgetTakesTheOldestFirstAndSkipsBlocksThatWent) {
    StaleWorld w;
    StaleBlocks stale;
    const CellRect op{w.centre.x, w.centre.y, w.centre.x, w.centre.y};
    stale.mark(op, w.blocks, w.real_x, w.real_y);
    // a later op beside it: its new blocks queue behind the first op's
    const CellRect later{w.centre.x + 3, w.centre.y, w.centre.x + 3, w.centre.y};
    stale.mark(later, w.blocks, w.real_x, w.real_y);
    const std::set<std::int32_t> first = w.window();
    const std::int32_t gone = w.blocks.blockOf(w.centre.x - 1, w.centre.y - 1);
    stale.forget(gone);
    std::vector<std::int32_t> out;
    stale.take(4, out);
    ASSERT_EQ(out.size(), 4u);
    for (const std::int32_t b : out) {
        EXPECT_TRUE(first.count(b)) << "the first op's blocks come first";
        EXPECT_NE(b, gone);
        EXPECT_FALSE(stale.stale(b));
    }
    std::vector<std::int32_t> all = out;
    while (stale.size() > 0) {
        stale.take(4, out);
        all.insert(all.end(), out.begin(), out.end());
    }
    EXPECT_EQ(std::count(all.begin(), all.end(), gone), 0) << "a block that went is skipped";
    EXPECT_EQ(std::set<std::int32_t>(all.begin(), all.end()).size(), all.size())
        << "no block twice";
    stale.take(4, out);
    EXPECT_TRUE(out.empty());
}

} // namespace
} // namespace terrain::testing
