// The tiles' index lists and vertex arrays as the lattice walk changes them, and the heights a
// geomorphing renderer draws them at (tile_emitter.h).

#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/tessellator_options.h>
#include <terrain/roam/tile_emitter.h>

#include <algorithm>

namespace terrain::roam {

using namespace detail;

void TileEmitter::reset(const WorldSpec& spec) {
    spec_ = spec;
    geo_ = ids_.geometry();
    written_before_ = 0; // the new lists' counters start from 0
    const std::size_t tiles = idx(spec_.tileCount());
    tiles_.clear();
    tiles_.resize(tiles);
    visible_.assign(tiles, 0);
    snug_.assign(tiles, 0);
    vertices_.reset(tiles);
}

void TileEmitter::clearVertexArrays() {
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        vertices_.clearTile(tile);
        vertices_.bumpVersion(tile);
        vertices_.markAll(tile);
    }
}

// ---- the lattice walk's changes -------------------------------------------------------------

Diamond TileEmitter::tileRoot(std::int32_t tile) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    return diamondAt(
        {tx * kLatticePerTile + kLatticePerTile / 2, ty * kLatticePerTile + kLatticePerTile / 2});
}

std::int32_t TileEmitter::tileOf(const Triangle& t) const {
    const LatticePoint c3 = centroidTimes3(t);
    return (c3.y / (3 * kLatticePerTile)) * spec_.tilesX() + c3.x / (3 * kLatticePerTile);
}

std::int64_t TileEmitter::rootTriangles() const {
    std::int64_t roots = 0;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            roots += geo().emitted(triangleOf(root, a)) ? 1 : 0;
    }
    return roots;
}

std::uint32_t TileEmitter::tileKey(const Triangle& t, std::int32_t tile) const {
    return tileTriangleKey(
        t, {(tile % spec_.tilesX()) * kLatticePerTile, (tile / spec_.tilesX()) * kLatticePerTile});
}

TileMesh::Indices TileEmitter::indicesOf(const Triangle& t, std::int32_t tile) const {
    return {
        vertexIndex(t.apex, t, tile), vertexIndex(t.left, t, tile), vertexIndex(t.right, t, tile)};
}

TileEmitter::MeshVertex
TileEmitter::vertexAt(LatticePoint v, const Triangle& t, std::int32_t tile) const {
    if (t.level <= kCellTriangleLevel) {
        const std::int32_t tx = tile % spec_.tilesX();
        const std::int32_t ty = tile / spec_.tilesX();
        const std::int32_t gx = v.x / kLatticePerCell;
        const std::int32_t gy = v.y / kLatticePerCell;
        return {
            static_cast<std::uint32_t>(
                (gy - ty * kTileCells) * kTileVertices + (gx - tx * kTileCells)),
            static_cast<std::int64_t>(terrain_->sample(gx, gy)) * kFineUnitsPerQuantum};
    }
    // a triangle finer than the base cells lies in one cell, and its vertices are in the grains
    // of that cell's block its split diamonds keep resident (block_grains.h)
    const LatticePoint c3 = centroidTimes3(t);
    const std::int32_t cx = c3.x / (3 * kLatticePerCell);
    const std::int32_t cy = c3.y / (3 * kLatticePerCell);
    const std::int32_t block = blocks_.blockOf(cx, cy);
    const std::int32_t k = v.x - cx * kLatticePerCell;
    const std::int32_t l = v.y - cy * kLatticePerCell;
    const int g = grainOf(k, l);
    const std::int32_t chunk = pool_.chunkOf(block, g);
    TERRAIN_ASSERT(chunk >= 0);
    const std::int32_t segment = pool_.segment(g, chunk);
    const std::uint16_t slot =
        grainTables().vertex_slot[static_cast<std::size_t>(l * kBlockSide + k)];
    return {
        vertices_.firstVertex(tile, segment) + slot,
        pool_.base(g, chunk) + pool_.heights(g, chunk)[slot]};
}

