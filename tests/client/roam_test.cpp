// The ROAM tessellator against properties it must keep: conformity (no cracks, no T-junctions),
// the tau-pixel error bound measured on the true surface, agreement of split/merge with
// split-only, locality of re-tessellation after a crater, no allocation in a steady frame, and
// graceful behaviour at the triangle cap.

#include "support/mesh_checks.h"
#include "support/terrain_builders.h"

#include <terrain/battle.h>
#include <terrain/client/replica.h>
#include <terrain/io/dem_import.h>
#include <terrain/roam/screen_error.h>
#include <terrain/roam/tessellator.h>
#include <terrain/snapshot.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <new>
#include <random>
#include <set>

// Allocation counting for the steady-state test: every operator new in this binary goes
// through here; only allocations made while counting is on are counted.
namespace {
std::atomic<bool> g_counting{false};
std::atomic<std::int64_t> g_allocations{0};
} // namespace

void* operator new(std::size_t size) {
    if (g_counting.load(std::memory_order_relaxed))
        g_allocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(size == 0 ? 1 : size))
        return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
    return operator new(size);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}

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

/// Updates for `cam` until a frame finishes within the work budget (a jump across the map
/// re-tessellates more than one frame's budget); fails the test if it never does.
roam::FrameStats updateUntilSettled(Tessellator& tess, const Camera& cam) {
    roam::FrameStats stats = tess.update(cam);
    for (int frame = 1; stats.budget_exhausted && frame < 200; ++frame)
        stats = tess.update(cam);
    EXPECT_FALSE(stats.budget_exhausted) << "still over the work budget after 200 frames";
    return stats;
}

Terrain cratered(std::uint64_t seed, int craters) {
    Terrain t = makeHills(seed);
    CraterSeries s;
    s.seed = seed;
    s.count = craters;
    applyAll(t, randomCraters(t.spec(), s));
    return t;
}

TEST(RoamMesh, ConformsAndMeetsTauOnHillsWithCraters) {
    const Terrain t = cratered(7, 40);
    ASSERT_GT(t.patchCount(), 0u);
    TessellatorOptions o;
    o.tau_pixels = 1.0;
    o.max_detail_blocks = 1 << 20; // views of the whole map: tau, not the pool, must bind
    Tessellator tess(t, o);
    std::mt19937_64 rng(3);
    for (int i = 0; i < 6; ++i) {
        const Camera cam = randomCamera(t, rng);
        const auto stats = updateUntilSettled(tess, cam);
        EXPECT_GT(stats.triangles, 0);
        expectConforming(tess, t.spec());
        expectIndexListsMatchMesh(tess);
        const auto err = roam::measureScreenError(tess, t, cam);
        EXPECT_LE(err.max_pixels, o.tau_pixels) << "camera " << i;
        EXPECT_EQ(tess.missingBlockRefusals(), 0);
    }
}

TEST(RoamMesh, ACellsErrorBoundsEveryTriangleOnItsBlock) {
    // DetailBlocks::cellError is what lets a cell's coarse diamonds carry true bounds without
    // its heights: every triangle of every level inside the cell, on the block's rounded
    // vertices, must be within it of the patch
    const Terrain t = cratered(7, 40);
    roam::DetailBlocks blocks;
    blocks.reset(t);
    std::int64_t checked = 0;
    double tightest = 1e9; // smallest margin seen, fine units
    for (std::int32_t r = 0; r < blocks.recordCapacity(); r += 7) {
        if (!blocks.recordInUse(r) || !blocks.hasPatch(r))
            continue;
        const auto cell = blocks.recordCell(r);
        const DetailPatch* patch = t.findPatch(cell.x, cell.y);
        ASSERT_NE(patch, nullptr);
        std::array<std::int64_t, roam::kBlockVertices> heights{};
        roam::fillCellHeights(t, cell.x, cell.y, heights);
        const double bound = blocks.cellError(r);
        const roam::LatticePoint o{cell.x * 16, cell.y * 16};
        const roam::Diamond centre = roam::diamondAt({o.x + 8, o.y + 8});
        std::vector<roam::Triangle> stack;
        for (const roam::LatticePoint a : roam::apexes(centre))
            stack.push_back(roam::triangleOf(centre, a));
        while (!stack.empty()) {
            const roam::Triangle tri = stack.back();
            stack.pop_back();
            if (tri.level < roam::kFinestTriangleLevel)
                for (const roam::Triangle& h : roam::splitTriangle(tri))
                    stack.push_back(h);
            const std::array<roam::LatticePoint, 3> v = {tri.apex, tri.left, tri.right};
            std::array<double, 3> z{};
            for (std::size_t i = 0; i < 3; ++i)
                z[i] = static_cast<double>(heights[static_cast<std::size_t>(
                    (v[i].y - o.y) * roam::kBlockSide + (v[i].x - o.x))]);
            for (int i = 0; i <= 4; ++i)
                for (int j = 0; i + j <= 4; ++j) {
                    const double l0 = i / 4.0, l1 = j / 4.0, l2 = 1.0 - l0 - l1;
                    const double x = l0 * v[0].x + l1 * v[1].x + l2 * v[2].x - o.x;
                    const double y = l0 * v[0].y + l1 * v[1].y + l2 * v[2].y - o.y;
                    const double surface = 16.0 * patchHeight(*patch, x / 16.0, y / 16.0);
                    const double plane = l0 * z[0] + l1 * z[1] + l2 * z[2];
                    const double err = std::abs(surface - plane);
                    ASSERT_LE(err, bound + 1e-6)
                        << "cell " << cell.x << "," << cell.y << " level " << tri.level;
                    tightest = std::min(tightest, bound - err);
                    ++checked;
                }
        }
    }
    EXPECT_GT(checked, 100000);
    EXPECT_GE(tightest, 0.0);
}

TEST(RoamMesh, StridedCellHeightsAreTheFullGridsOwn) {
    // after an op, a block's heights are refilled at its grains' vertices only (every 4th or
    // 2nd point for coarse and medium blocks): they must be the full grid's values there
    const Terrain t = cratered(7, 40);
    std::int64_t compared = 0;
    for (std::int32_t cy = 0; cy < t.spec().cellsY(); cy += 3)
        for (std::int32_t cx = 0; cx < t.spec().cellsX(); cx += 3) {
            if (t.findPatch(cx, cy) == nullptr && (cx + cy) % 31 != 0)
                continue; // every patch cell of the sample, and some without
            std::array<std::int64_t, roam::kBlockVertices> full{};
            roam::fillCellHeights(t, cx, cy, full);
            for (const std::int32_t stride : {2, 4}) {
                std::array<std::int64_t, roam::kBlockVertices> part{};
                roam::fillCellHeights(t, cx, cy, part, stride);
                for (std::int32_t l = 0; l < roam::kBlockSide; l += stride)
                    for (std::int32_t k = 0; k < roam::kBlockSide; k += stride) {
                        const auto i = static_cast<std::size_t>(l * roam::kBlockSide + k);
                        ASSERT_EQ(part[i], full[i])
                            << "cell " << cx << "," << cy << " (" << k << "," << l << ")";
                        ++compared;
                    }
            }
        }
    EXPECT_GT(compared, 10000);
}

/// Every diamond of every detail cell of `t` (their centres included), in cell order.
template <class Visit> void forEachDetailDiamond(const Terrain& t, Visit&& visit) {
    for (std::int32_t cy = 0; cy < t.spec().paddedHeight(); ++cy)
        for (std::int32_t cx = 0; cx < t.spec().paddedWidth(); ++cx)
            for (std::int32_t l = 0; l < 16; ++l)
                for (std::int32_t k = 0; k < 16; ++k)
                    if ((k | l) != 0)
                        visit(roam::LatticePoint{cx * 16 + k, cy * 16 + l});
}

