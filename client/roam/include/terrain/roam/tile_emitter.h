#pragma once

// The renderer's face of the tessellator: per tile, the index list of the mesh's leaf triangles
// (tile_mesh.h), the vertex array they index (tile_vertex_arrays.h: the base grid, then one
// segment per resident grain of the tile's blocks), whether the tile is in view, and the heights
// a geomorphing renderer draws.
//
// The lattice walk tells it what changed: a diamond split or merged (splitTriangles: its
// triangles' slots, a few index writes each), a whole tile to write again (emitTile), a grain
// joining or leaving a tile's array, an op's cells (markChangedSurface). A leaf triangle is
// emitted into the tile holding its centroid, with the indices of its corners in that tile's
// array: a base-grid corner for triangles down to the cells' own, else the copy of the corner in
// the grain of the cell's block that holds it (block_grains.h).
//
// Owns: the tiles' index lists, their visibility and slack, their vertex arrays' layout and
// changes, the upload it caused (index pages first written, grain vertices added), the
// geomorph walk's stamps. Reads: the terrain's grid heights, the records (DetailBlocks), the
// pool's chunks and heights (BlockPool), which diamonds are split (LatticeIds), bounds
// (BoundsUpdate, passed in). May not: split, merge or offer a diamond, make or evict a block,
// change a bound; it never decides what the mesh is, only writes it down.
// Pure, single-threaded; tiles are independent of each other except through their shared
// inputs.

#include <terrain/roam/bounds_update.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/frame_stats.h>
#include <terrain/roam/lattice.h>
#include <terrain/roam/lattice_ids.h>
#include <terrain/roam/tile_mesh.h>
#include <terrain/roam/tile_vertex_arrays.h>
#include <terrain/terrain.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::roam {

class TileEmitter {
  public:
    /// The parts it reads; they outlive it (the tessellator owns them all).
    TileEmitter(const DetailBlocks& blocks, const BlockPool& pool, const LatticeIds& ids)
        : blocks_(blocks), pool_(pool), ids_(ids) {}
    TileEmitter(const TileEmitter&) = delete;
    TileEmitter& operator=(const TileEmitter&) = delete;

    /// `spec`'s tiles, measured as ids' geometry (reset first): every list empty, every vertex
    /// array the base grid, nothing visible.
    void reset(const WorldSpec& spec);
    /// Reads the grid heights from `terrain` from now on.
    void read(const Terrain& terrain) { terrain_ = &terrain; }
    /// Every tile's vertex array back to the base grid, its version bumped and all of it changed
    /// (a snapshot: no block is resident any more).
    void clearVertexArrays();

    std::int32_t tileCount() const { return static_cast<std::int32_t>(tiles_.size()); }
    TileMesh& mesh(std::int32_t tile) { return tiles_[idx(tile)]; }
    const TileMesh& mesh(std::int32_t tile) const { return tiles_[idx(tile)]; }
    bool visible(std::int32_t tile) const { return visible_[idx(tile)] != 0; }
    TileVertexArrays& vertices() { return vertices_; }
    const TileVertexArrays& vertices() const { return vertices_; }

    /// Vertex `index` of the tile's array (a hole reads as the tile's first vertex).
    TileVertex tileVertex(std::int32_t tile, std::uint32_t index) const;
    /// Every vertex of the tile's array (out.size() == its vertex count).
    void tileVertices(std::int32_t tile, std::span<TileVertex> out) const;
    /// The vertices [first, first + out.size()) of the tile's array.
    void tileVertices(std::int32_t tile, std::uint32_t first, std::span<TileVertex> out) const;
    /// The heights (metres) the tile's mesh is drawn at for `view` (Tessellator::morphedHeights
    /// says how), refined to `threshold` with every vertex at its height from `full_pixels`.
    void morphedHeights(
        std::int32_t tile,
        const ViewMetric& view,
        double threshold,
        double full_pixels,
        const BoundsUpdate& bounds,
        std::span<double> out) const;
    /// Every leaf triangle of the current mesh: visit(triangle, tile, emitted).
    template <class Visit> void forEachLeaf(Visit&& visit) const;

