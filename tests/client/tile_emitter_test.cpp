// The tile emitter alone, on a cratered world with every detail block resident in all its
// grains: splits are made in the diamond space by hand (with the parents they force, as the
// lattice walk does) and told to the emitter. Every emitted leaf is in its tile's list with its
// corners, split/merge keeps the lists a full emission writes, the vertex reads agree, an op marks
// every vertex whose height moved, and geomorphing meets across tiles and reaches the surface.

#include "support/roam_parts.h"

#include <terrain/roam/lattice.h>
#include <terrain/roam/tile_emitter.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

namespace terrain::testing {
namespace {

using roam::Diamond;
using roam::LatticePoint;
using roam::TileVertex;
using roam::Triangle;

/// Splits the diamond centred at `p` and every parent it needs, telling the emitter of each
/// split when `emit`; false (nothing more split) where a diamond on the way has no id.
bool splitWithParents(RoamParts& w, LatticePoint p, bool emit) {
    const DiamondId id = w.ids.idOf(p);
    if (id == roam::kNoDiamond)
        return false;
    if (w.space.active(id))
        return true;
    const Diamond d = roam::diamondAt(p);
    if (d.level > 0)
        for (const LatticePoint a : roam::apexes(d))
            if (w.ids.geometry().insideMap(a) && !splitWithParents(w, a, emit))
                return false;
    w.space.state(id) |= DiamondSpace::kActive;
    if (emit)
        w.emitter.splitTriangles(d, true, false);
    return true;
}

bool hasSplitChild(const RoamParts& w, const Diamond& d) {
    std::array<LatticePoint, 4> kids{};
    const int n = roam::children(d, kids);
    for (int i = 0; i < n; ++i)
        if (w.ids.active(kids[static_cast<std::size_t>(i)]))
            return true;
    return false;
}

/// The cells' own triangles everywhere (every diamond above level 12 split), and every diamond
/// of every third detail cell with the parents it forces.
void refine(RoamParts& w, bool emit) {
    std::vector<Triangle> stack;
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
        const Diamond root = w.emitter.tileRoot(tile);
        for (const LatticePoint a : roam::apexes(root))
            stack.push_back(roam::triangleOf(root, a));
    }
    while (!stack.empty()) {
        const Triangle t = stack.back();
        stack.pop_back();
        if (t.level >= roam::kCellTriangleLevel)
            continue;
        splitWithParents(w, roam::splitPoint(t), emit);
        for (const Triangle& h : roam::splitTriangle(t))
            stack.push_back(h);
    }
    std::int32_t n = 0;
    for (std::int32_t r = 0; r < w.blocks.recordCapacity(); ++r) {
        if (!w.blocks.recordInUse(r) || n++ % 3 != 0)
            continue;
        const DetailBlocks::CellXY c = w.blocks.recordCell(r);
        for (std::int32_t local = 1; local < kLatticePerCell * kLatticePerCell; ++local)
            splitWithParents(
                w,
                {c.x * kLatticePerCell + local % kLatticePerCell,
                 c.y * kLatticePerCell + local / kLatticePerCell},
                emit);
    }
}

using Corners = std::array<std::pair<std::int32_t, std::int32_t>, 3>;

/// A tile's triangles as their corners' lattice positions, read through its list and vertex
/// array, sorted.
std::vector<Corners> listedTriangles(const RoamParts& w, std::int32_t tile) {
    const std::span<const std::uint32_t> indices = w.emitter.mesh(tile).indices();
    std::vector<Corners> out;
    for (std::size_t i = 0; i + 2 < indices.size(); i += 3) {
        Corners c{};
        for (std::size_t k = 0; k < 3; ++k) {
            const TileVertex v = w.emitter.tileVertex(tile, indices[i + k]);
            c[k] = {v.position.x, v.position.y};
        }
        out.push_back(c);
    }
    std::sort(out.begin(), out.end());
    return out;
}

/// Per tile, the triple lists of its index list (fillHoles first).
std::vector<std::vector<std::uint32_t>> everyList(RoamParts& w) {
    std::vector<std::vector<std::uint32_t>> lists;
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
        w.emitter.mesh(tile).fillHoles();
        const std::span<const std::uint32_t> idx = w.emitter.mesh(tile).indices();
        std::vector<std::array<std::uint32_t, 3>> tris;
        for (std::size_t i = 0; i + 2 < idx.size(); i += 3)
            tris.push_back({idx[i], idx[i + 1], idx[i + 2]});
        std::sort(tris.begin(), tris.end());
        std::vector<std::uint32_t> flat;
        for (const auto& t : tris)
            flat.insert(flat.end(), t.begin(), t.end());
        lists.push_back(std::move(flat));
    }
    return lists;
}