TEST(RoamMesh, LazyBoundsEqualBoundsBuiltForEveryCellAtOnce) {
    // a block's bounds are made when a split first needs it, from the 3 x 3 cells around it
    // (resident or made for the pass only); they must be the ones a pass over every block at
    // once makes, whatever order the blocks came in
    const Terrain t = cratered(7, 40);
    TessellatorOptions o;
    Tessellator lazy(t, o);
    std::mt19937_64 rng(3);
    for (int i = 0; i < 4; ++i)
        lazy.update(randomCamera(t, rng));
    ASSERT_GT(lazy.blockCount(), 0);
    ASSERT_LT(lazy.blockCount(), lazy.detailCellCount());
    Tessellator one_by_one(t, o);
    one_by_one.materialiseAll();
    EXPECT_EQ(one_by_one.blockCount(), one_by_one.detailCellCount());
    Tessellator at_once(t, o);
    at_once.materialiseAll();
    const CellRect whole{0, 0, t.spec().paddedWidth() - 1, t.spec().paddedHeight() - 1};
    at_once.terrainChanged(std::span<const CellRect>(&whole, 1), false);
    std::int64_t compared = 0;
    std::int64_t differ = 0;
    forEachDetailDiamond(t, [&](roam::LatticePoint p) {
        const double a = at_once.deltaAt(p);
        if (a < 0.0)
            return;
        if (one_by_one.deltaAt(p) != a && differ++ < 5)
            ADD_FAILURE() << "one by one: " << p.x << "," << p.y << " " << one_by_one.deltaAt(p)
                          << " vs " << a;
        const double l = lazy.deltaAt(p);
        if (l >= 0.0) {
            ++compared;
            if (l != a && differ++ < 5)
                ADD_FAILURE() << "lazy: " << p.x << "," << p.y << " " << l << " vs " << a;
        }
    });
    EXPECT_EQ(differ, 0);
    EXPECT_GT(compared, 1000);
}

TEST(RoamMesh, ABoundedBlockPoolHoldsItsLimitAndReportsTheErrorItCosts) {
    // views that want more detail blocks than the pool holds: the pool binds like the triangle
    // cap (splits refused, the threshold rises), blocks no diamond needs make room as the view
    // moves, and the reported bound still covers the measured error
    const Terrain t = cratered(7, 40);
    TessellatorOptions o;
    o.tau_pixels = 1.0;
    o.max_detail_blocks = 300;
    Tessellator tess(t, o);
    std::mt19937_64 rng(3);
    std::int64_t refusals = 0;
    std::int64_t evicted = 0;
    for (int i = 0; i < 6; ++i) {
        const Camera cam = randomCamera(t, rng);
        for (int f = 0; f < 4; ++f) { // a rebuild, then split/merge at the same eye
            const auto stats = tess.update(cam);
            refusals += stats.refused_by_pool;
            evicted += stats.blocks_evicted;
            EXPECT_LE(tess.blockCount(), o.max_detail_blocks);
            expectConforming(tess, t.spec());
            expectIndexListsMatchMesh(tess);
            if (!stats.budget_exhausted) {
                const auto err = roam::measureScreenError(tess, t, cam);
                EXPECT_LE(err.max_pixels, stats.error_bound_pixels + 1e-9)
                    << "camera " << i << " frame " << f;
            }
        }
        EXPECT_EQ(tess.missingBlockRefusals(), 0);
    }
    EXPECT_GT(refusals, 0) << "the pool never bound";
    EXPECT_GT(evicted, 0) << "no block made room for another";
    // the same views with room for every block meet tau
    TessellatorOptions roomy = o;
    roomy.max_detail_blocks = 1 << 20;
    Tessellator free_tess(t, roomy);
    std::mt19937_64 again(3);
    const Camera cam = randomCamera(t, again);
    EXPECT_LE(free_tess.update(cam).error_bound_pixels, o.tau_pixels);
    EXPECT_GT(free_tess.blockCount(), o.max_detail_blocks);
}

using LeafSet = std::set<std::array<std::int32_t, 6>>;

LeafSet leaves(const Tessellator& tess) {
    LeafSet out;
    tess.forEachLeaf([&](const roam::Triangle& t, std::int32_t, bool) {
        out.insert({t.apex.x, t.apex.y, t.left.x, t.left.y, t.right.x, t.right.y});
    });
    return out;
}

/// Above the middle of the map, looking straight down from `above` metres over its highest
/// point: with the map in view, no culling hides a difference between two meshes.
Camera overview(const Terrain& t, double above = 300.0) {
    const double cx = t.spec().extentX() / 2;
    const double cy = t.spec().extentY() / 2;
    double top = -1e9;
    for (double y = 0; y <= t.spec().extentY(); y += 1.0)
        for (double x = 0; x <= t.spec().extentX(); x += 1.0)
            top = std::max(top, surfaceHeight(t, x, y));
    Camera c = lookAt(glm::dvec3(cx, cy, top + above), glm::dvec3(cx, cy, 0.0));
    c.up = glm::dvec3(0.0, 1.0, 0.0);
    return c;
}

TEST(RoamMesh, ASnapshotReplacingTheWorldInPlaceAfterRefinementRebuildsIt) {
    // what a replica does on a second snapshot (a re-join): the same object, new contents, with
    // candidates of the old blocks still in the heap (this crashed before 12-06: the heap was
    // cleared after its pooled ranges had shrunk)
    Terrain t = cratered(11, 30);
    TessellatorOptions o;
    Tessellator tess(t, o);
    updateUntilSettled(tess, overview(t));
    ASSERT_GT(tess.blockCount(), 0);
    t = cratered(5, 60);
    tess.terrainChanged({}, true);
    const Camera cam = overview(t);
    updateUntilSettled(tess, cam);
    Tessellator fresh(t, o);
    updateUntilSettled(fresh, cam);
    EXPECT_EQ(leaves(tess), leaves(fresh));
}

TEST(RoamMesh, ARebindReadsTheNewTerrainAsAFreshTessellatorWould) {
    // the old world goes once rebound (asan: nothing reads it), the next is another of the same
    // size, then one of another size
    auto first = std::make_unique<Terrain>(cratered(11, 30));
    const Terrain same_size = cratered(5, 60);
    Terrain other_size = makeHills(3, 200, 180);
    CraterSeries series;
    series.seed = 3;
    series.count = 30;
    applyAll(other_size, randomCraters(other_size.spec(), series));
    TessellatorOptions o;
    o.tau_pixels = 1.0;
    Tessellator tess(*first, o);
    updateUntilSettled(tess, overview(*first));
    for (const Terrain* next : {&same_size, static_cast<const Terrain*>(&other_size)}) {
        tess.rebind(*next);
        first.reset();
        const Camera cam = overview(*next);
        updateUntilSettled(tess, cam);
        Tessellator fresh(*next, o);
        updateUntilSettled(fresh, cam);
        EXPECT_EQ(leaves(tess), leaves(fresh));
        ASSERT_EQ(tess.tileCount(), fresh.tileCount());
        for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile)
            EXPECT_EQ(tess.tileVertexCount(tile), fresh.tileVertexCount(tile)) << tile;
        EXPECT_EQ(tess.blockCount(), fresh.blockCount());
        EXPECT_GT(tess.blockCount(), 0) << "the craters were refined below the grid";
    }
}

TEST(RoamMesh, SplitMergeConvergesToTheSplitOnlyMesh) {
    const Terrain t = cratered(11, 30);
    TessellatorOptions sm;
    TessellatorOptions so;
    so.mode = TessellationMode::kSplitOnly;
    Tessellator a(t, sm);
    Tessellator b(t, so);
    // start high, then come down step by step so split/merge works incrementally
    const Camera end = overview(t, 30.0);
    for (int i = 20; i >= 0; --i) {
        Camera c = end;
        c.eye.z += 15.0 * i;
        a.update(c);
    }
    const Camera c = end;
    b.update(c);
    EXPECT_FALSE(a.update(c).rebuilt);
    EXPECT_FALSE(a.update(c).rebuilt); // merges out of view that the last step left due
    EXPECT_EQ(leaves(a), leaves(b));
    EXPECT_EQ(a.triangleCount(), b.triangleCount());
}

