#pragma once

// The chunked level of detail most engines ship (geomipmapping, CDLOD-style quadtree), built
// as its best form so the charts compare our ROAM with what a user would otherwise pick.
//
// A quadtree of chunks: every chunk is a grid of kChunkCells x kChunkCells cells at its level's
// step (2^level base cells), triangulated with the base surface's alternating diagonals, so a
// chunk's triangles are unions of the base triangles (the 4-8 hierarchy) and its error against
// the base surface is largest at a base vertex. Each chunk stores that error, exactly (every base
// vertex it covers), plus the largest deviation of a detail patch under it (the base grid is its
// finest level: it cannot show sub-grid crater detail, and its stated error says so).
//
// Selection is error-driven and best-first: from the root, the chunk whose screen error
// (ViewMetric::screenError of its box and error: the same bound ROAM uses) is largest is split
// first, while it exceeds tau and the triangle cap allows. Neighbours then differ by at most one
// level (a restricted quadtree: a leaf next to a finer leaf two levels down is split, "forced"),
// and a chunk next to a coarser one drops its odd edge vertices: each pair of triangles at such
// an edge becomes one (the 4-8 parent of the pair), so the mesh is conforming (no T-junction,
// no skirt). The stitched strip has its own error (stored per edge); where it would break tau,
// the coarser neighbour is split too (forced), so every drawn chunk is within tau as stitched,
// except where the base grid is the finest level and a patch's deviation alone exceeds it.
//
// Drawing model (for the bytes it would upload): a chunk's vertex buffer is loaded when it is
// first drawn and kept until it has been out of the selection for evict_after_frames; its index
// buffers are shared by every chunk (16 stitch variants, loaded once). An op reloads the loaded
// chunks it touches. Pure: no GL, no clocks.

#include <terrain/roam/camera.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::lodlab {

inline constexpr std::int32_t kChunkCells = 16;
inline constexpr std::int32_t kChunkVertices = (kChunkCells + 1) * (kChunkCells + 1);
inline constexpr std::int32_t kChunkVertexBytes = 16; ///< as the renderer's GpuVertex

struct ChunkedLodOptions {
    double tau_pixels = 1.0;
    std::int64_t max_triangles = 4'000'000;
    std::uint32_t evict_after_frames = 300;
};

struct ChunkedFrame {
    std::int64_t nodes_visited = 0;
    std::int64_t leaves = 0;        ///< chunks selected, in view or not
    std::int64_t chunks_drawn = 0;  ///< leaves in the frustum
    std::int64_t triangles = 0;     ///< of the chunks drawn
    std::int64_t forced_splits = 0; ///< splits the 2:1 restriction needed
    std::int64_t stitched_edges = 0;
    std::int64_t upload_bytes = 0;
    /// Largest screen error bound over the chunks drawn: tau, or more where the cap bound or a
    /// base-level chunk's error (patches) exceeds it.
    double error_bound_pixels = 0.0;
    std::int64_t chunks_over_tau = 0; ///< drawn chunks whose bound exceeds tau
    bool capped = false;              ///< the triangle cap stopped a split
};

class ChunkedLod {
  public:
    ChunkedLod(const Terrain& terrain, const ChunkedLodOptions& options);

    ChunkedFrame update(const roam::Camera& camera);
    /// The surface changed under `cells` (or everywhere): errors and boxes of the chunks above
    /// them are recomputed, loaded ones reloaded.
    void terrainChanged(std::span<const CellRect> cells, bool all);
    void setTau(double tau_pixels) { options_.tau_pixels = tau_pixels; }
    void setMaxTriangles(std::int64_t max_triangles) { options_.max_triangles = max_triangles; }

    /// Triangles of the selected chunks (in the frustum only, or all), in world metres, counter-
    /// clockwise seen from above, three vertices each.
    void triangles(bool visible_only, std::vector<glm::dvec3>& out) const;
    /// The same as base-grid vertex indices x0 y0 x1 y1 x2 y2 (exact; tests: conformity).
    void gridTriangles(bool visible_only, std::vector<std::array<std::int32_t, 6>>& out) const;

    /// Stated error (metres) of chunk (level, x, y); tests.
    double chunkError(std::int32_t level, std::int32_t x, std::int32_t y) const;
    std::int32_t levels() const { return static_cast<std::int32_t>(levels_.size()); }
    std::size_t memoryBytes() const;
    /// Bytes the loaded chunks' vertex buffers and the shared index buffers hold.
    std::int64_t gpuBytes() const;

  private:
    struct Level {
        std::int32_t nx = 0;
        std::int32_t ny = 0;
        std::int32_t step = 1;         ///< base cells per chunk cell
        std::vector<float> error;      ///< plain form, metres (patches included)
        std::vector<float> edge_error; ///< per edge (bottom, right, top, left): its strip stitched
        std::vector<float> zlo;
        std::vector<float> zhi;
        std::vector<std::uint8_t> state;   ///< kLeaf, kSplit, or 0 (under a leaf, or unseen)
        std::vector<std::uint8_t> visible; ///< leaf in the frustum this frame
        std::vector<std::uint64_t> loaded; ///< frame it was last drawn + 1; 0: not loaded
        std::vector<std::uint8_t> reload;  ///< surface changed while loaded
    };
    static constexpr std::uint8_t kLeaf = 1;
    static constexpr std::uint8_t kSplit = 2;

    std::size_t at(const Level& l, std::int32_t x, std::int32_t y) const {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(l.nx) +
               static_cast<std::size_t>(x);
    }
    double heightAt(std::int32_t x, std::int32_t y) const; ///< base vertex, clamped to the map
    void computeChunk(std::int32_t level, std::int32_t x, std::int32_t y);
    roam::Box boxOf(std::int32_t level, std::int32_t x, std::int32_t y) const;
    /// The level of the leaf covering the point (x2 / 2, y2 / 2) in base-vertex units (halves
    /// address the strips between vertices); -1 if outside the tree.
    std::int32_t leafLevelAt(std::int64_t x2, std::int64_t y2) const;
    /// For each edge (bottom, right, top, left): whether the neighbour is coarser.
    std::array<bool, 4> stitching(std::int32_t level, std::int32_t x, std::int32_t y) const;
    template <class Emit>
    void emitChunk(std::int32_t level, std::int32_t x, std::int32_t y, Emit&& emit) const;
    void split(std::int32_t level, std::int32_t x, std::int32_t y);

    const Terrain* terrain_;
    ChunkedLodOptions options_;
    std::int32_t cells_x_ = 0; ///< real map
    std::int32_t cells_y_ = 0;
    double spacing_ = 0.0;
    double metres_per_unit_ = 0.0;
    std::vector<float> patch_deviation_; ///< per base cell, metres (0 without a patch)
    std::vector<Level> levels_;          ///< 0 = base step; the last holds the root
    std::uint64_t frame_ = 0;
    std::int64_t triangles_ = 0;
    std::int64_t index_bytes_loaded_ = 0;
    struct Candidate {
        double priority;
        std::int32_t level;
        std::int32_t x;
        std::int32_t y;
        bool operator<(const Candidate& o) const { return priority < o.priority; }
    };
    std::vector<Candidate> heap_;
    std::vector<std::array<std::int32_t, 3>> leaves_; ///< level, x, y
};

} // namespace terrain::lodlab
