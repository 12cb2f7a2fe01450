#pragma once

// The nested error bounds of the diamonds below the base grid, computed for a set of detail
// cells at once from their full-resolution heights (the kernel behind the tessellator's blocks).
//
// A sub-grid diamond's bound (ROAM's nested bound: how far its centre lies from its hypotenuse,
// plus the largest of its children's bounds; the finest triangles start from the patch's grid
// error) depends on its descendants, which reach into the cells around its own: the bounds of a
// cell's 255 diamonds depend on the heights of its 3 x 3 cells and no further
// (RoamMesh.LazyBoundsEqualBoundsBuiltForEveryCellAtOnce). So a pass computes the heights of the
// targets' 3 x 3 windows (fillCellHeights, with the tessellator's rules for the map's last
// lines) and, level by level, finest first, the bounds of the diamonds the targets depend on (a
// static table: a target's own 255 and its border diamonds' descendants in its neighbours);
// each target's bounds are then exact whatever else is resident. A bound is clamped to a nested cap
// (the largest cellError of the cells its triangles and its children's touch), so a diamond's bound
// is never above the conservative bound of the cell's centre, nor below a child's.
//
// Heights are fine units (1/16 quantum), bounds metres (floats rounded outward). Pure: no GL,
// no clocks, no I/O. Single-threaded; the scratch is reused between passes.

#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/lattice.h>
#include <terrain/terrain.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::roam {

/// A diamond's nested bound: `delta` (metres, rounded up) bounds the vertical distance between its
/// triangles, or any refinement of them, and the true surface; [zlo, zhi] holds everything its
/// refinement can produce, over the square its descendants reach.
struct DiamondBounds {
    float delta = 0.0f;
    float zlo = 0.0f;
    float zhi = 0.0f;
};

/// The map as the tessellator sees it.
struct BlockGeometry {
    double metres_per_fine = 0.0;
    std::int32_t grid_w = 0; ///< padded grid, vertices
    std::int32_t grid_h = 0;
    std::int32_t cells_x = 0; ///< real map, cells
    std::int32_t cells_y = 0;
};

class BlockBounds {
  public:
    /// Heights and bounds of every sub-grid diamond of every cell in `cells` (each a detail cell,
    /// none twice). A pass's scratch spans the cells' bounding box: callers split scattered sets.
    void compute(
        const Terrain& t,
        const DetailBlocks& records,
        const BlockGeometry& g,
        std::span<const DetailBlocks::CellXY> cells);

    /// The bounds of diamond `local` (l * 16 + k; not the grid vertex 0) of cells[i]; zero for a
    /// diamond off the map (a virtual cell's past its first line).
    const DiamondBounds& bounds(std::size_t i, std::uint32_t local) const {
        return bounds_[target_bounds_[i] * kCellDiamonds + local];
    }
    /// The cap bounds(i, local) was clamped to.
    float cap(std::size_t i, std::uint32_t local) const {
        return caps_[target_bounds_[i] * kCellDiamonds + local];
    }
    /// The heights of cells[i]'s 17 x 17 vertices as its block draws them (fillCellHeights).
    void heights(std::size_t i, std::span<std::int64_t, kBlockVertices> out) const;

    std::size_t memoryBytes() const;

  private:
    static constexpr std::size_t kCellDiamonds = kLatticePerCell * kLatticePerCell;

    std::int32_t regionIndex(std::int32_t cx, std::int32_t cy) const {
        return (cy - ry0_) * rw_ + (cx - rx0_);
    }
    /// On the map's last lines or past them: the mesh reads other heights than the cell's own.
    bool special(std::int32_t cx, std::int32_t cy) const;
    void fillRuled(std::int32_t cx, std::int32_t cy, std::span<std::int64_t, kBlockVertices> out);
    /// What a bound cell's passes read around it, gathered once per pass.
    struct CellFrame {
        std::int32_t cx = 0;
        std::int32_t cy = 0;
        bool clear = false; ///< every point of its 3 x 3 is on the map: no map checks
        bool inner = false; ///< a cell of the padded grid, not a virtual one past it
        const std::array<std::uint64_t, 4>* needed = nullptr;
        const std::int64_t* own_raw = nullptr; ///< its own heights (not the ruled ones)
        std::size_t own_bounds = 0;            ///< its first entry in bounds_ and caps_
        /// Per cell of its 3 x 3 ((dy + 1) * 3 + dx + 1): the heights as the mesh's rules read
        /// them (or none), its bound slot (or -1), its cap, its finest triangles' error (metres).
        std::array<const std::int64_t*, 9> heights{};
        std::array<std::int32_t, 9> bounds{-1, -1, -1, -1, -1, -1, -1, -1, -1};
        std::array<float, 9> caps{};
        std::array<double, 9> finest{};
    };
    CellFrame frameOf(std::int32_t cx, std::int32_t cy) const;
    /// The bounds of the cell's needed diamonds of one level (the finer levels' being done).
    void boundLevel(const CellFrame& f, int level);
    template <bool kClear> void boundLevelOf(const CellFrame& f, int level);

    const Terrain* terrain_ = nullptr;
    const DetailBlocks* records_ = nullptr;
    BlockGeometry geometry_{};
    std::int32_t rx0_ = 0; ///< region: the targets' bounding box, a cell wider
    std::int32_t ry0_ = 0;
    std::int32_t rw_ = 0;
    std::int32_t rh_ = 0;
    /// Per region cell: the diamonds some target's bounds depend on (a bit per local position).
    std::vector<std::array<std::uint64_t, 4>> needed_;
    std::vector<std::int32_t> height_slot_; ///< per region cell: its heights in heights_, or -1
    std::vector<std::int32_t> ruled_slot_;  ///< per region cell: its heights in ruled_, or -1
    std::vector<std::int32_t> bound_slot_;  ///< per region cell: its bounds in bounds_, or -1
    std::vector<std::int64_t> heights_;     ///< kBlockVertices per slot, the cell's own
    std::vector<std::int64_t> ruled_;       ///< the same where the mesh's rules differ
    std::vector<DiamondBounds> bounds_;     ///< kCellDiamonds per slot
    std::vector<float> caps_;
    std::vector<float> cell_caps_;                  ///< per region cell: its cellError (metres)
    std::vector<DetailBlocks::CellXY> bound_cells_; ///< the cells with bounds, by slot
    std::vector<CellFrame> frames_;                 ///< by slot
    std::vector<std::size_t> target_bounds_;        ///< bound slot of each target
    std::vector<DetailBlocks::CellXY> targets_;
    std::array<std::int64_t, kBlockVertices> scratch_{};
};

} // namespace terrain::roam