TEST(RoamMesh, SplitMergeFlightStaysWithinTenPercentOfSplitOnlyAndWithinTau) {
    const Terrain t = cratered(5, 60);
    TessellatorOptions sm;
    sm.tau_pixels = 1.0;
    TessellatorOptions so = sm;
    so.mode = TessellationMode::kSplitOnly;
    Tessellator a(t, sm);
    Tessellator b(t, so);
    std::int64_t rebuilds = 0;
    double worst_ratio = 0.0;
    for (int f = 0; f < 240; ++f) {
        // a low loop over the map, turning all the time
        const double s = f / 240.0 * 2.0 * M_PI;
        const double x = t.spec().extentX() * (0.5 + 0.3 * std::cos(s));
        const double y = t.spec().extentY() * (0.5 + 0.3 * std::sin(s));
        Camera c = lookAt(
            glm::dvec3(x, y, surfaceHeight(t, x, y) + 6.0),
            glm::dvec3(
                x - 20.0 * std::sin(s + 0.4), y + 20.0 * std::cos(s + 0.4),
                surfaceHeight(t, x, y)));
        const auto sa = a.update(c);
        const auto sb = b.update(c);
        rebuilds += sa.rebuilt ? 1 : 0;
        worst_ratio = std::max(
            worst_ratio,
            std::abs(static_cast<double>(sa.visible_triangles - sb.visible_triangles)) /
                static_cast<double>(sb.visible_triangles));
        if (f % 60 == 30) {
            expectConforming(a, t.spec());
            expectIndexListsMatchMesh(a);
            EXPECT_LE(roam::measureScreenError(a, t, c).max_pixels, sm.tau_pixels) << "frame " << f;
            EXPECT_LE(roam::measureScreenError(b, t, c).max_pixels, so.tau_pixels) << "frame " << f;
        }
    }
    EXPECT_EQ(rebuilds, 1) << "only the first frame rebuilds";
    EXPECT_LE(worst_ratio, 0.10);
}

TEST(RoamMesh, EveryDemConformsAndMeetsTau) {
    const std::filesystem::path dir(TERRAIN_DEM_DIR);
    if (!std::filesystem::exists(dir))
        GTEST_SKIP() << "no DEMs at " << dir << " (../shared/data/dem beside the repo)";
    int seen = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (!entry.is_directory())
            continue;
        const auto json = entry.path() / (entry.path().filename().string() + ".json");
        if (!std::filesystem::exists(json))
            continue;
        auto dem = io::importDem(json, {});
        if (!dem.ok()) {
            // gcanyon_hoppe_1200 states no spacing; its notes suggest 30-45 m
            io::DemImportOptions with_spacing;
            with_spacing.spacing_metres = 40.0;
            dem = io::importDem(json, with_spacing);
        }
        ASSERT_TRUE(dem.ok()) << json << ": " << dem.error().message;
        Terrain& t = dem->terrain;
        // a few craters, so patches and their halos meet real relief
        CraterSeries s;
        s.count = 8;
        s.min_radius = 0.8 * t.spec().spacingMetres();
        s.max_radius = 3.0 * t.spec().spacingMetres();
        applyAll(t, randomCraters(t.spec(), s));
        ++seen;
        Tessellator tess(t, {});
        std::mt19937_64 rng(static_cast<std::uint64_t>(seen));
        for (int i = 0; i < 2; ++i) {
            Camera c = randomCamera(t, rng);
            c.eye.z += 100.0 + 10.0 * t.spec().spacingMetres();
            updateUntilSettled(tess, c);
            SCOPED_TRACE(entry.path().filename().string() + " camera " + std::to_string(i));
            expectConforming(tess, t.spec());
            expectIndexListsMatchMesh(tess);
            EXPECT_LE(roam::measureScreenError(tess, t, c, {3, 1.0}).max_pixels, 1.0);
            EXPECT_EQ(tess.missingBlockRefusals(), 0);
        }
    }
    EXPECT_GE(seen, 1);
}

TEST(RoamMesh, FullRefinementAroundPatchesNeverLacksABlock) {
    // tau near zero with the eye just above crater rims: every patch cell is refined to its
    // finest level, and the forced splits around it must find blocks in the halo
    Terrain t = cratered(3, 25);
    for (const auto mode : {TessellationMode::kSplitMerge, TessellationMode::kSplitOnly}) {
        TessellatorOptions o;
        o.tau_pixels = 0.02;
        o.mode = mode;
        Tessellator tess(t, o);
        std::mt19937_64 rng(9);
        int deepest = 0;
        for (int i = 0; i < 4; ++i) {
            Camera c = randomCamera(t, rng);
            c.eye.z = surfaceHeight(t, c.eye.x, c.eye.y) + 1.0;
            tess.update(c);
            tess.forEachLeaf([&](const roam::Triangle& tr, std::int32_t, bool) {
                deepest = std::max(deepest, tr.level);
            });
            expectConforming(tess, t.spec());
        }
        EXPECT_EQ(deepest, roam::kFinestTriangleLevel);
        EXPECT_EQ(tess.missingBlockRefusals(), 0);
    }
}

TEST(RoamMesh, AFinestSplitForcesItsAncestorsAcrossTiles) {
    const Terrain t = cratered(13, 40);
    TessellatorOptions o;
    o.tau_pixels = 1e9; // nothing is worth a split: two triangles per tile
    Tessellator tess(t, o);
    const Camera c = overview(t);
    tess.update(c);
    ASSERT_EQ(tess.triangleCount(), 2 * tess.tileCount());
    // the finest diamond in a patch cell next to the corner shared by four tiles
    const PatchEntry* near_corner = nullptr;
    std::int32_t best = 1 << 30;
    for (const PatchEntry& e : t.tilePatches(0)) {
        const std::int32_t d = (63 - e.cell % 64) + (63 - e.cell / 64);
        if (d < best) {
            best = d;
            near_corner = &e;
        }
    }
    ASSERT_NE(near_corner, nullptr);
    const roam::LatticePoint p{
        (near_corner->cell % 64) * 16 + 16, (near_corner->cell / 64) * 16 + 15}; // level 19
    ASSERT_EQ(roam::diamondAt(p).level, roam::kMaxDiamondLevel);
    roam::FrameStats stats;
    ASSERT_TRUE(tess.splitAt(p, stats));
    EXPECT_GE(stats.forced_splits, roam::kMaxDiamondLevel);
    int touched = 0;
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile)
        touched += tess.tileMesh(tile).counters().forced_splits > 0 ? 1 : 0;
    EXPECT_GE(touched, 2) << "the forced chain crosses tile borders";
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    // and the metric merges it all away again
    for (int i = 0; i < 3; ++i)
        tess.update(c);
    EXPECT_EQ(tess.triangleCount(), 2 * tess.tileCount());
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
}

TEST(RoamMesh, ACraterChangesOnlyItsTile) {
    Terrain t = makeHills(21, 257, 257); // 4 x 4 tiles
    const double tile_m = 64.0 * t.spec().spacingMetres();
    const double cx = 1.5 * tile_m;
    const double cy = 1.5 * tile_m;
    const Camera c = lookAt(
        glm::dvec3(cx - 30.0, cy - 30.0, surfaceHeight(t, cx, cy) + 25.0),
        glm::dvec3(cx, cy, surfaceHeight(t, cx, cy)));
    Tessellator tess(t, {});
    for (int i = 0; i < 3; ++i)
        tess.update(c);
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile)
        tess.tileMesh(tile).takeChanges();
    const std::int32_t before = tess.tileVertexVersion(5);

    OpRequest crater;
    crater.x = cx;
    crater.y = cy;
    crater.radius = 4.0;
    crater.height = 1.5;
    auto op = quantizeOp(crater, t.spec());
    ASSERT_TRUE(op.ok());
    auto effect = t.apply(*op);
    ASSERT_TRUE(effect.ok());
    ASSERT_GT(effect->patches_created, 0);
    ASSERT_EQ(effect->dirty_tiles, std::vector<std::int32_t>{5});
    tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
    const auto stats = tess.update(c);
    EXPECT_FALSE(stats.rebuilt);
    EXPECT_GT(stats.splits, 0);
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile)
        EXPECT_EQ(tess.tileMesh(tile).dirty(), tile == 5) << "tile " << tile;
    EXPECT_NE(tess.tileVertexVersion(5), before);
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    EXPECT_LE(roam::measureScreenError(tess, t, c).max_pixels, 1.0);
}

