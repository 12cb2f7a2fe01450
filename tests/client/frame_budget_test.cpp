// The frame budget steers the triangle cap to hold a frame-time target: checked against a
// simulated frame cost (a fixed part plus a part per triangle), and end to end on a
// tessellator whose cap it sets.

#include "support/terrain_builders.h"

#include <terrain/client/frame_budget.h>
#include <terrain/roam/tessellator.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

namespace terrain::client {
namespace {

// What a frame of `triangles` costs: 3 ms plus 0.1 ms per thousand triangles.
double simulatedMs(std::int64_t triangles) {
    return 3.0 + 1.0e-4 * static_cast<double>(triangles);
}

// A view that would draw `wanted` triangles if the cap let it.
std::int64_t drawn(std::int64_t wanted, std::int64_t cap) {
    return std::min(wanted, cap);
}

TEST(FrameBudget, OffLeavesTheCapAlone) {
    FrameBudget b({.target_ms = 0.0, .max_triangles = 300'000});
    for (int f = 0; f < 100; ++f)
        EXPECT_EQ(b.observe(500.0, 300'000), 300'000);
}

TEST(FrameBudget, ShrinksTheCapUntilFramesHoldTheTarget) {
    FrameBudget b({.target_ms = 13.0, .max_triangles = 400'000});
    std::int64_t cap = b.cap();
    for (int f = 0; f < 400; ++f)
        cap = b.observe(simulatedMs(drawn(1'000'000, cap)), drawn(1'000'000, cap));
    // 13 ms is 100,000 triangles in this model; the budget holds between 80 % and 100 % of it
    EXPECT_LE(simulatedMs(cap), 13.0 * 1.02);
    EXPECT_GE(simulatedMs(cap), 13.0 * 0.8 * 0.999); // the band is [80 %, 100 %] of the target
    const std::int64_t settled = cap;
    for (int f = 0; f < 200; ++f)
        cap = b.observe(simulatedMs(drawn(1'000'000, cap)), drawn(1'000'000, cap));
    EXPECT_EQ(cap, settled) << "a cap that holds the target stays put";
}

TEST(FrameBudget, GrowsBackWhenTheViewGetsCheaper) {
    FrameBudget b({.target_ms = 13.0, .max_triangles = 400'000});
    std::int64_t cap = b.cap();
    for (int f = 0; f < 400; ++f) // an expensive stretch: the cap shrinks
        cap = b.observe(3.0 + 3.0e-4 * static_cast<double>(drawn(1'000'000, cap)), cap);
    ASSERT_LT(cap, 60'000);
    for (int f = 0; f < 400; ++f) // triangles got cheap (a smaller window): it grows back
        cap = b.observe(simulatedMs(drawn(1'000'000, cap)), drawn(1'000'000, cap));
    EXPECT_GE(simulatedMs(cap), 13.0 * 0.8 * 0.999); // the band is [80 %, 100 %] of the target
    EXPECT_LE(simulatedMs(cap), 13.0 * 1.02);
}

TEST(FrameBudget, NeverLeavesItsFloorAndCeiling) {
    FrameBudget slow({.target_ms = 1.0, .max_triangles = 400'000, .min_triangles = 30'000});
    std::int64_t cap = slow.cap();
    for (int f = 0; f < 400; ++f)
        cap = slow.observe(50.0, cap);
    EXPECT_EQ(cap, 30'000);
    FrameBudget fast({.target_ms = 100.0, .max_triangles = 400'000});
    for (int f = 0; f < 400; ++f)
        EXPECT_LE(fast.observe(1.0, 400'000), 400'000);
}

TEST(FrameBudget, ATessellatorFollowsTheCapItSetsWithoutRebuilding) {
    const Terrain t = testing::makeHills(9, 257, 257);
    roam::TessellatorOptions o;
    o.tau_pixels = 0.25; // wants far more than the caps below
    roam::Tessellator tess(t, o);
    const double x = t.spec().extentX() / 2;
    const double y = t.spec().extentY() / 2;
    roam::Camera c;
    c.eye = glm::dvec3(x - 60.0, y - 60.0, surfaceHeight(t, x, y) + 25.0);
    c.forward = glm::dvec3(x, y, surfaceHeight(t, x, y)) - c.eye;
    c.viewport_width = 1280;
    c.viewport_height = 720;
    tess.update(c);
    const std::int64_t uncapped = tess.triangleCount();
    ASSERT_GT(uncapped, 40'000);
    for (const std::int64_t cap : {uncapped / 2, uncapped / 5, uncapped / 3}) {
        tess.setMaxTriangles(cap);
        roam::FrameStats s;
        for (int f = 0; f < 40; ++f) {
            s = tess.update(c);
            EXPECT_FALSE(s.rebuilt);
        }
        EXPECT_LE(s.triangles, cap);
        EXPECT_GE(s.triangles, cap * 7 / 10) << "cap " << cap;
        EXPECT_GT(s.error_bound_pixels, o.tau_pixels);
    }
}

} // namespace
} // namespace terrain::client
