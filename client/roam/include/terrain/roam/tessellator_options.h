#pragma once

// How a Tessellator refines (tessellator.h): the screen error it aims at, and the caps and
// budgets that bound its triangles, memory and per-frame work.

#include <cstdint>

namespace terrain::roam {

enum class TessellationMode : std::uint8_t { kSplitMerge, kSplitOnly };

struct TessellatorOptions {
    double tau_pixels = 1.0;
    TessellationMode mode = TessellationMode::kSplitMerge;
    /// Triangle cap (the pool): splits beyond it are refused.
    std::int64_t max_triangles = 4'000'000;
    /// Detail blocks resident at once (about 7.7 KB each with their diamond state); a split
    /// that needs one more while all are in use is refused like the triangle cap.
    std::int32_t max_detail_blocks = 32768;
    /// A block no diamond refers to is released once unused for about this many frames (a
    /// sweep looks at a few hundred slots per frame); 0: only when the pool needs its slot.
    std::int32_t detail_block_idle_frames = 600;
    /// Work per frame in kSplitMerge, in splits: a split or merge counts 1, a detail block or
    /// grain made on the way kMaterialiseWork (its kernel pass); the rest waits for the next
    /// frame, and the frame reports budget_exhausted. A crater in a battle needs about 2,000; a
    /// U-turn low over the battle about 150,000 splits and 13,000 blocks (spread over frames).
    std::int64_t work_budget = 40'000;
    /// A block or grain materialised during split/merge costs this many splits of work_budget.
    static constexpr std::int64_t kMaterialiseWork = 16;
    /// Bytes the frame's splits and merges may make a renderer upload: each index page
    /// (TileMesh::kSlotsPerPage slots) when first written since the renderer took the tile,
    /// each grain's vertices when they join a tile's array (kUploadBytesPerVertex each). Past
    /// it the rest waits for the next frame, like work past work_budget, and the frame's error
    /// bound says so (budget_exhausted). Ops' own height changes are not held back (they are
    /// paced where they arrive). 0: no limit. 2 MiB: 120 MB/s at 60 frames a second, a small
    /// share of any GPU's bus; a U-turn low over a battle wants 5-15 MiB in one frame.
    std::int64_t upload_budget_bytes = 2 << 20;
    static constexpr std::int64_t kUploadBytesPerVertex = 16;
    /// Detail blocks whose bounds an op made stale, recomputed per frame (their heights follow
    /// the op at once, so the mesh drawn is the new surface); the rest wait for the next frames,
    /// and meanwhile the error bound is not exact there (FrameStats::stale_blocks). A crater in
    /// a battle makes about 300 stale; 0: no limit.
    std::int64_t stale_block_budget = 512;
    /// An eye jump longer than this rebuilds top-down; 0 means 8 tiles.
    double teleport_metres = 0.0;
    /// Merge candidates' culling is re-checked as the view turns, about all of them per this
    /// much turning (sampled in a low-discrepancy order, so not exactly each one), and every one
    /// on a turn of this much in one frame. Out-of-view regions merge within about this turn.
    double cull_sweep_degrees = 4.0;
    /// Hysteresis: a split diamond merges only once its priority falls to this share of the
    /// threshold (it split above the threshold). 1: merge as soon as it may (the mesh a
    /// top-down build at the threshold makes). Below 1, a diamond that hovers at the threshold
    /// (the eye drifting, a crater's new bounds) is not merged and split again: fewer moves and
    /// re-pricings, a few more triangles; the error bound is the threshold either way.
    double merge_band = 1.0;
    /// Counts where the moves land (FrameStats::moves_in_footprint, moves_undone; MoveCensus):
    /// benchmarks. About 1 MB per million cells, and a lookup and a hash insert per move.
    bool count_moves_by_place = false;
};

} // namespace terrain::roam