TEST(RoamMesh, ACraterAmongCratersRewritesOnlyItsOwnTriangles) {
    // a battle-worn tile: its detail blocks come and go with every crater, and each new one
    // must take a place in the tile's vertex array without moving the indices already listed
    Terrain t = makeHills(23, 257, 257);
    const double tile_m = 64.0 * t.spec().spacingMetres();
    const double cx = 1.5 * tile_m;
    const double cy = 1.5 * tile_m;
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> around(-20.0, 20.0);
    const auto crater_at = [&](double x, double y, double radius) {
        OpRequest r;
        r.x = x;
        r.y = y;
        r.radius = radius;
        r.height = 0.5 * radius;
        return *quantizeOp(r, t.spec());
    };
    for (int i = 0; i < 40; ++i)
        ASSERT_TRUE(t.apply(crater_at(cx + around(rng), cy + around(rng), 3.0)).ok());
    const Camera c = lookAt(
        glm::dvec3(cx - 40.0, cy - 40.0, surfaceHeight(t, cx, cy) + 30.0),
        glm::dvec3(cx, cy, surfaceHeight(t, cx, cy)));
    Tessellator tess(t, {});
    for (int i = 0; i < 3; ++i)
        tess.update(c);
    const roam::TileMesh& mesh = tess.tileMesh(5);
    ASSERT_GT(mesh.triangleCount(), 2000u);
    for (int shot = 0; shot < 10; ++shot) {
        for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile)
            tess.tileMesh(tile).takeChanges();
        const std::uint64_t rewrites = mesh.counters().rebuilds;
        auto effect = t.apply(crater_at(cx + around(rng), cy + around(rng), 2.0));
        ASSERT_TRUE(effect.ok());
        tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
        const auto stats = tess.update(c);
        ASSERT_FALSE(stats.rebuilt);
        EXPECT_EQ(mesh.counters().rebuilds, rewrites) << "shot " << shot << " rewrote the tile";
        EXPECT_LT(mesh.dirtyUploadBytes() * 4, mesh.slotCount() * 12u) << "shot " << shot;
    }
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    Tessellator fresh(t, {});
    for (int i = 0; i < 3; ++i)
        fresh.update(c);
    tess.update(c);
    EXPECT_EQ(leaves(tess), leaves(fresh));
}

TEST(RoamMesh, BlocksOutOfReachAreReleasedWhileThePoolHasRoom) {
    // memory follows the view: after the eye leaves a cratered area, the blocks it refined go
    // within the idle time plus a sweep of the pool, and coming back rebuilds the same mesh
    const Terrain t = cratered(7, 40);
    TessellatorOptions o;
    o.detail_block_idle_frames = 10;
    Tessellator tess(t, o);
    std::mt19937_64 rng(3);
    const Camera near_craters = randomCamera(t, rng);
    tess.update(near_craters);
    const std::int32_t resident = tess.blockCount();
    ASSERT_GT(resident, 100);
    const LeafSet before = leaves(tess);
    // looking straight up from high above: nothing below the base grid is needed
    Camera away = near_craters;
    away.eye.z += 3000.0;
    away.forward = {0.0, 0.0, 1.0};
    away.up = {0.0, 1.0, 0.0};
    std::int64_t evicted = 0;
    const int frames = 10 + 2 + (resident + 511) / 512 + 1;
    for (int f = 0; f < frames; ++f)
        evicted += tess.update(away).blocks_evicted;
    EXPECT_EQ(tess.pinnedBlockCount(), 0);
    EXPECT_EQ(tess.blockCount(), 0) << "of " << resident;
    EXPECT_EQ(evicted, resident);
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    for (int f = 0; f < 3; ++f)
        tess.update(near_craters);
    EXPECT_EQ(leaves(tess), before);
    expectIndexListsMatchMesh(tess);
}

// Every vertex's height by lattice position and the origin of the block it belongs to (the
// grid's own: -1), as a vertex on a cell border is in both cells' blocks and grains may sit
// anywhere in the arrays; a hole's vertices stand in for the tile's first, with its height.
std::map<std::array<std::int32_t, 4>, std::int64_t> vertexHeights(const Tessellator& s) {
    std::map<std::array<std::int32_t, 4>, std::int64_t> out;
    for (std::int32_t tile = 0; tile < s.tileCount(); ++tile)
        for (std::int32_t i = 0; i < s.tileVertexCount(tile); ++i) {
            const roam::TileVertex v = s.tileVertex(tile, static_cast<std::uint32_t>(i));
            out[{v.position.x, v.position.y, v.block_origin.x, v.block_origin.y}] = v.height;
        }
    return out;
}

// Every resident vertex of `tess` has the height a tessellator built from scratch on `t`, with
// every detail block materialised, gives it.
bool verticesMatchAFreshBuild(const Tessellator& tess, const Terrain& t) {
    Tessellator all(t, {});
    all.materialiseAll();
    const auto want = vertexHeights(all);
    for (const auto& [at, height] : vertexHeights(tess)) {
        const auto it = want.find(at);
        if (it == want.end() || it->second != height) {
            ADD_FAILURE() << "vertex " << at[0] << "," << at[1] << ": " << height << " vs "
                          << (it == want.end() ? -1 : it->second);
            return false;
        }
    }
    return true;
}

// Records, bounds, vertex heights and mesh equal those of a tessellator built from scratch on
// the same terrain: what incremental updates must keep. Blocks resident in `tess` (kept through
// the ops) must hold what a fresh build with every block gives.
void expectSameAsFreshBuild(
    Tessellator& tess, const Terrain& t, const Camera& c, std::int64_t min_diamonds) {
    // bounds that ops made stale are redone within a per-frame budget: the frames first
    for (int f = 0; f < 1000 && tess.staleBlockCount() > 0; ++f)
        tess.update(c);
    ASSERT_EQ(tess.staleBlockCount(), 0);
    Tessellator fresh(t, {});
    fresh.update(c);
    Tessellator all(t, {});
    all.materialiseAll();
    EXPECT_EQ(tess.detailCellCount(), fresh.detailCellCount());
    std::int64_t compared = 0;
    for (std::int32_t y = 0; y <= (t.spec().paddedHeight() - 1) * 16; ++y)
        for (std::int32_t x = 0; x <= (t.spec().paddedWidth() - 1) * 16; ++x) {
            const double a = tess.deltaAt({x, y});
            if (a < 0.0)
                continue;
            ASSERT_EQ(a, all.deltaAt({x, y})) << "diamond at " << x << "," << y;
            if (const double b = fresh.deltaAt({x, y}); b >= 0.0) {
                ASSERT_EQ(a, b) << "diamond at " << x << "," << y;
            }
            ++compared;
        }
    EXPECT_GT(compared, min_diamonds);
    tess.update(c);
    EXPECT_EQ(leaves(tess), leaves(fresh));
    EXPECT_TRUE(verticesMatchAFreshBuild(tess, t)) << "a vertex height differs";
    expectIndexListsMatchMesh(tess);
}

TEST(RoamMesh, FreedGrainChunksAreCompactedAwayWithTheSameMesh) {
    // views low over the craters, one after another: each refines cells to their finest grain,
    // and the last view's chunks land above the holes the earlier views' released chunks leave,
    // until trimGrains moves them down and cuts the arrays. Nothing drawn may change.
    const Terrain t = cratered(7, 40);
    TessellatorOptions o;
    o.detail_block_idle_frames = 10;
    o.tau_pixels = 0.25; // finer: more of grain 2
    Tessellator tess(t, o);
    std::mt19937_64 rng(5);
    std::vector<Camera> views;
    std::size_t peak = 0;
    std::int32_t peak_chunks = 0;
    for (int v = 0; v < 6; ++v) {
        views.push_back(randomCamera(t, rng));
        updateUntilSettled(tess, views.back());
        for (int f = 0; f < 30; ++f) // the earlier view's chunks go idle and are released
            tess.update(views.back());
        peak = std::max(peak, tess.memory().grains[2]);
        peak_chunks = std::max(peak_chunks, tess.grainCounts()[2]);
    }
    ASSERT_GT(peak_chunks, 300) << "the views must refine cells to grain 2";
    EXPECT_GT(tess.movedChunkCount(), 0);
    EXPECT_LT(tess.memory().grains[2], peak);
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    EXPECT_TRUE(verticesMatchAFreshBuild(tess, t)) << "a vertex height differs";
    for (const std::size_t v : {views.size() - 1, std::size_t{0}}) {
        updateUntilSettled(tess, views[v]);
        Tessellator fresh(t, o);
        updateUntilSettled(fresh, views[v]);
        EXPECT_EQ(leaves(tess), leaves(fresh)) << "view " << v;
        expectIndexListsMatchMesh(tess);
    }
}