void TileEmitter::splitTriangles(const Diamond& d, bool split, bool forced) {
    for (const LatticePoint a : apexes(d)) {
        if (!geo().insideMap(a))
            continue;
        const Triangle t = triangleOf(d, a);
        const auto halves = splitTriangle(t);
        const std::int32_t tile = tileOf(t);
        TileMesh& mesh = tiles_[idx(tile)];
        // the pages this first writes are what a renderer will upload (the upload budget)
        const std::size_t pages_before = mesh.dirtyPages().size();
        if (split) {
            if (geo().emitted(t)) {
                [[maybe_unused]] const bool held = mesh.remove(tileKey(t, tile));
                TERRAIN_ASSERT(held); // every emitted leaf has a slot
            }
            for (const Triangle& h : halves)
                if (geo().emitted(h))
                    mesh.add(tileKey(h, tile), indicesOf(h, tile));
            ++mesh.counters().splits;
            if (forced)
                ++mesh.counters().forced_splits;
        } else {
            // second half first, so the parent takes back the first half's slot (its own)
            for (const int i : {1, 0}) {
                if (geo().emitted(halves[static_cast<std::size_t>(i)])) {
                    [[maybe_unused]] const bool held =
                        mesh.remove(tileKey(halves[static_cast<std::size_t>(i)], tile));
                    TERRAIN_ASSERT(held);
                }
            }
            if (geo().emitted(t))
                mesh.add(tileKey(t, tile), indicesOf(t, tile));
            ++mesh.counters().merges;
        }
        upload_pages_ += static_cast<std::int64_t>(mesh.dirtyPages().size() - pages_before);
    }
}

std::int64_t TileEmitter::splitGain(const Diamond& d) const {
    std::int64_t gain = 0;
    for (const LatticePoint a : apexes(d)) {
        if (!geo().insideMap(a))
            continue;
        const Triangle t = triangleOf(d, a);
        const auto halves = splitTriangle(t);
        gain += (geo().emitted(halves[0]) ? 1 : 0) + (geo().emitted(halves[1]) ? 1 : 0) -
                (geo().emitted(t) ? 1 : 0);
    }
    return gain;
}

void TileEmitter::emitTriangle(const Triangle& t, std::int32_t tile, TileMesh& mesh) {
    if (t.level < kFinestTriangleLevel && ids_.active(splitPoint(t))) {
        const auto halves = splitTriangle(t);
        emitTriangle(halves[0], tile, mesh);
        emitTriangle(halves[1], tile, mesh);
        return;
    }
    if (geo().emitted(t))
        mesh.add(tileKey(t, tile), indicesOf(t, tile));
}

void TileEmitter::emitTile(std::int32_t tile) {
    TileMesh& mesh = tiles_[idx(tile)];
    mesh.clear();
    const Diamond root = tileRoot(tile);
    for (const LatticePoint a : apexes(root))
        emitTriangle(triangleOf(root, a), tile, mesh);
}

// ---- the vertex arrays ----------------------------------------------------------------------

std::int32_t TileEmitter::tileOfBlock(std::int32_t block) const {
    return detail::tileOfCell(blocks_.cellOf(block), spec_);
}

std::int32_t TileEmitter::attachGrain(std::int32_t block, int g, std::int32_t chunk) {
    const std::int32_t tile = tileOfBlock(block);
    if (tile < 0) // a virtual cell past the grid: nothing draws it
        return -1;
    upload_vertices_ += kGrainVertices[static_cast<std::size_t>(g)];
    return vertices_.attach(tile, g, chunk);
}

void TileEmitter::detachGrain(std::int32_t block, int g, std::int32_t segment) {
    const std::int32_t tile = tileOfBlock(block);
    if (tile < 0 || segment < 0)
        return;
    vertices_.detach(tile, g, segment);
}

void TileEmitter::grainMoved(std::int32_t block, std::int32_t segment, std::int32_t to) {
    vertices_.rechunk(tileOfBlock(block), segment, to);
}

