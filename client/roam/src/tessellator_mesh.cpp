// The tessellator's mesh: splits and merges of diamonds into the tiles' index slots, full
// emission of a tile, tile vertex arrays, and what an op changes.

#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>

namespace terrain::roam {

using namespace detail;

// ---- the mesh -----------------------------------------------------------------------------

std::int32_t Tessellator::tileOf(const Triangle& t) const {
    const LatticePoint c3 = centroidTimes3(t);
    return (c3.y / (3 * kLatticePerTile)) * spec_.tilesX() + c3.x / (3 * kLatticePerTile);
}

std::uint32_t Tessellator::tileKey(const Triangle& t, std::int32_t tile) const {
    return tileTriangleKey(
        t, {(tile % spec_.tilesX()) * kLatticePerTile, (tile / spec_.tilesX()) * kLatticePerTile});
}

bool Tessellator::emitted(const Triangle& t) const {
    const std::int32_t min_x = std::min({t.apex.x, t.left.x, t.right.x});
    const std::int32_t min_y = std::min({t.apex.y, t.left.y, t.right.y});
    return min_x < real_x_ && min_y < real_y_;
}

TileMesh::Indices Tessellator::indicesOf(const Triangle& t, std::int32_t tile) const {
    return {
        vertexIndex(t.apex, t, tile), vertexIndex(t.left, t, tile), vertexIndex(t.right, t, tile)};
}

std::uint32_t Tessellator::vertexIndex(LatticePoint v, const Triangle& t, std::int32_t tile) const {
    return vertexAt(v, t, tile).index;
}

Tessellator::MeshVertex
Tessellator::vertexAt(LatticePoint v, const Triangle& t, std::int32_t tile) const {
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

bool Tessellator::hasActiveChild(const Diamond& d) const {
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i)
        if (active(idOf(kids[idx(i)])))
            return true;
    return false;
}

bool Tessellator::parentsActive(const Diamond& d) const {
    if (d.level == 0)
        return true;
    for (const LatticePoint a : apexes(d))
        if (insideMap(a) && !active(idOf(a)))
            return false;
    return true;
}

bool Tessellator::canActivate(const Diamond& d, DiamondId id) const {
    return id != kNoDiamond && parentsActive(d);
}

void Tessellator::splitTriangles(const Diamond& d, bool split, bool forced) {
    for (const LatticePoint a : apexes(d)) {
        if (!insideMap(a))
            continue;
        const Triangle t = triangleOf(d, a);
        const auto halves = splitTriangle(t);
        const std::int32_t tile = tileOf(t);
        TileMesh& mesh = tiles_[idx(tile)];
        // the pages this first writes are what a renderer will upload (the upload budget)
        const std::size_t pages_before = mesh.dirtyPages().size();
        if (split) {
            if (emitted(t)) {
                [[maybe_unused]] const bool held = mesh.remove(tileKey(t, tile));
                TERRAIN_ASSERT(held); // every emitted leaf has a slot
            }
            for (const Triangle& h : halves)
                if (emitted(h))
                    mesh.add(tileKey(h, tile), indicesOf(h, tile));
            ++mesh.counters().splits;
            if (forced)
                ++mesh.counters().forced_splits;
        } else {
            // second half first, so the parent takes back the first half's slot (its own)
            for (const int i : {1, 0}) {
                if (emitted(halves[static_cast<std::size_t>(i)])) {
                    [[maybe_unused]] const bool held =
                        mesh.remove(tileKey(halves[static_cast<std::size_t>(i)], tile));
                    TERRAIN_ASSERT(held);
                }
            }
            if (emitted(t))
                mesh.add(tileKey(t, tile), indicesOf(t, tile));
            ++mesh.counters().merges;
        }
        upload_pages_ += static_cast<std::int64_t>(mesh.dirtyPages().size() - pages_before);
    }
}

std::int64_t Tessellator::splitGain(const Diamond& d) const {
    std::int64_t gain = 0;
    for (const LatticePoint a : apexes(d)) {
        if (!insideMap(a))
            continue;
        const Triangle t = triangleOf(d, a);
        const auto halves = splitTriangle(t);
        gain += (emitted(halves[0]) ? 1 : 0) + (emitted(halves[1]) ? 1 : 0) - (emitted(t) ? 1 : 0);
    }
    return gain;
}

bool Tessellator::activate(const Diamond& d, DiamondId id, bool forced, FrameStats& stats) {
    if (active(id))
        return true;
    if (d.level > 0) {
        for (const LatticePoint a : apexes(d)) {
            if (!insideMap(a))
                continue;
            const DiamondId parent = resolve(a);
            if (parent == kNoDiamond) {
                // no record is a bug (must stay 0); else the pool refused (counted there)
                if (blocks_.recordOf(a.x / kLatticePerCell, a.y / kLatticePerCell) < 0)
                    ++missing_block_refusals_;
                return false;
            }
            if (!active(parent) && !activate(diamondAt(a), parent, true, stats))
                return false;
        }
    }
    // splitting a cell's centre draws the cell with its block's vertices
    if (isCentre(id)) {
        const std::int32_t record = static_cast<std::int32_t>(id - grid_count_);
        if (blocks_.blockOfRecord(record) < 0 && materialise(record) < 0)
            return false; // the pool refused
        pool_.markBlockUsed(blocks_.blockOfRecord(record), use_epoch_);
    }
    const std::int64_t gain = splitGain(d);
    if (triangles_ + gain > options_.max_triangles) {
        ++stats.refused_by_cap;
        refused_by_cap_ = true;
        return false;
    }
    state(id) |= kActive;
    if (id >= kPooled)
        markUsed(id);
    triangles_ += gain;
    ++stats.splits;
    if (forced)
        ++stats.forced_splits;
    if (!bookkeeping_)
        return true;
    splitTriangles(d, true, forced);
    policy_.clearCandidate(id);
    if (d.level > 0)
        for (const LatticePoint a : apexes(d))
            if (insideMap(a)) {
                const DiamondId parent = idOf(a);
                if ((state(parent) & kMergeCandidate) != 0)
                    policy_.clearCandidate(parent);
            }
    policy_.offer(id, kMergeCandidate);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i) {
        const LatticePoint c = kids[idx(i)];
        if (!insideMap(c))
            continue;
        const Diamond cd = diamondAt(c);
        DiamondId child = idOf(c);
        if (child == kNoDiamond && parentsActive(cd))
            child = resolve(c); // a virtual cell's block, hanging from the real cell before it
        if (child != kNoDiamond && !active(child) && canActivate(cd, child)) {
            policy_.offer(child, kSplitCandidate);
        }
    }
    return true;
}

