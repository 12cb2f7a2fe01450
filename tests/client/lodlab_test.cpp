// The speed-against-accuracy lab: the chunked baseline is conforming and within the error it
// states from every flight (craters included), its cap binds and says so, an op reloads only the
// chunks it touches, and every method runs every flight on the same world.

#include "support/terrain_builders.h"

#include <terrain/battle.h>
#include <terrain/lodlab/chunked_lod.h>
#include <terrain/lodlab/flights.h>
#include <terrain/lodlab/lod_method.h>
#include <terrain/lodlab/screen_measure.h>
#include <terrain/procedural_map.h>

#include <gtest/gtest.h>

namespace terrain::lodlab {
namespace {

using terrain::testing::applyRequest;

/// A procedural map of width x height vertices with `shots` battle craters at its centre
/// (patches among them). 300 x 200 cells: the coarser chunks reach beyond the map.
Terrain smallWorld(int shots, std::int32_t width = 129, std::int32_t height = 129) {
    ProceduralMapOptions o;
    o.width = width;
    o.height = height;
    Terrain t = *makeProceduralMap(o);
    BattleGenerator gen = battleGenerator(t);
    fireShots(gen, t, shots);
    return t;
}

/// Open edges of the chunked mesh, in view or not, inside the map.
std::int64_t openEdges(const ChunkedLod& lod, const Terrain& t) {
    std::vector<std::array<std::int32_t, 6>> grid;
    lod.gridTriangles(false, grid);
    std::vector<LatticeTriangle> mesh;
    for (const auto& g : grid)
        mesh.push_back({g[0], g[1], g[2], g[3], g[4], g[5]});
    return countOpenEdges(mesh, t.spec().cellsX(), t.spec().cellsY());
}

std::int64_t openEdges(const LodMethod& lod, const Terrain& t) {
    std::vector<LatticeTriangle> mesh;
    lod.allTriangles(mesh);
    return countOpenEdges(
        mesh, std::int64_t{t.spec().cellsX()} * 16, std::int64_t{t.spec().cellsY()} * 16);
}

std::vector<FlightFrame> framesOf(const Terrain& t, FlightKind kind) {
    FlightOptions o;
    o.kind = kind;
    o.frames = 120;
    o.width = 320;
    o.height = 180;
    return makeFlight(t, o);
}

TEST(ChunkedLod, IsConformingAndWithinItsStatedErrorOnEveryFlight) {
    const Terrain t = smallWorld(60, 301, 201);
    ASSERT_GT(t.patchCount(), 0u);
    for (const double tau : {0.5, 2.0}) {
        for (FlightKind kind : kAllFlights) {
            ChunkedLod lod(t, {tau, std::int64_t{1} << 40, 300});
            const auto frames = framesOf(t, kind);
            for (std::size_t i = 0; i < frames.size(); i += 30) {
                const ChunkedFrame f = lod.update(frames[i].camera);
                EXPECT_EQ(openEdges(lod, t), 0) << toString(kind) << " frame " << i;
                std::vector<glm::dvec3> drawn;
                lod.triangles(true, drawn);
                ASSERT_EQ(drawn.size() / 3, static_cast<std::size_t>(f.triangles));
                ScreenErrorOptions so;
                so.samples_per_cell = 4.0;
                so.tau_pixels = tau;
                const MeshError e = measureMeshError(drawn, t, frames[i].camera, so);
                // the stated bound holds, and where it is within tau, so is what is drawn
                EXPECT_LE(e.max_pixels, f.error_bound_pixels + 1e-6)
                    << toString(kind) << " frame " << i;
                if (f.chunks_over_tau == 0) {
                    EXPECT_LE(e.max_pixels, tau + 1e-6) << toString(kind) << " frame " << i;
                }
                EXPECT_FALSE(f.capped);
            }
        }
    }
}

TEST(ChunkedLod, WithoutPatchesEveryDrawnChunkIsWithinTau) {
    const Terrain t = smallWorld(0);
    ChunkedLod lod(t, {1.0, std::int64_t{1} << 40, 300});
    for (FlightKind kind : {FlightKind::kLow, FlightKind::kHover, FlightKind::kWhip}) {
        const auto frames = framesOf(t, kind);
        for (std::size_t i = 0; i < frames.size(); i += 29) {
            const ChunkedFrame f = lod.update(frames[i].camera);
            EXPECT_EQ(f.chunks_over_tau, 0) << toString(kind);
            EXPECT_LE(f.error_bound_pixels, 1.0) << toString(kind);
            EXPECT_GT(f.chunks_drawn, 0);
        }
    }
    // a base-step chunk without patches is the surface itself
    EXPECT_EQ(lod.chunkError(0, 0, 0), 0.0);
    EXPECT_GT(lod.chunkError(lod.levels() - 1, 0, 0), 0.0);
}

TEST(ChunkedLod, ATriangleCapBindsAndTheBoundSaysWhatItCost) {
    const Terrain t = smallWorld(0);
    const auto frames = framesOf(t, FlightKind::kLow);
    ChunkedLod free(t, {0.5, std::int64_t{1} << 40, 300});
    const ChunkedFrame open = free.update(frames[0].camera);
    ChunkedLod capped(t, {0.5, 2500, 300});
    const ChunkedFrame f = capped.update(frames[0].camera);
    EXPECT_TRUE(f.capped);
    EXPECT_LT(f.triangles, open.triangles);
    EXPECT_GT(f.error_bound_pixels, 0.5);
    EXPECT_EQ(openEdges(capped, t), 0);
}

TEST(ChunkedLod, AnOpReloadsOnlyTheLoadedChunksItTouches) {
    Terrain t = smallWorld(0);
    const auto frames = framesOf(t, FlightKind::kHover);
    ChunkedLod lod(t, {1.0, std::int64_t{1} << 40, 300});
    const ChunkedFrame first = lod.update(frames[0].camera);
    EXPECT_GT(first.upload_bytes, 0);
    EXPECT_EQ(lod.update(frames[0].camera).upload_bytes, 0) << "nothing changed";
    const BattleZone z = battleZone(t);
    OpRequest crater;
    crater.kind = OpKind::kCrater;
    crater.x = z.x;
    crater.y = z.y;
    crater.radius = 3.0;
    crater.height = 1.5;
    const std::vector<CellRect> cells = {applyRequest(t, crater)};
    ASSERT_FALSE(cells[0].empty());
    lod.terrainChanged(cells, false);
    const ChunkedFrame after = lod.update(frames[0].camera);
    EXPECT_GT(after.upload_bytes, 0);
    EXPECT_LT(after.upload_bytes, first.upload_bytes / 2);
}

// every 60th frame of each flight; under sanitizers every 180th (the test took 74 s there)
#if defined(__SANITIZE_ADDRESS__)
constexpr std::size_t kFrameStride = 180;
#else
constexpr std::size_t kFrameStride = 60;
#endif

TEST(LodMethods, EveryMethodRunsEveryFlightOnTheSameWorld) {
    const Terrain t = smallWorld(30);
    for (Method m : kAllMethods) {
        EXPECT_EQ(parseMethod(toString(m)), m);
        for (FlightKind kind : kAllFlights) {
            EXPECT_EQ(parseFlight(toString(kind)), kind);
            auto lod = makeMethod(m, t, {1.0, std::int64_t{1} << 40});
            ASSERT_EQ(lod->method(), m);
            const auto frames = framesOf(t, kind);
            for (std::size_t i = 0; i < frames.size(); i += kFrameStride) {
                const MethodFrame f = lod->update(frames[i].camera);
                EXPECT_GT(f.triangles, 0) << toString(m) << " " << toString(kind);
                std::vector<glm::dvec3> drawn;
                lod->visibleTriangles(drawn);
                EXPECT_EQ(static_cast<std::int64_t>(drawn.size() / 3), f.triangles)
                    << toString(m) << " " << toString(kind);
                const MeshError e = measureMeshError(drawn, t, frames[i].camera, {});
                if (m == Method::kFullMesh) {
                    // at the lattice's 1/16 cell: within a pixel of the B-spline patches even
                    // from a few metres
                    EXPECT_LT(e.max_pixels, 1.0) << "the full mesh is the surface";
                } else {
                    EXPECT_LE(e.max_pixels, f.error_bound_pixels + 1e-6) << toString(m);
                }
                if (m != Method::kFullMesh) {
                    EXPECT_EQ(openEdges(*lod, t), 0) << toString(m) << " " << toString(kind);
                }
            }
        }
    }
}

TEST(LodMethods, TheFullMeshShowsItsTJunctionsAtPatchBorders) {
    // a patch cell is drawn at the lattice's 1/16 cell beside base cells drawn whole: the
    // count of open edges says so (geometrically closed: patch borders are straight or shared)
    const Terrain t = smallWorld(30);
    auto lod = makeMethod(Method::kFullMesh, t, {});
    EXPECT_GT(openEdges(*lod, t), 0);
    const Terrain plain = smallWorld(0);
    lod = makeMethod(Method::kFullMesh, plain, {});
    EXPECT_EQ(openEdges(*lod, plain), 0);
}

TEST(ScreenMeasure, OpenEdgesFindACrack) {
    // two triangles sharing an edge, then one of them split on that edge alone (a T-junction)
    std::vector<LatticeTriangle> ok = {{0, 0, 2, 0, 0, 2}, {2, 0, 2, 2, 0, 2}};
    EXPECT_EQ(countOpenEdges(ok, 2, 2), 0);
    std::vector<LatticeTriangle> t = {{0, 0, 2, 0, 0, 2}, {2, 0, 2, 2, 1, 1}, {1, 1, 2, 2, 0, 2}};
    EXPECT_EQ(countOpenEdges(t, 2, 2), 3); // the long edge once, its two halves once each
    EXPECT_EQ(countOpenEdges(t, 1, 1), 0); // all of it on or beyond the border of a smaller map
}

} // namespace
} // namespace terrain::lodlab