TEST(RoamMesh, IncrementalBoundsAfterOpsEqualAFreshBuild) {
    Terrain t = makeHills(4);
    Tessellator tess(t, {});
    const Camera c = overview(t);
    tess.update(c);
    tess.materialiseAll(); // every block then follows the ops incrementally
    CraterSeries s;
    s.seed = 4;
    s.count = 30;
    for (const OpRequest& r : randomCraters(t.spec(), s)) {
        auto op = quantizeOp(r, t.spec());
        ASSERT_TRUE(op.ok());
        auto effect = t.apply(*op);
        ASSERT_TRUE(effect.ok());
        tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
        tess.update(c);
    }
    // a flatten that removes patches again, so blocks go away too
    OpRequest flat;
    flat.kind = OpKind::kFlatten;
    flat.x = t.spec().extentX() / 2;
    flat.y = t.spec().extentY() / 2;
    flat.radius = 30.0;
    flat.height = 5.0;
    auto op = quantizeOp(flat, t.spec());
    ASSERT_TRUE(op.ok());
    auto effect = t.apply(*op);
    ASSERT_TRUE(effect.ok());
    tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
    tess.update(c);

    expectSameAsFreshBuild(tess, t, c, 10000);
}

TEST(RoamMesh, ABattleFedOpByOpEqualsAFreshBuild) {
    // a battle's shots land on what earlier ones left, so patches appear, change and go at the
    // border of every footprint (border enforcement one ring past it): each op's own cells
    // must be enough for the client to stay exact, vertex for vertex and bound for bound
    Terrain t = makeHills(5, 160, 160);
    BattleOptions o;
    o.seed = 3;
    o.zone_x = 80;
    o.zone_y = 80;
    BattleGenerator generator(o);
    Tessellator tess(t, {});
    const Camera c = lookAt(
        glm::dvec3(40.0, 40.0, surfaceHeight(t, 80.0, 80.0) + 40.0),
        glm::dvec3(80.0, 80.0, surfaceHeight(t, 80.0, 80.0)));
    tess.update(c);
    int craters = 0;
    for (int shot = 0; shot < 100; ++shot) {
        const BattleShot s = generator.next(t);
        if (!s.crater)
            continue;
        auto op = quantizeOp(*s.crater, t.spec());
        ASSERT_TRUE(op.ok());
        auto effect = t.apply(*op);
        ASSERT_TRUE(effect.ok());
        tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
        tess.update(c);
        ++craters;
        // shot 8 straightens a patch one ring out (later ones cover it up); a fresh build with
        // every block is the costly part, so only around it
        if (shot == 0 || shot == 8 || shot == 11) {
            ASSERT_TRUE(verticesMatchAFreshBuild(tess, t))
                << "shot " << shot << " left a vertex height stale";
        }
    }
    ASSERT_GT(craters, 80);
    expectSameAsFreshBuild(tess, t, c, 100000);
}

TEST(RoamMesh, ABurstOfCratersIsSpreadOverFramesAndConverges) {
    // many ops in one frame: their vertex heights follow at once (the mesh drawn is the new
    // surface, crack-free), their blocks' bounds within the per-frame budget, reported as not
    // exact until done; then the tessellator is what a fresh build makes
    Terrain t = cratered(6, 40); // patches, so blocks, before the burst
    TessellatorOptions o;
    o.stale_block_budget = 64;
    Tessellator tess(t, o);
    const Camera c = overview(t, 60.0);
    tess.update(c);
    tess.materialiseAll(); // every block follows the ops: plenty of stale bounds
    CraterSeries s;
    s.seed = 60;
    s.count = 12;
    std::vector<CellRect> changed;
    applyAll(t, randomCraters(t.spec(), s), &changed);
    tess.terrainChanged(changed, false);
    const auto first = tess.update(c);
    EXPECT_LE(first.stale_blocks_bounded, o.stale_block_budget);
    EXPECT_GT(first.stale_blocks, 0) << "the burst fitted in one frame's budget";
    EXPECT_TRUE(first.budget_exhausted);
    EXPECT_TRUE(verticesMatchAFreshBuild(tess, t)) << "a vertex height lagged the ops";
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    int frames = 1;
    while (tess.staleBlockCount() > 0 && frames < 1000) {
        EXPECT_LE(tess.update(c).stale_blocks_bounded, o.stale_block_budget);
        ++frames;
    }
    EXPECT_GT(frames, 2);
    EXPECT_FALSE(tess.update(c).budget_exhausted);
    expectSameAsFreshBuild(tess, t, c, 10000);
}

TEST(RoamMesh, FollowsAReplicaThroughOpsAndASnapshot) {
    // the client's loop: ops reach the replica, its dirty set reaches the tessellator
    Terrain server = makeHills(14);
    auto decoded = decodeSnapshot(encodeSnapshot(server, 0));
    ASSERT_TRUE(decoded.ok());
    client::Replica replica;
    replica.loadSnapshot(std::move(*decoded));
    replica.takeDirty();
    Tessellator tess(replica.terrain(), {});
    const Camera c = overview(server, 40.0);
    tess.update(c);
    CraterSeries s;
    s.seed = 14;
    s.count = 12;
    std::uint64_t seq = 0;
    for (const OpRequest& r : randomCraters(server.spec(), s)) {
        auto op = quantizeOp(r, server.spec());
        ASSERT_TRUE(op.ok());
        ASSERT_TRUE(server.apply(*op).ok());
        auto outcome = replica.applyOp(++seq, *op, server.worldHash());
        ASSERT_TRUE(outcome.ok());
        ASSERT_EQ(*outcome, client::Replica::OpOutcome::kApplied);
        if (seq % 3 == 0) { // several ops per frame, as when frames are slower than ops
            const client::DirtySet dirty = replica.takeDirty();
            tess.terrainChanged(dirty.cells, dirty.all);
            tess.update(c);
        }
    }
    const client::DirtySet dirty = replica.takeDirty();
    tess.terrainChanged(dirty.cells, dirty.all);
    tess.update(c);
    Tessellator fresh(replica.terrain(), {});
    fresh.update(c);
    EXPECT_EQ(leaves(tess), leaves(fresh));
    expectConforming(tess, server.spec());
    expectIndexListsMatchMesh(tess);

    // a snapshot of another world replaces everything, size included
    Terrain other = makeHills(15, 200, 90);
    auto next = decodeSnapshot(encodeSnapshot(other, 100));
    ASSERT_TRUE(next.ok());
    replica.loadSnapshot(std::move(*next));
    const client::DirtySet all = replica.takeDirty();
    ASSERT_TRUE(all.all);
    tess.terrainChanged(all.cells, all.all);
    const Camera c2 = overview(other, 40.0);
    const auto stats = tess.update(c2);
    EXPECT_TRUE(stats.rebuilt);
    EXPECT_EQ(tess.tileCount(), other.spec().tileCount());
    expectConforming(tess, other.spec());
    expectIndexListsMatchMesh(tess);
    EXPECT_LE(roam::measureScreenError(tess, replica.terrain(), c2).max_pixels, 1.0);
}

// ---- where such methods are known to fail ---------------------------------------------------

TEST(RoamStability, FastSpinsKeepTheBoundAndTheTriangleCount) {
    const Terrain t = cratered(16, 40);
    TessellatorOptions sm;
    TessellatorOptions so;
    so.mode = TessellationMode::kSplitOnly;
    Tessellator a(t, sm);
    Tessellator b(t, so);
    const double cx = t.spec().extentX() / 2;
    const double cy = t.spec().extentY() / 2;
    const glm::dvec3 eye(cx, cy, surfaceHeight(t, cx, cy) + 4.0);
    for (int f = 0; f < 36; ++f) {
        const double yaw = f * 41.0 * M_PI / 180.0; // a whip pan: 41 degrees per frame
        const Camera c = lookAt(eye, eye + glm::dvec3(std::cos(yaw), std::sin(yaw), -0.3));
        const auto sa = a.update(c);
        const auto sb = b.update(c);
        EXPECT_FALSE(f > 0 && sa.rebuilt) << "turning alone is no teleport";
        EXPECT_LE(
            std::abs(static_cast<double>(sa.visible_triangles - sb.visible_triangles)),
            0.10 * static_cast<double>(sb.visible_triangles))
            << "frame " << f;
        if (f % 9 == 4) {
            expectConforming(a, t.spec());
            expectIndexListsMatchMesh(a);
            EXPECT_LE(roam::measureScreenError(a, t, c).max_pixels, sm.tau_pixels);
        }
    }
}