TEST(RoamTileEmitter, EveryEmittedLeafIsInItsTilesListWithItsCorners) {
    RoamParts w(crateredWorld());
    refine(w, false);
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile)
        w.emitter.emitTile(tile);
    std::vector<std::vector<Corners>> leaves(static_cast<std::size_t>(w.emitter.tileCount()));
    std::int64_t emitted = 0;
    std::int64_t finest = 0;
    w.emitter.forEachLeaf([&](const Triangle& t, std::int32_t tile, bool drawn) {
        if (!drawn)
            return;
        ++emitted;
        finest += t.level == roam::kFinestTriangleLevel ? 1 : 0;
        EXPECT_EQ(w.emitter.tileOf(t), tile);
        leaves[static_cast<std::size_t>(tile)].push_back(
            {{{t.apex.x, t.apex.y}, {t.left.x, t.left.y}, {t.right.x, t.right.y}}});
    });
    ASSERT_GT(finest, 1000) << "the refinement reached no block's finest triangles";
    std::int64_t listed = 0;
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
        auto& expected = leaves[static_cast<std::size_t>(tile)];
        std::sort(expected.begin(), expected.end());
        EXPECT_EQ(listedTriangles(w, tile), expected) << "tile " << tile;
        listed += w.emitter.mesh(tile).triangleCount();
    }
    EXPECT_EQ(listed, emitted);
    // the count split/merge keeps: the roots, and each split diamond's gain
    std::int64_t count = w.emitter.rootTriangles();
    for (const DiamondId id : w.everyId())
        if (id != roam::kNoDiamond && w.space.active(id))
            count += w.emitter.splitGain(roam::diamondAt(w.ids.pointOf(id)));
    EXPECT_EQ(count, emitted);
}

TEST(RoamTileEmitter, SplitsAndMergesKeepTheListsAFullEmissionWrites) {
    RoamParts w(crateredWorld());
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile)
        w.emitter.emitTile(tile);
    refine(w, true);
    // then splits and merges anywhere: a random detail cell's diamond, or a grid diamond
    std::mt19937_64 rng(11);
    const auto cells = detailCells(w.terrain);
    const std::vector<std::pair<std::int32_t, std::int32_t>> cell_list(cells.begin(), cells.end());
    const std::int32_t max_x = w.ids.geometry().real_x;
    const std::int32_t max_y = w.ids.geometry().real_y;
    std::int64_t splits = 0;
    std::int64_t merges = 0;
    for (int step = 0; step < 20000; ++step) {
        LatticePoint p;
        if (rng() % 4 == 0) {
            p = {
                static_cast<std::int32_t>(rng() % static_cast<std::uint64_t>(max_x)),
                static_cast<std::int32_t>(rng() % static_cast<std::uint64_t>(max_y))};
        } else {
            const auto& c = cell_list[rng() % cell_list.size()];
            const auto local = static_cast<std::int32_t>(1 + rng() % 255);
            p = {
                c.first * kLatticePerCell + local % kLatticePerCell,
                c.second * kLatticePerCell + local / kLatticePerCell};
        }
        const Diamond d = roam::diamondAt(p);
        const DiamondId id = w.ids.idOf(p);
        if (!d.valid() || id == roam::kNoDiamond)
            continue;
        if (!w.space.active(id)) {
            splits += splitWithParents(w, p, true) ? 1 : 0;
        } else if (!hasSplitChild(w, d)) {
            w.space.state(id) &= static_cast<std::uint8_t>(~DiamondSpace::kActive);
            w.emitter.splitTriangles(d, false, false);
            ++merges;
        }
    }
    ASSERT_GT(splits, 500);
    ASSERT_GT(merges, 500);
    const auto followed = everyList(w);
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile)
        w.emitter.emitTile(tile);
    const auto written = everyList(w);
    for (std::size_t tile = 0; tile < written.size(); ++tile)
        EXPECT_EQ(followed[tile], written[tile]) << "tile " << tile;
}

