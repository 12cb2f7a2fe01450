#pragma once

// The CPU side of a tile's vertex buffer: the GpuVertex array of the tessellator's vertex array
// for one tile (positions in lattice units, heights, normals of the true surface), built against
// what the buffer already holds, so that only vertices that are new to their slot, moved, lie
// within a cell of one that moved, or lie in a changed region get new normals. Pure: no GL.

#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>
#include <terrain/terrain.h>

#include <span>
#include <vector>

namespace terrain::render {

/// A lattice-unit rectangle (inclusive) where the surface changed.
struct LatticeRegion {
    roam::LatticePoint lo;
    roam::LatticePoint hi;
    bool contains(roam::LatticePoint p) const {
        return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y;
    }
};

/// The vertex normal packed as GL_INT_2_10_10_10_REV, normalised (w = 0). Never 0 for a
/// terrain normal (z > 0), which marks "not computed yet".
std::uint32_t packNormal(double nx, double ny, double nz);

class TileVertexBuilder {
  public:
    /// Fills `out` (resized to the tile's vertex count). `previous`: the buffer's vertices
    /// (empty: every normal is computed, as a fresh build does); `changed`: regions whose
    /// normals are redone whatever moved.
    void build(
        const roam::Tessellator& tess,
        const Terrain& terrain,
        std::int32_t tile,
        std::span<const GpuVertex> previous,
        std::span<const LatticeRegion> changed,
        std::vector<GpuVertex>& out);

  private:
    std::vector<roam::TileVertex> keys_;
};

} // namespace terrain::render