void Tessellator::deactivate(const Diamond& d, DiamondId id, FrameStats& stats) {
    state(id) = static_cast<std::uint8_t>(state(id) & ~kActive);
    triangles_ -= splitGain(d);
    ++stats.merges;
    if (!bookkeeping_)
        return;
    splitTriangles(d, false, false);
    policy_.clearCandidate(id);
    policy_.offer(id, kSplitCandidate);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i) {
        const DiamondId child = idOf(kids[idx(i)]);
        if (child != kNoDiamond && (state(child) & kSplitCandidate) != 0)
            policy_.clearCandidate(child);
    }
    if (d.level == 0)
        return;
    for (const LatticePoint a : apexes(d)) {
        if (!insideMap(a))
            continue;
        const DiamondId parent = idOf(a);
        const Diamond pd = diamondAt(a);
        if (active(parent) && !hasActiveChild(pd)) {
            policy_.offer(parent, kMergeCandidate);
        }
    }
}

void Tessellator::deactivateSubtree(LatticePoint p, FrameStats& stats) {
    const DiamondId id = idOf(p);
    if (!active(id))
        return;
    const Diamond d = diamondAt(p);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i)
        if (insideMap(kids[idx(i)]))
            deactivateSubtree(kids[idx(i)], stats);
    deactivate(d, id, stats);
}