void TileEmitter::blockChanged(std::int32_t block) {
    if (const std::int32_t tile = tileOfBlock(block); tile >= 0)
        vertices_.bumpVersion(tile);
}

void TileEmitter::heightsChanged(CellRect cells) {
    for (std::int32_t ty = std::max(0, cells.y0) / kTileCells;
         ty <= std::min(cells.y1 / kTileCells, spec_.tilesY() - 1); ++ty)
        for (std::int32_t tx = std::max(0, cells.x0) / kTileCells;
             tx <= std::min(cells.x1 / kTileCells, spec_.tilesX() - 1); ++tx)
            vertices_.bumpVersion(ty * spec_.tilesX() + tx);
}

void TileEmitter::markChangedSurface(CellRect cells) {
    // base vertices: a sample moved at the corners of the cells (x0..x1+1), and a base normal
    // reads the samples one step either side; a block vertex's normal reads the surface one
    // lattice step away, inside its cell or the next. Vertices in the padding take the map
    // edge's normal: a change within two cells of the edge reaches all of them.
    std::int32_t vx0 = cells.x0 - 1;
    std::int32_t vx1 = cells.x1 + 2;
    std::int32_t vy0 = cells.y0 - 1;
    std::int32_t vy1 = cells.y1 + 2;
    CellRect blocks{cells.x0 - 1, cells.y0 - 1, cells.x1 + 1, cells.y1 + 1};
    if (cells.x1 + 2 >= spec_.cellsX()) {
        vx1 = spec_.tilesX() * kTileCells;
        blocks.x1 = vx1;
    }
    if (cells.y1 + 2 >= spec_.cellsY()) {
        vy1 = spec_.tilesY() * kTileCells;
        blocks.y1 = vy1;
    }
    // a tile holds grid vertices tx * 64 .. tx * 64 + 64: the one before shares column tx * 64
    for (std::int32_t ty = std::max(0, (vy0 - 1) / kTileCells);
         ty <= std::min(vy1 / kTileCells, spec_.tilesY() - 1); ++ty)
        for (std::int32_t tx = std::max(0, (vx0 - 1) / kTileCells);
             tx <= std::min(vx1 / kTileCells, spec_.tilesX() - 1); ++tx) {
            const std::int32_t tile = ty * spec_.tilesX() + tx;
            if (vertices_.allChanged(tile))
                continue;
            const std::int32_t gx0 = std::max(vx0 - tx * kTileCells, 0);
            const std::int32_t gx1 = std::min(vx1 - tx * kTileCells, kTileCells);
            const std::int32_t gy0 = std::max(vy0 - ty * kTileCells, 0);
            const std::int32_t gy1 = std::min(vy1 - ty * kTileCells, kTileCells);
            if (gx0 <= gx1)
                for (std::int32_t gy = gy0; gy <= gy1; ++gy)
                    vertices_.mark(
                        tile, static_cast<std::uint32_t>(gy * kTileVertices + gx0),
                        static_cast<std::uint32_t>(gy * kTileVertices + gx1 + 1));
            for (const VertexSegment& seg : vertices_.segments(tile)) {
                if (seg.chunk < 0)
                    continue;
                const auto g = static_cast<std::size_t>(seg.grain);
                const DetailBlocks::CellXY c = blocks_.cellOf(pool_.blockOf(seg.grain, seg.chunk));
                if (c.x < blocks.x0 || c.x > blocks.x1 || c.y < blocks.y0 || c.y > blocks.y1)
                    continue;
                const auto first = static_cast<std::uint32_t>(kBaseVertices + seg.offset);
                vertices_.mark(tile, first, first + static_cast<std::uint32_t>(kGrainVertices[g]));
            }
        }
}