TEST(RoamStability, CraterStormAtEdgesSeamsAndCornersMatchesAFreshBuild) {
    Terrain t = makeHills(17, 193, 129); // 3 x 2 tiles, no padding
    Tessellator tess(t, {});
    const Camera c = overview(t, 60.0);
    tess.update(c);
    const double w = t.spec().extentX();
    const double h = t.spec().extentY();
    const double seam = 64.0 * t.spec().spacingMetres();
    // corners, edges, tile seams and their crossing; radii from the smallest to large
    const std::vector<std::array<double, 3>> storm = {
        {0.0, 0.0, 1.0},
        {w, h, 2.5},
        {w, 0.0, 6.0},
        {0.0, h, 0.8},
        {seam, seam, 3.0},
        {2 * seam, seam, 1.2},
        {seam, 0.0, 4.0},
        {w / 2, h, 2.0},
        {seam + 0.3, seam - 0.2, 0.7},
        {w / 2, h / 2, 40.0},
        {2 * seam - 0.5, 10.0, 5.0},
        {w - 0.5, h / 2, 1.5}};
    int in_frame = 0;
    for (const auto& [x, y, r] : storm) {
        OpRequest crater;
        crater.x = x;
        crater.y = y;
        crater.radius = r;
        crater.height = 0.6 * r;
        auto op = quantizeOp(crater, t.spec());
        ASSERT_TRUE(op.ok()) << op.error().message;
        auto effect = t.apply(*op);
        ASSERT_TRUE(effect.ok());
        tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
        if (++in_frame == 4) { // several ops land between two frames
            in_frame = 0;
            tess.update(c);
            expectConforming(tess, t.spec());
        }
    }
    tess.update(c);
    Tessellator fresh(t, {});
    fresh.update(c);
    EXPECT_EQ(leaves(tess), leaves(fresh));
    expectIndexListsMatchMesh(tess);
    EXPECT_LE(roam::measureScreenError(tess, t, c).max_pixels, 1.0);
    EXPECT_EQ(tess.missingBlockRefusals(), 0);
}

TEST(RoamStability, SpikyTerrainAndTauNearZero) {
    // white noise of +-30 m on every sample: no smoothness for the bounds to lean on
    WorldSpec spec;
    spec.width = 97;
    spec.height = 70;
    std::vector<std::int32_t> samples(static_cast<std::size_t>(spec.width * spec.height));
    std::mt19937_64 rng(18);
    std::uniform_int_distribution<std::int32_t> noise(-30 * 1024, 30 * 1024);
    for (auto& v : samples)
        v = noise(rng);
    auto made = Terrain::create(spec, samples);
    ASSERT_TRUE(made.ok());
    const Terrain& t = *made;
    for (const double tau : {4.0, 0.05}) {
        TessellatorOptions o;
        o.tau_pixels = tau;
        Tessellator tess(t, o);
        std::mt19937_64 cams(19);
        for (int i = 0; i < 2; ++i) {
            Camera c = randomCamera(t, cams);
            c.eye.z += 35.0;
            tess.update(c);
            expectConforming(tess, t.spec());
            expectIndexListsMatchMesh(tess);
            EXPECT_LE(roam::measureScreenError(tess, t, c).max_pixels, tau) << "tau " << tau;
        }
    }
}

TEST(RoamMesh, APatchOnAnUnpaddedMapBorderIsRefinedLikeAnyOther) {
    // 65 x 65: no padding, so diamonds on the last column belong to a virtual cell past the grid
    Terrain t = makeHills(31, 65, 65);
    OpRequest crater;
    crater.x = 63.5;
    crater.y = 32.0;
    crater.radius = 2.0;
    crater.height = 1.2;
    auto op = quantizeOp(crater, t.spec());
    ASSERT_TRUE(op.ok());
    ASSERT_TRUE(t.apply(*op).ok());
    ASSERT_NE(t.findPatch(63, 32), nullptr);
    TessellatorOptions o;
    o.tau_pixels = 0.5;
    Tessellator tess(t, o);
    const Camera c = lookAt(
        glm::dvec3(61.0, 32.5, surfaceHeight(t, 61.0, 32.5) + 1.5),
        glm::dvec3(64.0, 32.5, surfaceHeight(t, 64.0, 32.5)));
    for (int i = 0; i < 2; ++i)
        tess.update(c);
    // the virtual cell's block, materialised when the real cell before it was refined
    EXPECT_GT(tess.deltaAt({64 * 16, 32 * 16 + 8}), 0.0) << "the border wedge has a bound";
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    // 1.5 m from a crater rim even the patch grid's own error shows (finest level, reported
    // apart); everything the tessellator could still split is within tau
    EXPECT_LE(roam::measureScreenError(tess, t, c).max_pixels_above_finest, o.tau_pixels);
    EXPECT_EQ(tess.missingBlockRefusals(), 0);
}

TEST(RoamMesh, ADirtyRectCoveringTheWholeMapStillRequeuesCandidates) {
    Terrain t = makeHills(32, 65, 65);
    Tessellator tess(t, {});
    const Camera c = lookAt(
        glm::dvec3(26.0, 26.0, surfaceHeight(t, 32.0, 32.0) + 4.0),
        glm::dvec3(32.0, 32.0, surfaceHeight(t, 32.0, 32.0)));
    for (int i = 0; i < 3; ++i)
        tess.update(c);
    OpRequest crater;
    crater.x = 32.0;
    crater.y = 32.0;
    crater.radius = 3.0;
    crater.height = 1.5;
    auto op = quantizeOp(crater, t.spec());
    ASSERT_TRUE(op.ok());
    ASSERT_TRUE(t.apply(*op).ok());
    const CellRect everything{0, 0, 63, 63}; // a superset, as a coalesced dirty set may give
    tess.terrainChanged(std::span<const CellRect>(&everything, 1), false);
    for (int i = 0; i < 3; ++i)
        tess.update(c);
    Tessellator fresh(t, {});
    fresh.update(c);
    EXPECT_EQ(leaves(tess), leaves(fresh));
    EXPECT_LE(roam::measureScreenError(tess, t, c).max_pixels, 1.0);
}

TEST(RoamMesh, VertexVersionsFollowBlockChangesWhileARebuildIsPending) {
    Terrain t = makeHills(33, 257, 257);
    Tessellator tess(t, {});
    tess.update(overview(t, 60.0));
    tess.materialiseAll(); // blocks an op refills (none yet: the hills have no patch)
    tess.setTau(0.9);      // the next update rebuilds; ops meanwhile must still bump versions
    std::vector<std::int32_t> count;
    std::vector<std::uint32_t> version;
    for (std::int32_t i = 0; i < tess.tileCount(); ++i) {
        count.push_back(tess.tileVertexCount(i));
        version.push_back(tess.tileVertexVersion(i));
    }
    // a small crater in the last column of tile 4, so the halo reaches into tile 5
    OpRequest crater;
    crater.x = 63.4;
    crater.y = 100.0;
    crater.radius = 0.6;
    crater.height = 0.4;
    auto op = quantizeOp(crater, t.spec());
    ASSERT_TRUE(op.ok());
    auto effect = t.apply(*op);
    ASSERT_TRUE(effect.ok());
    ASSERT_NE(t.findPatch(63, 100), nullptr);
    tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
    // the op moved heights in tiles 4 and 5 (its cells reach both); nothing is resident there
    // yet, so the vertex counts stay
    for (const std::int32_t i : {4, 5}) {
        EXPECT_NE(tess.tileVertexVersion(i), version[i]) << "tile " << i;
        version[i] = tess.tileVertexVersion(i);
    }
    // refining the crater closely (the rebuild) materialises blocks on both sides of the border
    tess.update(lookAt(
        glm::dvec3(62.0, 98.5, surfaceHeight(t, 62.0, 98.5) + 1.0),
        glm::dvec3(63.5, 100.0, surfaceHeight(t, 63.5, 100.0))));
    int changed = 0;
    for (std::int32_t i = 0; i < tess.tileCount(); ++i)
        if (tess.tileVertexCount(i) != count[i]) {
            ++changed;
            EXPECT_NE(tess.tileVertexVersion(i), version[i]) << "tile " << i;
        }
    EXPECT_GE(changed, 2);
}

