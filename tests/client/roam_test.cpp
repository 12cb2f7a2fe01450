// The ROAM tessellator against properties it must keep: conformity (no cracks, no T-junctions),
// the tau-pixel error bound measured on the true surface, agreement of split/merge with
// split-only, locality of re-tessellation after a crater, no allocation in a steady frame, and
// graceful behaviour at the triangle cap.

#include "support/mesh_checks.h"
#include "support/terrain_builders.h"

#include <terrain/roam/screen_error.h>
#include <terrain/roam/tessellator.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace terrain::testing {
namespace {

using roam::Camera;
using roam::TessellationMode;
using roam::Tessellator;
using roam::TessellatorOptions;

Camera lookAt(glm::dvec3 eye, glm::dvec3 target, double fovy_degrees = 60.0) {
    Camera c;
    c.eye = eye;
    c.forward = target - eye;
    c.fovy_radians = fovy_degrees * M_PI / 180.0;
    c.viewport_width = 640;
    c.viewport_height = 360;
    c.near_plane = 0.25;
    return c;
}

/// A camera above the surface somewhere over the map, looking at another point of it.
Camera randomCamera(const Terrain& t, std::mt19937_64& rng) {
    std::uniform_real_distribution<double> ux(0.0, t.spec().extentX());
    std::uniform_real_distribution<double> uy(0.0, t.spec().extentY());
    std::uniform_real_distribution<double> up(0.5, 40.0);
    const double x = ux(rng);
    const double y = uy(rng);
    const glm::dvec3 eye{x, y, surfaceHeight(t, x, y) + up(rng)};
    const double tx = ux(rng);
    const double ty = uy(rng);
    return lookAt(eye, glm::dvec3(tx, ty, surfaceHeight(t, tx, ty)));
}

Terrain cratered(std::uint64_t seed, int craters) {
    Terrain t = makeHills(seed);
    CraterSeries s;
    s.seed = seed;
    s.count = craters;
    applyAll(t, randomCraters(t.spec(), s));
    return t;
}

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

TEST(RoamMesh, ConformsAndMeetsTauOnHillsWithCraters) {
    const Terrain t = cratered(7, 40);
    ASSERT_GT(t.patchCount(), 0u);
    TessellatorOptions o;
    o.tau_pixels = 1.0;
    Tessellator tess(t, o);
    std::mt19937_64 rng(3);
    for (int i = 0; i < 6; ++i) {
        const Camera cam = randomCamera(t, rng);
        const auto stats = tess.update(cam);
        EXPECT_GT(stats.triangles, 0);
        expectConforming(tess, t.spec());
        expectIndexListsMatchMesh(tess);
        const auto err = roam::measureScreenError(tess, t, cam);
        EXPECT_LE(err.max_pixels, o.tau_pixels) << "camera " << i;
        EXPECT_EQ(tess.missingBlockRefusals(), 0);
    }
}

} // namespace
} // namespace terrain::testing
