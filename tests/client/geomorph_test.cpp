// Geomorphing (Tessellator::morphedHeights): the drawn surface is within tau at every frame of
// every flight while vertices slide, a split at the threshold or a merge below it moves nothing
// drawn, every copy of a vertex (tiles, cell blocks) is drawn at one height, and without a band
// every vertex is at its own height.

#include <terrain/battle.h>
#include <terrain/lodlab/flights.h>
#include <terrain/lodlab/screen_measure.h>
#include <terrain/procedural_map.h>
#include <terrain/roam/tessellator.h>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <utility>

namespace terrain::roam {
namespace {

/// A procedural map with battle craters (patches among them) at its centre, over several tiles.
Terrain craterWorld(int shots) {
    ProceduralMapOptions o;
    o.width = 201;
    o.height = 161;
    Terrain t = *makeProceduralMap(o);
    BattleGenerator gen = lodlab::battleGenerator(t);
    lodlab::fireShots(gen, t, shots);
    return t;
}

std::vector<lodlab::FlightFrame> flight(const Terrain& t, lodlab::FlightKind kind) {
    lodlab::FlightOptions o;
    o.kind = kind;
    o.frames = 60;
    o.width = 320;
    o.height = 180;
    return lodlab::makeFlight(t, o);
}

using Key = std::pair<std::int32_t, std::int32_t>;

/// Every drawn vertex of the visible tiles: lattice point -> drawn height (metres); fails the
/// test if two copies of one point differ. Also the drawn triangles in world metres.
struct Drawn {
    std::map<Key, double> heights;
    std::vector<glm::dvec3> triangles;
    std::int64_t sliding = 0; ///< drawn vertices away from their own height
};

Drawn drawnMesh(const Tessellator& tess, const Camera& camera, double full_pixels) {
    Drawn d;
    const ViewMetric view(camera);
    std::vector<double> heights;
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile) {
        if (!tess.tileVisible(tile))
            continue;
        // NaN where the walk writes nothing: a vertex of the mesh must not be one of them
        heights.assign(static_cast<std::size_t>(tess.tileVertexCount(tile)), std::nan(""));
        tess.morphedHeights(tile, view, full_pixels, heights);
        const auto indices = tess.tileMesh(tile).indices();
        for (const std::uint32_t i : indices) {
            const TileVertex v = tess.tileVertex(tile, i);
            const double z = heights[i];
            EXPECT_FALSE(std::isnan(z)) << "a vertex of the mesh left unwritten";
            const auto [at, fresh] = d.heights.emplace(Key{v.position.x, v.position.y}, z);
            EXPECT_EQ(at->second, z) << "two copies of (" << v.position.x << ", " << v.position.y
                                     << ") drawn at different heights: a crack";
            if (fresh &&
                std::abs(z - static_cast<double>(v.height) * tess.metresPerFineUnit()) > 1e-9)
                ++d.sliding;
            d.triangles.push_back(
                {v.position.x * tess.metresPerLattice(), v.position.y * tess.metresPerLattice(),
                 z});
        }
    }
    return d;
}

/// The drawn surface's height at lattice point p (inside some drawn triangle), by barycentric
/// interpolation; NaN if no triangle holds it.
double heightAt(const Drawn& d, const Tessellator& tess, Key p) {
    const double x = p.first * tess.metresPerLattice();
    const double y = p.second * tess.metresPerLattice();
    for (std::size_t i = 0; i + 2 < d.triangles.size(); i += 3) {
        const glm::dvec3 a = d.triangles[i];
        const glm::dvec3 b = d.triangles[i + 1];
        const glm::dvec3 c = d.triangles[i + 2];
        const double det = (b.y - c.y) * (a.x - c.x) + (c.x - b.x) * (a.y - c.y);
        if (det == 0.0)
            continue;
        const double wa = ((b.y - c.y) * (x - c.x) + (c.x - b.x) * (y - c.y)) / det;
        const double wb = ((c.y - a.y) * (x - c.x) + (a.x - c.x) * (y - c.y)) / det;
        const double wc = 1.0 - wa - wb;
        constexpr double kEps = -1e-9;
        if (wa >= kEps && wb >= kEps && wc >= kEps)
            return wa * a.z + wb * b.z + wc * c.z;
    }
    return std::nan("");
}

TEST(Geomorph, TheDrawnSurfaceIsWithinTauAtEveryFrameOfEveryFlight) {
    const Terrain t = craterWorld(80);
    ASSERT_GT(t.patchCount(), 0u);
    constexpr double kTau = 1.0;
    constexpr double kFraction = 0.5;
    std::int64_t sliding = 0;
    int checked = 0;
    for (const lodlab::FlightKind kind : {lodlab::FlightKind::kLow, lodlab::FlightKind::kBattle}) {
        TessellatorOptions o;
        o.tau_pixels = kFraction * kTau;
        Tessellator tess(t, o);
        const auto frames = flight(t, kind);
        for (std::size_t i = 0; i < frames.size(); ++i) {
            const FrameStats s = tess.update(frames[i].camera);
            if (i % 10 != 0)
                continue;
            const Drawn d = drawnMesh(tess, frames[i].camera, tess.threshold() / kFraction);
            sliding += d.sliding;
            lodlab::ScreenErrorOptions so;
            so.tau_pixels = kTau;
            const lodlab::MeshError e =
                lodlab::measureMeshError(d.triangles, t, frames[i].camera, so);
            if (!s.budget_exhausted) {
                ++checked;
                EXPECT_LE(e.max_pixels, std::max(kTau, s.error_bound_pixels / kFraction) + 1e-6)
                    << lodlab::toString(kind) << " frame " << i;
            }
        }
    }
    EXPECT_GT(sliding, 100) << "the flights must catch vertices mid-slide";
    EXPECT_GE(checked, 8) << "most measured frames must have kept up with their work";
}

TEST(Geomorph, ASplitAtTheThresholdOrAMergeBelowItMovesNothingDrawn) {
    const Terrain t = craterWorld(40);
    TessellatorOptions o;
    o.tau_pixels = 0.5;
    Tessellator tess(t, o);
    const auto frames = flight(t, lodlab::FlightKind::kLow);
    const Camera& cam = frames[30].camera;
    for (int i = 0; i <= 30; ++i)
        tess.update(frames[static_cast<std::size_t>(i)].camera);
    ASSERT_FALSE(tess.update(cam).budget_exhausted);
    const Drawn before = drawnMesh(tess, cam, 1.0);
    ASSERT_GT(before.sliding, 0);

    // a leaf a few levels coarser than the cells, wholly in view: its diamond, and any
    // ancestor the split forces, are in the frustum and below the threshold (else they would be
    // split). (One out of view is not split whatever its priority: it pops in as the view turns
    // to it, morphing or not.)
    const ViewMetric view(cam);
    LatticePoint target{-1, -1};
    tess.forEachLeaf([&](const Triangle& tri, std::int32_t tile, bool emitted) {
        if (target.x >= 0 || !emitted || !tess.tileVisible(tile) || tri.level < 6 ||
            tri.level >= kCellTriangleLevel)
            return;
        for (const LatticePoint p : {tri.apex, tri.left, tri.right}) {
            const Key k{p.x, p.y};
            const auto z = before.heights.find(k);
            if (z == before.heights.end() ||
                !view.isVisible(view.project(
                    {p.x * tess.metresPerLattice(), p.y * tess.metresPerLattice(), z->second})))
                return;
        }
        target = splitPoint(tri);
    });
    ASSERT_GE(target.x, 0);
    FrameStats stats;
    ASSERT_TRUE(tess.splitAt(target, stats));
    const Drawn split = drawnMesh(tess, cam, 1.0);
    EXPECT_GT(split.heights.size(), before.heights.size());
    int fresh = 0;
    for (const auto& [p, z] : split.heights) {
        const auto old = before.heights.find(p);
        if (old != before.heights.end()) {
            EXPECT_EQ(z, old->second) << "a drawn vertex moved";
        } else {
            ++fresh;
            EXPECT_NEAR(z, heightAt(before, tess, p), 1e-6) << "a new vertex off the drawn surface";
        }
    }
    EXPECT_GT(fresh, 0);

    // the next frame merges it back: the drawn mesh is the one before
    tess.update(cam);
    const Drawn merged = drawnMesh(tess, cam, 1.0);
    EXPECT_EQ(merged.heights, before.heights);
}

TEST(Geomorph, WithoutABandEveryVertexIsAtItsHeight) {
    const Terrain t = craterWorld(40);
    Tessellator tess(t, {});
    const auto frames = flight(t, lodlab::FlightKind::kBattle);
    tess.update(frames[10].camera);
    const Drawn d = drawnMesh(tess, frames[10].camera, tess.threshold());
    EXPECT_GT(d.heights.size(), 100u);
    EXPECT_EQ(d.sliding, 0);
}

} // namespace
} // namespace terrain::roam
