#pragma once

// The CPU side of a tile's vertex buffer: DrawVertex values for vertices of the tessellator's
// array for one tile (positions in lattice units, heights in metres, normals of the surface),
// a run of them or a list. Normals are central differences one grid step either side: on the base
// grid, of the samples a cell apart; inside detail blocks, of the lattice heights a lattice step
// apart, read from whole cells' 17 x 17 height grids (fillCellHeights, cached until the
// terrain changes there or the cache evicts them, least recently used first: a cell's grid costs
// about what four single surface queries do per vertex). A lattice
// point's height is always read from the same cell's grid, so the two copies of a vertex on a
// cell border get the same normal. Pure: no GL.

#include <terrain/roam/tessellator.h>
#include <terrain/roam/vertex_slots.h>
#include <terrain/terrain.h>

#include <algorithm>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

namespace terrain::roam {

/// One vertex as a renderer draws it: x and y in lattice units (1/16 cell) from the map's corner
/// (whole numbers, exact in a float), z in metres, and the normal packed as signed 10:10:10:2
/// (GL_INT_2_10_10_10_REV, normalised). 16 bytes, the layout of the GPU's vertex buffers.
struct DrawVertex {
    float x = 0.0f;
    float y = 0.0f;
    float z = 0.0f;
    std::uint32_t normal = 0;
};

/// The vertex normal packed as GL_INT_2_10_10_10_REV, normalised (w = 0). Never 0 for a
/// terrain normal (z > 0), which marks "not computed yet".
std::uint32_t packNormal(double nx, double ny, double nz);

class TileVertexBuilder {
  public:
    /// Grids kept at most by default (4.7 MB): past it, one is evicted per new grid.
    static constexpr std::size_t kMaxCells = 2048;
    explicit TileVertexBuilder(std::size_t max_cells = kMaxCells)
        : max_cells_(std::max<std::size_t>(max_cells, 1)) {}

    /// Forgets the cached cell grids: once a frame, before the first build (the terrain may
    /// have changed since the last).
    void newFrame();
    /// Forgets the cached grids of `cells` only (the rest of the terrain did not change): a
    /// builder told every change keeps its grids from one build to the next.
    void forget(CellRect cells);
    /// The vertices [first, first + out.size()) of the tile's array.
    void build(
        const Tessellator& tess,
        const Terrain& terrain,
        std::int32_t tile,
        std::uint32_t first,
        std::span<DrawVertex> out);
    /// Vertex indices[i] of the tile's array into out[i]; kNoVertex: a point of the tile facing
    /// up, standing in for a vertex nothing draws. Consecutive indices are built as runs.
    static constexpr std::uint32_t kNoVertex = VertexSlots::kNone;
    void buildEach(
        const Tessellator& tess,
        const Terrain& terrain,
        std::int32_t tile,
        std::span<const std::uint32_t> indices,
        std::span<DrawVertex> out);
    /// Cell grids held now (at most the max_cells it was made with).
    std::size_t cachedGrids() const { return cell_slot_.size(); }
    /// Positions and heights only (normal 0): cheap, for validation.
    void positions(
        const Tessellator& tess, std::int32_t tile, std::uint32_t first, std::span<DrawVertex> out);

  private:
    /// The grid of cell (cx, cy), cached.
    const std::int64_t* cellGrid(const Terrain& terrain, std::int32_t cx, std::int32_t cy);
    /// The height (fine units) of lattice point (x, y), from the grid of the cell that owns it.
    std::int64_t latticeHeight(const Terrain& terrain, std::int32_t x, std::int32_t y);
    std::uint32_t
    blockNormal(const Terrain& terrain, LatticePoint p, double per_lattice, double per_fine);

    /// A slot held by no grid, by its least recently used one in clock order.
    std::uint32_t evictOne();
    static constexpr std::uint64_t kNoCell = ~std::uint64_t{0};

    std::size_t max_cells_ = kMaxCells;

    std::vector<TileVertex> keys_;
    std::unordered_map<std::uint64_t, std::uint32_t> cell_slot_; ///< (cx, cy) -> grid slot
    std::vector<std::int64_t> grids_;         ///< kBlockVertices heights per slot
    std::vector<std::uint64_t> slot_keys_;    ///< per slot: its cell, or kNoCell
    std::vector<std::uint8_t> recently_used_; ///< per slot: used since the clock last passed
    std::uint32_t hand_ = 0;
    std::vector<std::uint32_t> free_slots_; ///< slots of forgotten grids
    std::uint64_t last_key_ = ~std::uint64_t{0};
    const std::int64_t* last_grid_ = nullptr;
};

} // namespace terrain::roam