TEST(RoamTileEmitter, TheFramesEndCountsWhatTheListsHoldAndWhatWasWritten) {
    RoamParts w(crateredWorld());
    refine(w, false);
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile)
        w.emitter.emitTile(tile);
    roam::Camera camera; // over the first tile's corner, looking along +x: some tiles behind
    camera.eye = {70.0, 20.0, 40.0};
    camera.forward = {1.0, 0.0, -0.3};
    const roam::ViewMetric view(camera);
    roam::FrameStats first;
    w.emitter.finishFrame(1, view, w.bounds, first);
    std::int64_t triangles = 0;
    std::int64_t visible = 0;
    std::int64_t slot_bytes = 0;
    std::int32_t tiles_visible = 0;
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
        const roam::TileMesh& mesh = w.emitter.mesh(tile);
        EXPECT_EQ(mesh.slotCount(), mesh.triangleCount()) << "holes left after the frame";
        triangles += mesh.triangleCount();
        visible += w.emitter.visible(tile) ? mesh.triangleCount() : 0;
        tiles_visible += w.emitter.visible(tile) ? 1 : 0;
        slot_bytes +=
            static_cast<std::int64_t>(mesh.slotCount()) * roam::TileMesh::kIndexBytesPerTriangle;
    }
    EXPECT_EQ(first.triangles, triangles);
    EXPECT_EQ(first.visible_triangles, visible);
    EXPECT_EQ(first.index_bytes_total, slot_bytes);
    EXPECT_GT(tiles_visible, 0);
    EXPECT_LT(tiles_visible, w.emitter.tileCount()) << "every tile in view: visibility untested";
    EXPECT_GT(first.index_bytes_written, 0);
    // a frame that changed nothing wrote nothing; a forced split writes, counts and uploads
    roam::FrameStats idle;
    w.emitter.finishFrame(2, view, w.bounds, idle);
    EXPECT_EQ(idle.index_bytes_written, 0);
    const std::int64_t upload = w.emitter.uploadBytes();
    LatticePoint p{-1, -1}; // a detail cell's centre the refinement left unsplit
    for (std::int32_t r = 0; r < w.blocks.recordCapacity() && p.x < 0; ++r) {
        if (!w.blocks.recordInUse(r))
            continue;
        const DetailBlocks::CellXY c = w.blocks.recordCell(r);
        const LatticePoint q{
            c.x * kLatticePerCell + kLatticePerCell / 2,
            c.y * kLatticePerCell + kLatticePerCell / 2};
        const DiamondId id = w.ids.idOf(q);
        const Diamond d = roam::diamondAt(q);
        bool parents = d.valid() && d.level > 0;
        if (parents)
            for (const LatticePoint a : roam::apexes(d))
                parents = parents && w.ids.active(a);
        if (id != roam::kNoDiamond && !w.space.active(id) && parents && w.emitter.splitGain(d) > 0)
            p = q;
    }
    ASSERT_GE(p.x, 0) << "no split candidate found";
    const Diamond d = roam::diamondAt(p);
    const std::int32_t tile = w.emitter.tileOf(roam::triangleOf(d, roam::apexes(d)[0]));
    const std::uint64_t forced = w.emitter.mesh(tile).counters().forced_splits;
    std::uint64_t in_tile = 0; // the diamond's triangles in that tile (each one counts)
    for (const LatticePoint a : roam::apexes(d))
        in_tile += w.emitter.tileOf(roam::triangleOf(d, a)) == tile ? 1 : 0;
    for (std::int32_t t = 0; t < w.emitter.tileCount(); ++t)
        w.emitter.mesh(t).takeChanges(); // a renderer took everything: the split's pages are new
    w.space.state(w.ids.idOf(p)) |= DiamondSpace::kActive;
    w.emitter.splitTriangles(d, true, true);
    EXPECT_EQ(w.emitter.mesh(tile).counters().forced_splits, forced + in_tile);
    EXPECT_GT(w.emitter.uploadBytes(), upload);
    roam::FrameStats after;
    w.emitter.finishFrame(3, view, w.bounds, after);
    EXPECT_GT(after.index_bytes_written, 0);
    EXPECT_EQ(after.triangles, first.triangles + w.emitter.splitGain(d));
    // another world: the counters start again, nothing negative
    w.emitter.reset(w.terrain.spec());
    roam::FrameStats fresh;
    w.emitter.finishFrame(4, view, w.bounds, fresh);
    EXPECT_EQ(fresh.index_bytes_written, 0);
    EXPECT_EQ(fresh.triangles, 0);
}

