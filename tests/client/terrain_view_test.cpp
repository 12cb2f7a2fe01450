// The client's terrain frame (client/view): a view fed op by op draws what a tessellator built
// on the final state draws, the cap follows slow frames, and a click becomes the crater under it.

#include <terrain/client/terrain_view.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <array>
#include <set>

namespace terrain::client {
namespace {

Terrain viewMap() {
    ProceduralMapOptions o;
    o.width = 193;
    o.height = 129;
    return std::move(*makeProceduralMap(o));
}

roam::Camera downAt(const Terrain& t, double x, double y, double above) {
    roam::Camera c;
    c.eye = {x, y, surfaceHeight(t, x, y) + above};
    c.forward = {0.0, 0.0, -1.0};
    c.up = {0.0, 1.0, 0.0};
    c.viewport_width = 640;
    c.viewport_height = 360;
    return c;
}

std::set<std::array<std::int32_t, 6>> leaves(const roam::Tessellator& tess) {
    std::set<std::array<std::int32_t, 6>> out;
    tess.forEachLeaf([&](const roam::Triangle& t, std::int32_t, bool) {
        out.insert({t.apex.x, t.apex.y, t.left.x, t.left.y, t.right.x, t.right.y});
    });
    return out;
}

TEST(TerrainView, FedOpByOpItDrawsWhatAFreshTessellatorOfTheFinalStateDraws) {
    Terrain server = viewMap();
    Replica replica;
    replica.loadSnapshot(std::move(*decodeSnapshot(encodeSnapshot(server, 1))));
    TerrainViewOptions o;
    TerrainView view(replica, o);
    EXPECT_FALSE(view.absorb()) << "the view starts from the replica's state";
    const roam::Camera cam = downAt(server, 96.0, 64.0, 60.0);
    view.update(cam);
    std::uint64_t seq = 1;
    for (int i = 0; i < 12; ++i) {
        const DeformOp op =
            *quantizeOp(OpRequest{OpKind::kCrater, 60.0 + 6.0 * i, 64.0, 4, 2, 0.3}, server.spec());
        ASSERT_TRUE(server.apply(op).ok());
        ASSERT_TRUE(replica.applyOp(++seq, op, server.worldHash()).ok());
        EXPECT_TRUE(view.absorb());
        view.update(cam);
    }
    for (int frame = 0; frame < 50 && view.lastStats().budget_exhausted; ++frame)
        view.update(cam);
    roam::Tessellator fresh(server, o.tessellation);
    fresh.update(cam);
    EXPECT_EQ(leaves(view.tessellator()), leaves(fresh));
    EXPECT_EQ(view.lastStats().triangles, fresh.triangleCount());
}

TEST(TerrainView, SlowFramesLowerTheTriangleCap) {
    const Terrain t = viewMap();
    Replica replica;
    replica.loadSnapshot(std::move(*decodeSnapshot(encodeSnapshot(t, 1))));
    TerrainViewOptions o;
    o.tessellation.tau_pixels = 0.5;
    o.budget.target_ms = 10.0;
    o.budget.max_triangles = 400'000;
    o.budget.min_triangles = 1'000;
    TerrainView view(replica, o);
    const roam::Camera cam = downAt(t, 96.0, 64.0, 30.0);
    const std::int64_t before = view.tessellator().options().max_triangles;
    for (int frame = 0; frame < 40; ++frame) {
        view.update(cam);
        view.steer(40.0); // four times the target
    }
    EXPECT_LT(view.tessellator().options().max_triangles, before);
    view.update(cam);
    EXPECT_LE(view.lastStats().triangles, view.tessellator().options().max_triangles)
        << "the mesh keeps under the cap it steered";
}

TEST(TerrainView, AClickAsksForTheCraterUnderThePixelAndASkyClickForNone) {
    const Terrain t = viewMap();
    roam::Camera cam = downAt(t, 80.0, 50.0, 40.0);
    const CraterShape shape{.radius = 5.0, .depth = 2.0, .rim = 0.3};
    const std::optional<OpRequest> centre = craterAtPixel(t, cam, 320.0, 180.0, shape);
    ASSERT_TRUE(centre.has_value());
    EXPECT_EQ(centre->kind, OpKind::kCrater);
    EXPECT_NEAR(centre->x, 80.0, 1e-6);
    EXPECT_NEAR(centre->y, 50.0, 1e-6);
    EXPECT_EQ(centre->radius, 5.0);
    EXPECT_EQ(centre->height, 2.0);
    EXPECT_EQ(centre->strength, 0.3);
    // the top of the picture is +y (up is +y looking down): the hit lies north of the centre
    const std::optional<OpRequest> north = craterAtPixel(t, cam, 320.0, 10.0, shape);
    ASSERT_TRUE(north.has_value());
    EXPECT_GT(north->y, 55.0);
    cam.forward = {0.0, 0.0, 1.0}; // at the sky
    cam.up = {0.0, 1.0, 0.0};
    EXPECT_FALSE(craterAtPixel(t, cam, 320.0, 180.0, shape).has_value());
}

} // namespace
} // namespace terrain::client
