#pragma once

// The CPU side of a tile's vertex buffer: GpuVertex values for vertices of the tessellator's
// array for one tile (positions in lattice units, heights in metres, normals of the surface),
// all of them or a run. Normals are central differences one grid step either side: on the base
// grid, of the samples a cell apart; inside detail blocks, of the lattice heights a lattice step
// apart, read from whole cells' 17 x 17 height grids (roam::fillCellHeights, cached for the
// frame: a cell's grid costs about what four single surface queries do per vertex). A lattice
// point's height is always read from the same cell's grid, so the two copies of a vertex on a
// cell border get the same normal. Pure: no GL.

#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>
#include <terrain/terrain.h>

#include <span>
#include <unordered_map>
#include <vector>

namespace terrain::render {

/// The vertex normal packed as GL_INT_2_10_10_10_REV, normalised (w = 0). Never 0 for a
/// terrain normal (z > 0), which marks "not computed yet".
std::uint32_t packNormal(double nx, double ny, double nz);

class TileVertexBuilder {
  public:
    /// Forgets the cached cell grids: once a frame, before the first build (the terrain may
    /// have changed since the last).
    void newFrame();
    /// The vertices [first, first + out.size()) of the tile's array.
    void build(
        const roam::Tessellator& tess,
        const Terrain& terrain,
        std::int32_t tile,
        std::uint32_t first,
        std::span<GpuVertex> out);
    /// Positions and heights only (normal 0): cheap, for validation.
    void positions(
        const roam::Tessellator& tess,
        std::int32_t tile,
        std::uint32_t first,
        std::span<GpuVertex> out);

  private:
    /// The grid of cell (cx, cy), cached.
    const std::int64_t* cellGrid(const Terrain& terrain, std::int32_t cx, std::int32_t cy);
    /// The height (fine units) of lattice point (x, y), from the grid of the cell that owns it.
    std::int64_t latticeHeight(const Terrain& terrain, std::int32_t x, std::int32_t y);
    std::uint32_t
    blockNormal(const Terrain& terrain, roam::LatticePoint p, double per_lattice, double per_fine);

    std::vector<roam::TileVertex> keys_;
    std::unordered_map<std::uint64_t, std::uint32_t> cell_slot_; ///< (cx, cy) -> grid slot
    std::vector<std::int64_t> grids_; ///< roam::kBlockVertices heights per slot
    std::uint64_t last_key_ = ~std::uint64_t{0};
    const std::int64_t* last_grid_ = nullptr;
};

} // namespace terrain::render