TileVertex TileEmitter::tileVertex(std::int32_t tile, std::uint32_t index) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    const auto i = static_cast<std::int32_t>(index);
    if (i < kBaseVertices) {
        const std::int32_t gx = tx * kTileCells + i % kTileVertices;
        const std::int32_t gy = ty * kTileCells + i / kTileVertices;
        return {
            {gx * kLatticePerCell, gy * kLatticePerCell},
            static_cast<std::int64_t>(terrain_->sample(gx, gy)) * kFineUnitsPerQuantum,
            {-1, -1}};
    }
    const std::int32_t r = i - kBaseVertices;
    const std::span<const VertexSegment> segments = vertices_.segments(tile);
    // segments are in offset order: the last one starting at or before r holds it
    const auto it = std::upper_bound(
        segments.begin(), segments.end(), r,
        [](std::int32_t v, const VertexSegment& s) { return v < s.offset; });
    const VertexSegment& seg = *(it - 1);
    if (seg.chunk < 0) // a hole: no triangle refers to it; the tile's first vertex stands in
        return tileVertex(tile, 0);
    const auto g = static_cast<std::size_t>(seg.grain);
    const auto slot = static_cast<std::size_t>(r - seg.offset);
    const std::uint16_t local = grainTables().vertex_local[g][slot];
    const DetailBlocks::CellXY c = blocks_.cellOf(pool_.blockOf(seg.grain, seg.chunk));
    const LatticePoint origin{c.x * kLatticePerCell, c.y * kLatticePerCell};
    return {
        {origin.x + local % kBlockSide, origin.y + local / kBlockSide},
        pool_.base(seg.grain, seg.chunk) + pool_.heights(seg.grain, seg.chunk)[slot],
        origin};
}

void TileEmitter::tileVertices(
    std::int32_t tile, std::uint32_t first, std::span<TileVertex> out) const {
    const auto end = first + static_cast<std::uint32_t>(out.size());
    TERRAIN_ASSERT(end <= static_cast<std::uint32_t>(vertices_.vertexCount(tile)));
    std::uint32_t i = first;
    for (; i < end && i < static_cast<std::uint32_t>(kBaseVertices); ++i)
        out[i - first] = tileVertex(tile, i);
    if (i == end)
        return;
    const GrainTables& tables = grainTables();
    const std::span<const VertexSegment> segments = vertices_.segments(tile);
    // the segment holding i, then on through the next ones
    const auto r = static_cast<std::int32_t>(i) - kBaseVertices;
    auto it = std::upper_bound(
                  segments.begin(), segments.end(), r,
                  [](std::int32_t v, const VertexSegment& s) { return v < s.offset; }) -
              1;
    for (; i < end; ++it) {
        const VertexSegment& seg = *it;
        const auto g = static_cast<std::size_t>(seg.grain);
        const auto seg_first = static_cast<std::uint32_t>(kBaseVertices + seg.offset);
        const auto n = static_cast<std::uint32_t>(kGrainVertices[g]);
        if (seg.chunk < 0) { // a hole: the tile's first vertex stands in
            const TileVertex stand_in = tileVertex(tile, 0);
            for (; i < end && i < seg_first + n; ++i)
                out[i - first] = stand_in;
            continue;
        }
        const DetailBlocks::CellXY c = blocks_.cellOf(pool_.blockOf(seg.grain, seg.chunk));
        const LatticePoint origin{c.x * kLatticePerCell, c.y * kLatticePerCell};
        const std::int64_t base = pool_.base(seg.grain, seg.chunk);
        const std::uint32_t* heights = pool_.heights(seg.grain, seg.chunk).data();
        for (; i < end && i < seg_first + n; ++i) {
            const std::uint16_t local = tables.vertex_local[g][i - seg_first];
            out[i - first] = {
                {origin.x + local % kBlockSide, origin.y + local / kBlockSide},
                base + heights[i - seg_first],
                origin};
        }
    }
}