TEST(RoamTileEmitter, ARangeOfVerticesReadsWhatEachVertexReads) {
    RoamParts w(crateredWorld());
    // a hole: a grain leaves its tile's array; its vertices read as the tile's first
    std::int32_t block = -1;
    for (std::int32_t r = 0; r < w.blocks.recordCapacity() && block < 0; ++r) {
        const std::int32_t b = w.blocks.recordInUse(r) ? w.blocks.blockOfRecord(r) : -1;
        if (b >= 0 && w.pool.segment(1, w.pool.chunkOf(b, 1)) >= 0)
            block = b; // a real cell's block (a virtual cell's grains have no segment)
    }
    ASSERT_GE(block, 0);
    const std::int32_t chunk = w.pool.chunkOf(block, 1);
    w.emitter.detachGrain(block, 1, w.pool.segment(1, chunk));
    w.pool.segment(1, chunk) = -1;
    bool hole_seen = false;
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
        const auto n = static_cast<std::uint32_t>(w.emitter.vertices().vertexCount(tile));
        std::vector<TileVertex> all(n);
        w.emitter.tileVertices(tile, all);
        const TileVertex first = w.emitter.tileVertex(tile, 0);
        for (std::uint32_t i = 0; i < n; ++i) {
            const TileVertex v = w.emitter.tileVertex(tile, i);
            ASSERT_EQ(all[i].position, v.position) << "tile " << tile << " vertex " << i;
            ASSERT_EQ(all[i].height, v.height);
            ASSERT_EQ(all[i].block_origin, v.block_origin);
            hole_seen |= i >= static_cast<std::uint32_t>(roam::kTileBaseVertices) &&
                         v.position == first.position && v.height == first.height &&
                         v.block_origin == first.block_origin;
        }
        for (const std::uint32_t from : {0u, 100u, n / 2, n - 7}) {
            std::vector<TileVertex> part(std::min<std::uint32_t>(n - from, 5000));
            w.emitter.tileVertices(tile, from, part);
            for (std::size_t i = 0; i < part.size(); ++i) {
                ASSERT_EQ(part[i].position, all[from + i].position) << "from " << from;
                ASSERT_EQ(part[i].height, all[from + i].height);
                ASSERT_EQ(part[i].block_origin, all[from + i].block_origin);
            }
        }
    }
    EXPECT_TRUE(hole_seen);
}