TEST(RoamMesh, ASteadyFrameAllocatesNothing) {
    const Terrain t = cratered(8, 30);
    Tessellator tess(t, {});
    auto orbit = [&](int f) {
        const double s = f / 120.0 * 2.0 * M_PI;
        const double x = t.spec().extentX() * (0.5 + 0.25 * std::cos(s));
        const double y = t.spec().extentY() * (0.5 + 0.25 * std::sin(s));
        return lookAt(
            glm::dvec3(x, y, 12.0 + surfaceHeight(t, x, y)),
            glm::dvec3(t.spec().extentX() / 2, t.spec().extentY() / 2, 0.0));
    };
    for (int f = 0; f < 240; ++f) // two laps reach every capacity the loop needs
        tess.update(orbit(f));
    std::int64_t work = 0;
    g_allocations = 0;
    g_counting = true;
    for (int f = 240; f < 360; ++f) {
        const auto stats = tess.update(orbit(f));
        work += stats.splits + stats.merges;
    }
    g_counting = false;
    EXPECT_GT(work, 100) << "the orbit must make the tessellator work";
    EXPECT_EQ(g_allocations.load(), 0);
}

TEST(RoamMesh, TheTriangleCapHoldsWithoutCracks) {
    const Terrain t = cratered(2, 40);
    for (const auto mode : {TessellationMode::kSplitMerge, TessellationMode::kSplitOnly}) {
        TessellatorOptions o;
        o.mode = mode;
        o.tau_pixels = 0.25;
        o.max_triangles = 3000;
        Tessellator tess(t, o);
        std::mt19937_64 rng(5);
        std::int64_t refused = 0;
        for (int i = 0; i < 8; ++i) {
            const Camera c = randomCamera(t, rng);
            for (int k = 0; k < 3; ++k) {
                const auto stats = tess.update(c);
                refused += stats.refused_by_cap;
                EXPECT_LE(stats.triangles, o.max_triangles);
            }
            expectConforming(tess, t.spec());
            expectIndexListsMatchMesh(tess);
            // the cap is spent, not abandoned early (split/merge lowers its threshold while the
            // mesh is under 80 % of the cap, so a view that needs less settles within frames)
            for (int k = 0; k < 20 && mode == TessellationMode::kSplitMerge; ++k)
                tess.update(c);
            EXPECT_GE(tess.triangleCount(), o.max_triangles * 8 / 10);
        }
        EXPECT_GT(refused, 0);
    }
}

TEST(RoamMesh, UnderTheCapSplitMergeFollowsTheBudgetWithoutRebuilding) {
    // ROAM's dual queues under a budget: when the cap binds, split/merge keeps the mesh that a
    // top-down build at its threshold (the achieved error) makes, the best mesh for that count,
    // by raising and lowering the threshold, not by rebuilding now and then
    const Terrain t = cratered(2, 40);
    TessellatorOptions sm;
    sm.tau_pixels = 0.25;
    sm.max_triangles = 3000;
    Tessellator a(t, sm);
    const glm::dvec3 centre(t.spec().extentX() / 2, t.spec().extentY() / 2, 0.0);
    auto orbit = [&](int f) { // low over the ground, looking at the centre: no teleport
        const double s = f / 240.0 * 2.0 * M_PI;
        const double x = t.spec().extentX() * (0.5 + 0.3 * std::cos(s));
        const double y = t.spec().extentY() * (0.5 + 0.3 * std::sin(s));
        return lookAt(glm::dvec3(x, y, 6.0 + surfaceHeight(t, x, y)), centre);
    };
    const roam::FrameStats first = a.update(orbit(0));
    ASSERT_TRUE(first.rebuilt);
    EXPECT_GT(first.error_bound_pixels, sm.tau_pixels) << "the cap must bind in this test";
    int rises = 0;
    int falls = 0;
    for (int f = 1; f < 240; ++f) {
        const double before = a.threshold();
        const roam::FrameStats s = a.update(orbit(f));
        EXPECT_FALSE(s.rebuilt) << "frame " << f;
        EXPECT_LE(s.triangles, sm.max_triangles);
        EXPECT_GE(s.error_bound_pixels, before);
        rises += a.threshold() > before ? 1 : 0;
        falls += a.threshold() < before ? 1 : 0;
    }
    EXPECT_GT(rises + falls, 0) << "the orbit must move the threshold";
    // a few frames on the spot settle it: the cap then neither refuses nor lies idle
    const Camera c = orbit(240);
    roam::FrameStats last;
    for (int f = 0; f < 20; ++f)
        last = a.update(c);
    EXPECT_EQ(last.refused_by_cap, 0);
    EXPECT_EQ(last.error_bound_pixels, a.threshold());
    EXPECT_GE(a.triangleCount(), sm.max_triangles * 8 / 10);
    // the achieved error it reports is what the mesh measures, at most
    const auto measured = roam::measureScreenError(a, t, c);
    EXPECT_LE(measured.max_pixels_above_finest, last.error_bound_pixels);
    EXPECT_GT(measured.max_pixels, sm.tau_pixels) << "the cap wins over tau here";
    expectConforming(a, t.spec());
    expectIndexListsMatchMesh(a);

    // exactly the mesh a fresh top-down build at the threshold makes
    TessellatorOptions at = sm;
    at.mode = TessellationMode::kSplitOnly;
    at.tau_pixels = a.threshold();
    at.max_triangles = 1'000'000;
    Tessellator b(t, at);
    b.update(c);
    EXPECT_EQ(leaves(a), leaves(b));

    // and the error a fresh best-first build reaches with as many triangles, within 10 %
    TessellatorOptions capped = sm;
    capped.mode = TessellationMode::kSplitOnly;
    capped.max_triangles = a.triangleCount();
    Tessellator fresh(t, capped);
    const roam::FrameStats fs = fresh.update(c);
    EXPECT_GT(fs.error_bound_pixels, sm.tau_pixels);
    EXPECT_LE(a.threshold(), fs.error_bound_pixels * 1.1);
    EXPECT_GE(a.threshold() * 1.1, fs.error_bound_pixels);
}

TEST(RoamMesh, BudgetSpreadsWorkOverFramesAndConverges) {
    const Terrain t = cratered(6, 30);
    TessellatorOptions o;
    o.work_budget = 200;
    Tessellator tess(t, o);
    TessellatorOptions so;
    so.mode = TessellationMode::kSplitOnly;
    Tessellator reference(t, so);
    Camera c = overview(t, 300.0);
    tess.update(c); // first frame rebuilds top-down, unbudgeted
    c = overview(t, 25.0);
    reference.update(c);
    int frames = 0;
    bool exhausted = false;
    while (frames < 200) {
        const auto stats = tess.update(c);
        ++frames;
        exhausted = exhausted || stats.budget_exhausted;
        EXPECT_LE(stats.splits + stats.merges, o.work_budget + 32); // forced chains finish
        expectConforming(tess, t.spec());
        if (!stats.budget_exhausted && stats.splits + stats.merges == 0)
            break;
    }
    EXPECT_TRUE(exhausted);
    EXPECT_GT(frames, 2);
    EXPECT_EQ(leaves(tess), leaves(reference));
}

/// A step's end after a fixed number of budget checks (a worker reads a clock; a test counts):
/// `share` of the step is spent once `share * checks` checks were made.
struct CountedDeadline final : roam::StepDeadline {
    explicit CountedDeadline(int checks_per_step) : checks(checks_per_step) {}
    bool spent(double share) const override {
        return static_cast<double>(++made) >= share * static_cast<double>(checks);
    }
    void start() { made = 0; }
    int checks;
    mutable int made = 0;
};