void TileEmitter::tileVertices(std::int32_t tile, std::span<TileVertex> out) const {
    TERRAIN_ASSERT(out.size() == static_cast<std::size_t>(vertices_.vertexCount(tile)));
    for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(kBaseVertices); ++i)
        out[i] = tileVertex(tile, i);
    const GrainTables& tables = grainTables();
    for (const VertexSegment& seg : vertices_.segments(tile)) {
        const auto g = static_cast<std::size_t>(seg.grain);
        const auto first = static_cast<std::size_t>(kBaseVertices + seg.offset);
        const auto n = static_cast<std::size_t>(kGrainVertices[g]);
        if (seg.chunk < 0) { // a hole: the tile's first vertex stands in
            std::fill_n(out.begin() + static_cast<std::ptrdiff_t>(first), n, out[0]);
            continue;
        }
        const DetailBlocks::CellXY c = blocks_.cellOf(pool_.blockOf(seg.grain, seg.chunk));
        const LatticePoint origin{c.x * kLatticePerCell, c.y * kLatticePerCell};
        const std::int64_t base = pool_.base(seg.grain, seg.chunk);
        const std::uint32_t* heights = pool_.heights(seg.grain, seg.chunk).data();
        for (std::size_t v = 0; v < n; ++v) {
            const std::uint16_t local = tables.vertex_local[g][v];
            out[first + v] = {
                {origin.x + local % kBlockSide, origin.y + local / kBlockSide},
                base + heights[v],
                origin};
        }
    }
}

// ---- the frame's end and geomorphing -------------------------------------------------------

void TileEmitter::finishFrame(
    std::uint64_t frame, const ViewMetric& view, const BoundsUpdate& bounds, FrameStats& stats) {
    std::uint64_t written = 0;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        TileMesh& mesh = tiles_[idx(tile)];
        mesh.fillHoles();
        written += mesh.counters().index_bytes_written;
        const Diamond root = tileRoot(tile);
        const DiamondBounds b = bounds.bounds(ids_.idOf(root.centre));
        const std::int32_t tx = tile % spec_.tilesX();
        const std::int32_t ty = tile / spec_.tilesX();
        Box box;
        box.lo = {
            tx * kLatticePerTile * geo().metres_per_lattice,
            ty * kLatticePerTile * geo().metres_per_lattice, b.zlo};
        box.hi = {
            std::min((tx + 1) * kLatticePerTile, geo().real_x) * geo().metres_per_lattice,
            std::min((ty + 1) * kLatticePerTile, geo().real_y) * geo().metres_per_lattice, b.zhi};
        const bool in_view = view.intersectsFrustum(box);
        visible_[idx(tile)] = in_view ? 1 : 0;
        // memory follows the mesh: a tile whose list has stayed well below its peak for a while
        // gives the capacity back (a few tiles a frame); one that returns to its peak, as in an
        // orbit, keeps it
        if (!mesh.hasSlack())
            snug_[idx(tile)] = frame;
        else if (
            frame > snug_[idx(tile)] + kTileSlackFrames &&
            (frame + static_cast<std::uint64_t>(tile)) % kTileShrinkEvery == 0)
            mesh.shrink();
        stats.triangles += mesh.triangleCount();
        if (in_view)
            stats.visible_triangles += mesh.triangleCount();
        stats.index_bytes_total +=
            static_cast<std::int64_t>(mesh.slotCount()) * TileMesh::kIndexBytesPerTriangle;
    }
    stats.index_bytes_written = static_cast<std::int64_t>(written - written_before_);
    written_before_ = written;
}

std::int64_t TileEmitter::uploadBytes() const {
    return upload_pages_ * TileMesh::kSlotsPerPage * TileMesh::kIndexBytesPerTriangle +
           upload_vertices_ * TessellatorOptions::kUploadBytesPerVertex;
}

std::size_t TileEmitter::memoryBytes() const {
    std::size_t bytes = vertices_.memoryBytes();
    for (const TileMesh& t : tiles_)
        bytes += t.memoryBytes();
    return bytes;
}

struct TileEmitter::MorphWalk {
    const ViewMetric* view = nullptr;
    const BoundsUpdate* bounds = nullptr;
    std::int32_t tile = 0;
    double low = 0.0;      ///< the threshold: a vertex starts on its hypotenuse
    double inv_band = 0.0; ///< 1 / (full - low); 0: every vertex at its height
    std::span<double> drawn;
};

