#pragma once

// What a Tessellator reports (tessellator.h): per frame, what update() did and the error bound
// the mesh is within; and where its memory goes.

#include <array>
#include <cstddef>
#include <cstdint>

namespace terrain::roam {

struct FrameStats {
    std::int64_t splits = 0;
    std::int64_t forced_splits = 0; ///< of which forced by a finer split
    std::int64_t merges = 0;
    std::int64_t evaluations = 0; ///< priorities computed
    /// Of the splits and merges, those in cells an op changed lately, and those that undid a
    /// recent move of the same diamond (counted only with TessellatorOptions::
    /// count_moves_by_place; MoveCensus says what "lately" is).
    std::int64_t moves_in_footprint = 0;
    std::int64_t moves_undone = 0;
    std::int64_t refused_by_cap = 0;  ///< splits refused by the triangle cap or the block pool
    std::int64_t refused_by_pool = 0; ///< of which for want of a detail block
    std::int64_t blocks_materialised = 0;
    std::int64_t blocks_evicted = 0;
    std::int64_t stale_blocks_bounded = 0; ///< blocks whose stale bounds this frame redid
    std::int64_t stale_blocks = 0;         ///< still waiting (their error bound is the old one)
    /// Splits and merges priced and left for later frames (a spent budget, a refusal).
    std::int64_t backlog = 0;
    std::int64_t triangles = 0;         ///< emitted, all tiles
    std::int64_t visible_triangles = 0; ///< in tiles that intersect the frustum
    std::int64_t index_bytes_written = 0;
    std::int64_t index_bytes_total = 0; ///< size of every tile's index list
    /// What split/merge this frame will make a renderer upload (upload_budget_bytes' measure:
    /// index pages first written, grain vertices added).
    std::int64_t upload_bytes = 0;
    bool upload_budget_bound = false; ///< splits or merges waited for the upload budget
    /// The screen error (pixels) every triangle of the mesh is within: tau, or the higher
    /// threshold the triangle cap forced, or more while splits the frame wanted wait (cap or
    /// work budget). Exact only when !budget_exhausted (waiting candidates were not all priced).
    double error_bound_pixels = 0.0;
    bool rebuilt = false;
    bool budget_exhausted = false;
};

/// Where a tessellator's memory goes (bytes, capacity of its arrays).
struct TessellatorMemory {
    std::size_t grid = 0;    ///< eager diamond state: the grid's and the detail cells' centres
    std::size_t records = 0; ///< detail cells' records and the cell table
    std::array<std::size_t, 3> grains{}; ///< resident blocks, by grain (block_grains.h)
    std::size_t heap = 0;                ///< the candidate heap, and its per-id positions
    std::size_t meshes = 0;              ///< the tiles' index lists and vertex segments
    std::size_t scratch = 0;             ///< the bounds pass
    std::size_t total() const {
        return grid + records + grains[0] + grains[1] + grains[2] + heap + meshes + scratch;
    }
};

} // namespace terrain::roam