/// Whether a sample a base vertex's normal reads (one step either side) moved.
bool normalInputMoved(const Terrain& before, const Terrain& after, LatticePoint p) {
    const std::int32_t gx = p.x / kLatticePerCell;
    const std::int32_t gy = p.y / kLatticePerCell;
    const WorldSpec& spec = after.spec();
    for (const auto& [dx, dy] : {std::pair{0, 0}, {-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
        const std::int32_t x = std::clamp(gx + dx, 0, spec.paddedWidth() - 1);
        const std::int32_t y = std::clamp(gy + dy, 0, spec.paddedHeight() - 1);
        if (before.sample(x, y) != after.sample(x, y))
            return true;
    }
    return false;
}

TEST(RoamTileEmitter, AnOpMarksEveryVertexWhoseHeightOrNormalMoved) {
    RoamParts w(crateredWorld());
    const auto everyVertex = [&] {
        std::vector<std::vector<TileVertex>> all;
        for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
            all.emplace_back(static_cast<std::size_t>(w.emitter.vertices().vertexCount(tile)));
            w.emitter.tileVertices(tile, all.back());
        }
        return all;
    };
    const auto before = everyVertex();
    const Terrain surface_before = w.terrain;
    const OpRequest op = craterKeepingTheRecords(w);
    const CellRect r = w.change(op);
    w.bounds.markStale(r);
    w.bounds.recomputeAround(r);
    w.bounds.freshenHeights();
    // what the bounds update marked is its own; the emitter's marks must cover every move
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile)
        w.emitter.vertices().take(tile);
    w.emitter.markChangedSurface(r);
    const auto after = everyVertex();
    std::int64_t moved = 0;
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
        const auto t = static_cast<std::size_t>(tile);
        ASSERT_FALSE(w.emitter.vertices().allChanged(tile));
        for (std::size_t i = 0; i < after[t].size(); ++i) {
            if (after[t][i].height == before[t][i].height &&
                (i >= static_cast<std::size_t>(roam::kTileBaseVertices) ||
                 !normalInputMoved(surface_before, w.terrain, after[t][i].position)))
                continue;
            ++moved;
            bool marked = false;
            for (const roam::VertexRange& range : w.emitter.vertices().changes(tile))
                marked |= i >= range.begin && i < range.end;
            EXPECT_TRUE(marked) << "tile " << tile << " vertex " << i << " moved, unmarked";
        }
    }
    EXPECT_GT(moved, 0) << "the op moved no vertex";
}

TEST(RoamTileEmitter, GeomorphingMeetsAcrossTilesAndCellsAndReachesTheSurface) {
    RoamParts w(crateredWorld());
    refine(w, false);
    for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile)
        w.emitter.emitTile(tile);
    roam::Camera camera;
    camera.eye = {70.0, 20.0, 40.0};
    camera.forward = {0.0, 1.0, -0.5};
    const roam::ViewMetric view(camera);
    const double metres_per_fine = w.ids.geometry().metres_per_fine;
    for (const double full : {8.0, 0.5}) { // a band from 1 px to 8 px; none: every vertex true
        std::map<std::pair<std::int32_t, std::int32_t>, double> drawn_at;
        std::int64_t differs = 0;
        std::int64_t morphing = 0;
        for (std::int32_t tile = 0; tile < w.emitter.tileCount(); ++tile) {
            const auto n = static_cast<std::size_t>(w.emitter.vertices().vertexCount(tile));
            std::vector<double> drawn(n, std::nan(""));
            w.emitter.morphedHeights(tile, view, 1.0, full, w.bounds, drawn);
            for (const std::uint32_t i : w.emitter.mesh(tile).indices()) {
                const TileVertex v = w.emitter.tileVertex(tile, i);
                ASSERT_FALSE(std::isnan(drawn[i])) << "a vertex of the mesh was not drawn";
                const double z = static_cast<double>(v.height) * metres_per_fine;
                if (full <= 1.0) {
                    ASSERT_EQ(drawn[i], z);
                }
                morphing += drawn[i] != z ? 1 : 0;
                const auto [it, fresh] = drawn_at.insert({{v.position.x, v.position.y}, drawn[i]});
                differs += !fresh && it->second != drawn[i] ? 1 : 0;
            }
        }
        EXPECT_EQ(differs, 0) << "copies of a vertex drawn at different heights (a crack)";
        if (full > 1.0) {
            EXPECT_GT(morphing, 0) << "no vertex in the band: the test shows nothing";
        }
    }
}

} // namespace
} // namespace terrain::testing