/// Short steps for `c` until one leaves nothing for the next; fails if that never happens.
/// Every tenth step, the mesh conforms (a step may end anywhere).
int stepUntilDone(
    Tessellator& tess, CountedDeadline& deadline, const Camera& c, const WorldSpec& spec) {
    for (int step = 1; step <= 5000; ++step) {
        deadline.start();
        const roam::FrameStats s = tess.update(c);
        if (step % 10 == 0)
            expectConforming(tess, spec);
        if (!s.budget_exhausted && s.stale_blocks == 0 && s.backlog == 0 &&
            s.splits + s.merges == 0)
            return step;
    }
    ADD_FAILURE() << "short steps never finished";
    return 0;
}

// A worker's short steps (Tessellator::setStepDeadline): each update ends at its deadline, what
// it leaves (stale bounds, priced splits and merges, candidates not yet priced) waits for the
// next, and steps with the camera held settle on the mesh one whole update makes; so do they
// after a burst of craters, bound for bound.
TEST(RoamMesh, ShortStepsEndAtTheirDeadlineAndSettleOnTheMeshOneWholeUpdateMakes) {
    Terrain t = cratered(6, 30);
    CountedDeadline deadline(400);
    Tessellator tess(t, {});
    Camera c = overview(t, 300.0);
    tess.update(c); // the first frame rebuilds top-down, whole
    tess.setStepDeadline(&deadline);
    c = overview(t, 25.0);
    deadline.start();
    const roam::FrameStats first = tess.update(c);
    EXPECT_TRUE(first.budget_exhausted) << "the swoop fitted in one short step";
    EXPECT_GT(first.backlog, 0);
    const int steps = stepUntilDone(tess, deadline, c, t.spec());
    EXPECT_GT(steps, 3);
    Tessellator whole(t, {});
    whole.update(c);
    EXPECT_EQ(leaves(tess), leaves(whole));

    // a burst of craters: heights at once, bounds and moves over the steps, then the same as a
    // fresh build
    tess.materialiseAll();
    CraterSeries s;
    s.seed = 61;
    s.count = 10;
    std::vector<CellRect> changed;
    applyAll(t, randomCraters(t.spec(), s), &changed);
    tess.terrainChanged(changed, false);
    EXPECT_TRUE(verticesMatchAFreshBuild(tess, t)) << "a vertex height waited for a step";
    EXPECT_GT(stepUntilDone(tess, deadline, c, t.spec()), 1);
    Tessellator fresh(t, {});
    fresh.update(c);
    EXPECT_EQ(leaves(tess), leaves(fresh));
}

// A crater's cells are settled once no block of theirs waits for its bounds and no split there
// waits for a budget: the worker's measure of a crater's convergence.
TEST(RoamMesh, ACratersCellsAreSettledOnceTheirBoundsAndSplitsAreDone) {
    Terrain t = cratered(8, 30);
    TessellatorOptions o;
    o.stale_block_budget = 16;
    Tessellator tess(t, o);
    const Camera c = overview(t, 40.0);
    updateUntilSettled(tess, c);
    tess.materialiseAll();
    OpRequest r;
    r.x = t.spec().extentX() / 2;
    r.y = t.spec().extentY() / 2;
    r.radius = 8.0;
    r.height = 3.0;
    r.strength = 0.5;
    const CellRect cells = applyRequest(t, r);
    ASSERT_FALSE(cells.empty());
    EXPECT_TRUE(tess.settled(cells)) << "nothing was told yet";
    tess.terrainChanged(std::span<const CellRect>(&cells, 1), false);
    EXPECT_FALSE(tess.settled(cells)) << "its blocks' bounds are stale";
    int frames = 0;
    while (!tess.settled(cells) && frames < 100) {
        tess.update(c);
        ++frames;
    }
    EXPECT_GT(frames, 1) << "16 blocks a frame: the crater's bounds took frames";
    EXPECT_TRUE(tess.settled(cells));
    EXPECT_EQ(tess.staleBlockCount(), 0);
}

// The upload budget holds a frame's mesh changes to what a renderer may send in one frame: a
// swoop from high to low spreads its index pages and grain vertices over frames, each within the
// budget (one split's pages past it at most), the mesh conforming and the error bound honest
// (budget_exhausted while it waits), and it ends where the unbudgeted mesh is.
TEST(RoamMesh, UploadBudgetSpreadsWhatARendererSendsOverFrames) {
    const Terrain t = cratered(6, 30);
    TessellatorOptions o;
    o.work_budget = 1 << 30;
    o.upload_budget_bytes = 64 << 10;
    Tessellator tess(t, o);
    TessellatorOptions so;
    so.mode = TessellationMode::kSplitOnly;
    Tessellator reference(t, so);
    Camera c = overview(t, 300.0);
    tess.update(c); // first frame rebuilds top-down, unbudgeted
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile)
        tess.tileMesh(tile).takeChanges(); // what a renderer does after its upload
    c = overview(t, 25.0);
    reference.update(c);
    int frames = 0;
    int bound = 0;
    std::int64_t most = 0;
    while (frames < 400) {
        const auto stats = tess.update(c);
        ++frames;
        // the pages a renderer would send, counted the renderer's way
        std::int64_t pages = 0;
        for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile) {
            pages += static_cast<std::int64_t>(tess.tileMesh(tile).dirtyPages().size());
            tess.tileMesh(tile).takeChanges();
        }
        EXPECT_LE(pages * 384, stats.upload_bytes) << "frame " << frames;
        most = std::max(most, stats.upload_bytes);
        if (stats.upload_budget_bound) {
            ++bound;
            EXPECT_TRUE(stats.budget_exhausted);
        }
        // a split forces its ancestors' splits: a chain finishes past the budget
        EXPECT_LE(stats.upload_bytes, o.upload_budget_bytes + 8 * 1024) << "frame " << frames;
        expectConforming(tess, t.spec());
        if (!stats.budget_exhausted && stats.splits + stats.merges == 0)
            break;
    }
    std::printf(
        "upload budget 64 KiB: %d frames, %d bound by it, at most %lld bytes in one\n", frames,
        bound, static_cast<long long>(most));
    EXPECT_GT(bound, 2);
    EXPECT_EQ(leaves(tess), leaves(reference));
}

TEST(RoamMesh, ATeleportRebuildsTopDown) {
    const Terrain t = makeHills(12, 400, 400);
    TessellatorOptions o;
    o.teleport_metres = 100.0;
    Tessellator tess(t, o);
    Camera c = lookAt(glm::dvec3(20, 20, 30), glm::dvec3(60, 60, 0));
    tess.update(c);
    EXPECT_FALSE(tess.update(c).rebuilt);
    c = lookAt(glm::dvec3(380, 380, 30), glm::dvec3(340, 340, 0));
    const auto stats = tess.update(c);
    EXPECT_TRUE(stats.rebuilt);
    expectConforming(tess, t.spec());
    expectIndexListsMatchMesh(tess);
    EXPECT_LE(roam::measureScreenError(tess, t, c).max_pixels, 1.0);
}

} // namespace
} // namespace terrain::testing

namespace terrain::roam {
namespace {

// A click's ray (ViewMetric::rayThrough) projects back onto the pixel it came from.
TEST(Camera, RayThroughAPixelProjectsBackOntoIt) {
    Camera c;
    c.eye = glm::dvec3(10.0, -20.0, 30.0);
    c.forward = glm::dvec3(0.3, 1.0, -0.4);
    c.viewport_width = 640;
    c.viewport_height = 360;
    const ViewMetric m(c);
    for (const auto& [x, y] : std::vector<std::pair<double, double>>{
             {0.0, 0.0}, {320.0, 180.0}, {639.0, 12.5}, {17.0, 359.0}}) {
        const glm::dvec3 d = m.rayThrough(x, y);
        EXPECT_NEAR(std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z), 1.0, 1e-12);
        const ScreenPoint s = m.project(c.eye + 50.0 * d);
        EXPECT_NEAR(s.x, x, 1e-9);
        EXPECT_NEAR(s.y, y, 1e-9);
        EXPECT_GT(s.depth, 0.0);
    }
}

} // namespace
} // namespace terrain::roam
