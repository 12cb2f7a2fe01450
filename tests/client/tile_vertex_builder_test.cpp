// TileVertexBuilder's cache of cell height grids: however small it is, and whatever it evicted
// or was told the terrain changed, a builder builds the same vertices (bits) as a fresh one.

#include "support/terrain_builders.h"

#include <terrain/roam/tessellator.h>
#include <terrain/roam/tile_vertex_builder.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

namespace terrain::testing {
namespace {

using roam::Camera;
using roam::DrawVertex;
using roam::Tessellator;
using roam::TileVertexBuilder;

Camera lowCamera(const Terrain& t, double x, double y) {
    Camera c;
    c.eye = glm::dvec3(x, y, surfaceHeight(t, x, y) + 6.0);
    c.forward = glm::dvec3(0.8, 0.6, -0.35);
    c.fovy_radians = 60.0 * M_PI / 180.0;
    c.viewport_width = 640;
    c.viewport_height = 360;
    c.near_plane = 0.25;
    return c;
}

/// Every tile's whole vertex array, as `builder` builds it.
std::vector<DrawVertex>
buildAll(TileVertexBuilder& builder, const Tessellator& tess, const Terrain& t) {
    std::vector<DrawVertex> all;
    std::vector<DrawVertex> tile;
    for (std::int32_t k = 0; k < tess.tileCount(); ++k) {
        tile.resize(static_cast<std::size_t>(tess.tileVertexCount(k)));
        builder.build(tess, t, k, 0, tile);
        all.insert(all.end(), tile.begin(), tile.end());
    }
    return all;
}

bool sameBits(const std::vector<DrawVertex>& a, const std::vector<DrawVertex>& b) {
    return a.size() == b.size() &&
           std::memcmp(a.data(), b.data(), a.size() * sizeof(DrawVertex)) == 0;
}

TEST(TileVertexBuilder, ACacheOfAFewGridsEvictsAndBuildsTheSameVerticesAsAFreshBuilder) {
    Terrain t = makeHills(31, 129, 129);
    CraterSeries s;
    s.seed = 31;
    s.count = 40;
    applyAll(t, randomCraters(t.spec(), s));
    Tessellator tess(t, {});
    tess.update(lowCamera(t, 40.0, 40.0));

    TileVertexBuilder small(3); // evicts on almost every new cell
    TileVertexBuilder large(1 << 20);
    const std::vector<DrawVertex> first = buildAll(small, tess, t);
    ASSERT_FALSE(first.empty());
    EXPECT_TRUE(sameBits(first, buildAll(large, tess, t)));
    EXPECT_GT(large.cachedGrids(), 100u) << "the view draws few detail blocks: nothing evicted";
    EXPECT_LE(small.cachedGrids(), 3u);
    EXPECT_TRUE(sameBits(first, buildAll(small, tess, t))) << "built again from a warm cache";
    // (the vertices use the grids: a builder without normals differs)
    std::size_t with_normals = 0;
    for (const DrawVertex& v : first)
        with_normals += v.normal != 0 ? 1 : 0;
    EXPECT_GT(with_normals, first.size() / 2);

    // craters under the view: each builder told of the cells they changed keeps the rest of its
    // cache, and still builds what a fresh builder does
    for (int k = 0; k < 6; ++k) {
        OpRequest r;
        r.x = 48.0 + 3.0 * k;
        r.y = 46.0 + 2.0 * k;
        r.radius = 3.0;
        r.height = 1.0;
        r.strength = 0.5;
        const auto effect = t.apply(*quantizeOp(r, t.spec()));
        ASSERT_TRUE(static_cast<bool>(effect));
        tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
        tess.update(lowCamera(t, 40.0, 40.0));
        small.forget(effect->cells);
        large.forget(effect->cells);
        TileVertexBuilder fresh;
        const std::vector<DrawVertex> want = buildAll(fresh, tess, t);
        EXPECT_TRUE(sameBits(want, buildAll(small, tess, t))) << "crater " << k << ", small cache";
        EXPECT_TRUE(sameBits(want, buildAll(large, tess, t))) << "crater " << k << ", large cache";
    }
}

TEST(TileVertexBuilder, ABuilderNotToldOfAChangeKeepsTheOldGridsUntilItIs) {
    // what the test above would miss if forget() dropped nothing: a cached grid of a cell an op
    // changed is read until the builder is told
    Terrain t = makeHills(37, 129, 129);
    Tessellator tess(t, {});
    const Camera view = lowCamera(t, 40.0, 40.0);
    tess.update(view);
    TileVertexBuilder builder;
    const auto crater = [&](double height) {
        OpRequest r;
        r.x = 52.0;
        r.y = 49.0;
        r.radius = 3.0;
        r.height = height;
        r.strength = 0.5;
        const auto effect = t.apply(*quantizeOp(r, t.spec()));
        EXPECT_TRUE(static_cast<bool>(effect));
        tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
        tess.update(view);
        return effect->cells;
    };
    // the first crater makes detail blocks there, and the builder caches their cells' grids
    builder.forget(crater(1.0));
    buildAll(builder, tess, t);
    ASSERT_GT(builder.cachedGrids(), 10u);
    // the second lands on them, and the builder is not told
    const CellRect second = crater(1.0);
    TileVertexBuilder fresh;
    const std::vector<DrawVertex> want = buildAll(fresh, tess, t);
    EXPECT_FALSE(sameBits(want, buildAll(builder, tess, t))) << "stale grids went unnoticed";
    builder.forget(second);
    EXPECT_TRUE(sameBits(want, buildAll(builder, tess, t)));
}

} // namespace
} // namespace terrain::testing