void Tessellator::emitTriangle(const Triangle& t, std::int32_t tile, TileMesh& mesh) {
    if (t.level < kFinestTriangleLevel && active(idOf(splitPoint(t)))) {
        const auto halves = splitTriangle(t);
        emitTriangle(halves[0], tile, mesh);
        emitTriangle(halves[1], tile, mesh);
        return;
    }
    if (emitted(t))
        mesh.add(tileKey(t, tile), indicesOf(t, tile));
}

Diamond Tessellator::tileRoot(std::int32_t tile) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    return diamondAt(
        {tx * kLatticePerTile + kLatticePerTile / 2, ty * kLatticePerTile + kLatticePerTile / 2});
}

void Tessellator::emitTile(std::int32_t tile) {
    TileMesh& mesh = tiles_[idx(tile)];
    mesh.clear();
    const Diamond root = tileRoot(tile);
    for (const LatticePoint a : apexes(root))
        emitTriangle(triangleOf(root, a), tile, mesh);
}

void Tessellator::markChangedSurface(CellRect cells) {
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

std::int32_t Tessellator::tileOfCell(DetailBlocks::CellXY c) const {
    return detail::tileOfCell(c, spec_);
}

void Tessellator::attachGrain(std::int32_t block, int g) {
    const std::int32_t chunk = pool_.chunkOf(block, g);
    const std::int32_t tile = tileOfCell(blocks_.cellOf(block));
    if (tile < 0) { // a virtual cell past the grid: nothing draws it
        pool_.segment(g, chunk) = -1;
        return;
    }
    pool_.segment(g, chunk) = vertices_.attach(tile, g, chunk);
    upload_vertices_ += kGrainVertices[static_cast<std::size_t>(g)];
}

void Tessellator::detachGrain(std::int32_t block, int g) {
    const std::int32_t chunk = pool_.chunkOf(block, g);
    const std::int32_t segment = pool_.segment(g, chunk);
    pool_.segment(g, chunk) = -1;
    const std::int32_t tile = tileOfCell(blocks_.cellOf(block));
    if (tile < 0 || segment < 0)
        return;
    vertices_.detach(tile, g, segment);
}

TileVertex Tessellator::tileVertex(std::int32_t tile, std::uint32_t index) const {
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

void Tessellator::tileVertices(
    std::int32_t tile, std::uint32_t first, std::span<TileVertex> out) const {
    const auto end = first + static_cast<std::uint32_t>(out.size());
    TERRAIN_ASSERT(end <= static_cast<std::uint32_t>(tileVertexCount(tile)));
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

void Tessellator::tileVertices(std::int32_t tile, std::span<TileVertex> out) const {
    TERRAIN_ASSERT(out.size() == static_cast<std::size_t>(tileVertexCount(tile)));
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

// ---- terrain changes ----------------------------------------------------------------------

void Tessellator::terrainChanged(std::span<const CellRect> cells, bool all) {
    bounds_.surfaceChanged();
    if (all) {
        // a snapshot may bring another world (size, spacing): start from its spec
        if (tiles_.empty() || !(terrain_->spec() == spec_))
            adoptSpec();
        bounds_.reset(*terrain_, {spec_, metres_per_fine_, max_x_, max_y_});
        // the heap forgets its ids before their ranges shrink with the pool (clearing writes to
        // each held id's position)
        policy_.clearCandidates();
        blocks_.reset(*terrain_); // records only: no block resident
        pool_.clear();
        space_.dropChunks();
        resizeDiamondState();
        space_.clearStates();
        for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
            vertices_.clearTile(tile);
            vertices_.bumpVersion(tile);
            vertices_.markAll(tile);
        }
        bounds_.recomputeAll();
        needs_rebuild_ = true;
        return;
    }
    FrameStats ignored;
    // ops of one frame often overlap (shots land where the fight is): work through the union of
    // rectangles that overlap enough, so that a block and its bounds are redone once, not per op
    merged_.clear();
    for (const CellRect& r : cells)
        if (!r.empty())
            merged_.push_back(r);
    mergeOverlapping(merged_);
    for (const CellRect& r : merged_) {
        // records about to go: coarsen everything that refines into them first
        removing_.clear();
        blocks_.plan(*terrain_, r, removing_);
        for (const std::int32_t record : removing_) {
            const DetailBlocks::CellXY c = blocks_.recordCell(record);
            // every split diamond of the cell descends from its centre
            deactivateSubtree(
                {c.x * kLatticePerCell + kCentreLocal, c.y * kLatticePerCell + kCentreLocal},
                ignored);
            const std::int32_t block = blocks_.blockOfRecord(record);
            if (block >= 0) {
                for (std::uint32_t local = 1; local < kDiamondsPerBlock; ++local)
                    deactivateSubtree(
                        {c.x * kLatticePerCell + static_cast<std::int32_t>(local % kLatticePerCell),
                         c.y * kLatticePerCell +
                             static_cast<std::int32_t>(local / kLatticePerCell)},
                        ignored);
                for (std::uint32_t local = 1; local < kDiamondsPerBlock; ++local)
                    if (const DiamondId id = pooledId(block, local); id != kNoDiamond)
                        policy_.clearCandidate(id);
                // its segments in the tile's vertex array become holes: nothing refers to them
                evict(block);
            }
            policy_.clearCandidate(centreId(record));
            state(centreId(record)) = 0;
        }
        // the centres' bounds before (they are derived, not stored): only those that move are
        // re-examined
        bounds_.noteCentres(r);
        removed_.clear();
        added_.clear();
        blocks_.update(*terrain_, r, removed_, added_);
        resizeDiamondState();
        for (const std::int32_t record : added_)
            state(centreId(record)) = 0;
        // heights moved in these tiles
        for (std::int32_t ty = std::max(0, r.y0) / kTileCells;
             ty <= std::min(r.y1 / kTileCells, spec_.tilesY() - 1); ++ty)
            for (std::int32_t tx = std::max(0, r.x0) / kTileCells;
                 tx <= std::min(r.x1 / kTileCells, spec_.tilesX() - 1); ++tx)
                vertices_.bumpVersion(ty * spec_.tilesX() + tx);
        bounds_.markStale(r);
        bounds_.recomputeAround(r);
        if (initialized_ && !needs_rebuild_)
            for (const DiamondId id : bounds_.moved())
                refreshCandidate(id);
    }
    // the resident blocks' heights follow the op now, with the base grid's (read from the
    // terrain): a mesh drawn before the next update() is the new surface, without cracks
    // between a block and the grid around it (their bounds wait for the frames' budget)
    bounds_.freshenHeights();
    for (const CellRect& r : merged_)
        markChangedSurface(r);
}

void Tessellator::mergeOverlapping(std::vector<CellRect>& rects) {
    const auto area = [](const CellRect& r) {
        return static_cast<std::int64_t>(r.x1 - r.x0 + 1) * (r.y1 - r.y0 + 1);
    };
    // merge two whenever their union costs no more than the two apart; passes until none do
    bool merged = true;
    while (merged) {
        merged = false;
        for (std::size_t i = 0; i < rects.size(); ++i)
            for (std::size_t j = i + 1; j < rects.size();) {
                const CellRect& a = rects[i];
                const CellRect& b = rects[j];
                const CellRect u{
                    std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1),
                    std::max(a.y1, b.y1)};
                if (area(u) <= area(a) + area(b)) {
                    rects[i] = u;
                    rects[j] = rects.back();
                    rects.pop_back();
                    merged = true;
                } else {
                    ++j;
                }
            }
    }
}

void Tessellator::refreshCandidate(DiamondId id) {
    const Diamond d = diamondAt(pointOf(id));
    std::uint8_t kind = 0;
    if (active(id))
        kind = hasActiveChild(d) ? 0 : kMergeCandidate;
    else if (canActivate(d, id))
        kind = kSplitCandidate;
    policy_.clearCandidate(id);
    if (kind != 0) {
        policy_.offer(id, kind);
    }
}

} // namespace terrain::roam