void TileEmitter::morphedHeights(
    std::int32_t tile,
    const ViewMetric& view,
    double threshold,
    double full_pixels,
    const BoundsUpdate& bounds,
    std::span<double> out) const {
    const auto count = static_cast<std::size_t>(vertices_.vertexCount(tile));
    TERRAIN_ASSERT(out.size() == count);
    if (morph_stamp_.size() < count)
        morph_stamp_.resize(count, 0);
    if (++morph_call_ == 0) { // wrapped: old stamps could pass for new ones
        std::fill(morph_stamp_.begin(), morph_stamp_.end(), 0);
        morph_call_ = 1;
    }
    MorphWalk walk;
    walk.view = &view;
    walk.tile = tile;
    walk.bounds = &bounds;
    walk.low = threshold;
    walk.inv_band = full_pixels > threshold ? 1.0 / (full_pixels - threshold) : 0.0;
    walk.drawn = out;
    const Diamond root = tileRoot(tile);
    for (const LatticePoint a : apexes(root)) {
        const Triangle t = triangleOf(root, a);
        if (!geo().emitted(t))
            continue;
        // the tile's corners are roots: always at their height
        Corners z{};
        const std::array<LatticePoint, 3> corners = {t.apex, t.left, t.right};
        for (std::size_t i = 0; i < 3; ++i) {
            const MeshVertex v = vertexAt(corners[i], t, tile);
            z[i] = static_cast<double>(v.height) * geo().metres_per_fine;
            out[v.index] = z[i];
        }
        morphBelow(walk, t, z, z);
    }
}

void TileEmitter::morphBelow(
    MorphWalk& walk, const Triangle& t, const Corners& drawn, const Corners& z) const {
    if (t.level >= kFinestTriangleLevel)
        return;
    const LatticePoint c = splitPoint(t);
    const DiamondId id = ids_.idOf(c);
    if (!ids_.space().active(id))
        return;
    const auto halves = splitTriangle(t);
    if (t.level == kCellTriangleLevel) {
        // finer triangles use the copies of the cell's corners in its block
        walk.drawn[vertexIndex(t.apex, halves[0], walk.tile)] = drawn[0];
        walk.drawn[vertexIndex(t.left, halves[0], walk.tile)] = drawn[1];
        walk.drawn[vertexIndex(t.right, halves[0], walk.tile)] = drawn[2];
    }
    // a vertex on a cell's border has a copy in each cell's block, each one's triangles write
    // their own; the diamond's other triangle (this tile or another) finds the same ends: the
    // same arithmetic on the same values, so the same height everywhere
    const MeshVertex centre = vertexAt(c, halves[0], walk.tile);
    const double zc = static_cast<double>(centre.height) * geo().metres_per_fine;
    if (morph_stamp_[centre.index] != morph_call_) {
        morph_stamp_[centre.index] = morph_call_;
        const DiamondBounds b = walk.bounds->bounds(id);
        const Box box = geo().boxOf(diamondAt(c), b);
        const double priority =
            box.lo.x > box.hi.x ? 0.0 : walk.view->screenErrorAnyDirection(box, b.delta);
        const double s = walk.inv_band == 0.0
                             ? 1.0
                             : std::clamp((priority - walk.low) * walk.inv_band, 0.0, 1.0);
        walk.drawn[centre.index] = (drawn[1] + drawn[2]) * 0.5 + s * (zc - (z[1] + z[2]) * 0.5);
    }
    const double dc = walk.drawn[centre.index];
    if (geo().emitted(halves[0]))
        morphBelow(walk, halves[0], {dc, drawn[0], drawn[1]}, {zc, z[0], z[1]});
    if (geo().emitted(halves[1]))
        morphBelow(walk, halves[1], {dc, drawn[2], drawn[0]}, {zc, z[2], z[0]});
}

} // namespace terrain::roam