    // what the lattice walk reports
    /// The diamond whose two triangles are the tile's level-0 halves.
    Diamond tileRoot(std::int32_t tile) const;
    /// The tile holding the triangle's centroid.
    std::int32_t tileOf(const Triangle& t) const;
    /// The tiles' emitted level-0 triangles: the mesh's count with nothing split.
    std::int64_t rootTriangles() const;
    /// Emitted triangles the mesh gains when `d` splits (loses when it merges).
    std::int64_t splitGain(const Diamond& d) const;
    /// `d` was split (or merged): its triangles' slots give way to their halves (or back).
    void splitTriangles(const Diamond& d, bool split, bool forced);
    /// Writes the tile's list again from the split diamonds.
    void emitTile(std::int32_t tile);
    /// Gives grain g's `chunk` of `block` a segment of its tile's array; -1 for a virtual cell
    /// past the grid, which nothing draws.
    std::int32_t attachGrain(std::int32_t block, int g, std::int32_t chunk);
    /// Grain g of `block` leaves its tile's array: its segment becomes a hole.
    void detachGrain(std::int32_t block, int g, std::int32_t segment);
    /// Grain g's `segment` of `block`'s tile is now read from chunk `to` (a compaction).
    void grainMoved(std::int32_t block, std::int32_t segment, std::int32_t to);
    /// The vertices of `block`'s tile changed (a block or grain went): a new version.
    void blockChanged(std::int32_t block);
    /// Bumps the versions of the tiles holding `cells` (their heights moved).
    void heightsChanged(CellRect cells);
    /// Marks the vertices whose height or normal an op over `cells` may have changed: the base
    /// grid and the blocks within a cell of them.
    void markChangedSurface(CellRect cells);

    /// The frame's end: holes filled, visibility for `view` (from `bounds`), a list with slack
    /// for long shrunk; the frame's triangles, visible triangles and index bytes into `stats`.
    void finishFrame(
        std::uint64_t frame, const ViewMetric& view, const BoundsUpdate& bounds, FrameStats& stats);
    /// Bytes a renderer uploads for what split/merge and new grains wrote, all told.
    std::int64_t uploadBytes() const;
    std::size_t memoryBytes() const;
    std::size_t scratchBytes() const { return morph_stamp_.capacity() * sizeof(std::uint32_t); }

  private:
    static std::size_t idx(std::int64_t v) { return static_cast<std::size_t>(v); }
    const LatticeGeometry& geo() const { return geo_; }
    std::uint32_t tileKey(const Triangle& t, std::int32_t tile) const;
    TileMesh::Indices indicesOf(const Triangle& t, std::int32_t tile) const;
    struct MeshVertex {
        std::uint32_t index = 0;
        std::int64_t height = 0; ///< fine units
    };
    /// Index in the tile's vertex array of `v`, a vertex of triangle `t` of the tile, and its
    /// height.
    MeshVertex vertexAt(LatticePoint v, const Triangle& t, std::int32_t tile) const;
    std::uint32_t vertexIndex(LatticePoint v, const Triangle& t, std::int32_t tile) const {
        return vertexAt(v, t, tile).index;
    }
    void emitTriangle(const Triangle& t, std::int32_t tile, TileMesh& mesh);
    std::int32_t tileOfBlock(std::int32_t block) const;
    /// morphedHeights' walk below triangle t.
    struct MorphWalk;
    /// Drawn and true heights (metres) of a triangle's apex, left and right.
    using Corners = std::array<double, 3>;
    void
    morphBelow(MorphWalk& walk, const Triangle& t, const Corners& drawn, const Corners& z) const;

    const DetailBlocks& blocks_;
    const BlockPool& pool_;
    const LatticeIds& ids_;
    const Terrain* terrain_ = nullptr;
    WorldSpec spec_;
    LatticeGeometry geo_; ///< ids_'s, copied: emission reads it per triangle
    std::vector<TileMesh> tiles_;
    std::vector<std::uint8_t> visible_;
    std::vector<std::uint64_t> snug_; ///< per tile: the frame its list last had no slack
    TileVertexArrays vertices_;
    std::uint64_t written_before_ = 0; ///< index bytes written when the last frame ended
    std::int64_t upload_pages_ = 0;    ///< index pages first written by split/merge, all told
    std::int64_t upload_vertices_ = 0; ///< grain vertices added to tiles' arrays, all told
    /// morphedHeights: per vertex of the tile, the call that last wrote it
    mutable std::vector<std::uint32_t> morph_stamp_;
    mutable std::uint32_t morph_call_ = 0;
};

template <class Visit> void TileEmitter::forEachLeaf(Visit&& visit) const {
    std::vector<Triangle> stack;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            stack.push_back(triangleOf(root, a));
        while (!stack.empty()) {
            const Triangle t = stack.back();
            stack.pop_back();
            if (t.level < kFinestTriangleLevel && ids_.active(splitPoint(t))) {
                const auto halves = splitTriangle(t);
                stack.push_back(halves[0]);
                stack.push_back(halves[1]);
            } else {
                visit(t, tile, geo().emitted(t));
            }
        }
    }
}

} // namespace terrain::roam
