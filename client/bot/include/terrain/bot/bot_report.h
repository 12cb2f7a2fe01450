#pragma once

// A bot's report (JSON on disk) and the table that compares several: do all clients and the
// server hold the same world at the same seq, and what did the frames cost.

#include <terrain/result.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace terrain::bot {

/// Median, 95th percentile and maximum of a per-frame series (nearest rank).
struct Spread {
    double median = 0.0;
    double p95 = 0.0;
    double max = 0.0;
    static Spread of(std::vector<double> values);
};

struct BotReport {
    std::string name;
    int frames = 0;
    double seconds = 0.0; ///< wall time from joined to settled
    double join_seconds = 0.0;
    std::uint64_t final_seq = 0;
    std::uint64_t world_hash = 0;
    bool synced = false; ///< live, replica verified at the end
    std::uint64_t ops_applied = 0;
    std::uint64_t hash_mismatches = 0;
    std::uint64_t repairs = 0;
    std::uint64_t snapshots = 0;
    std::uint64_t genesis_deltas = 0; ///< of the snapshots, those that came as genesis deltas
    std::uint64_t snapshot_bytes = 0; ///< compressed bytes of both kinds
    int craters_requested = 0;
    int craters_accepted = 0;
    int craters_refused = 0;
    int craters_missed = 0; ///< the click's ray hit no ground
    /// The frame thread's tessellation: update() when synchronous; posting the camera and
    /// taking the worker's tiles when on a worker (async).
    Spread tessellate_ms;
    bool async_tessellation = false;
    Spread lag_frames; ///< async: frames the drawn mesh was behind the frame's camera
    /// async, per op (client::CraterLatency): frames from the frame that applied it to the first
    /// that drew it and to the first that drew it converged, and the largest error bound drawn
    /// meanwhile (pixels)
    Spread crater_frames_to_drawn;
    Spread crater_frames_to_converged;
    Spread crater_error_bound_until_converged_px;
    Spread render_ms;  ///< sync + draw + present (0 without rendering)
    Spread sync_ms;    ///< of it, the renderer's sync: vertices, normals, staging, GPU copies
    Spread draw_ms;    ///< the draw calls' submission
    Spread present_ms; ///< present(): the wait for the frame two back (2 frames in flight)
    /// GPU time of each frame's uploads and draws (GL_TIME_ELAPSED), frames whose result came
    /// back; empty (zeros, gpu_frames 0) where the context has no timer queries.
    Spread gpu_ms;
    int gpu_frames = 0;
    Spread frame_ms; ///< whole frame: network, tessellation, rendering
    Spread triangles;
    Spread visible_triangles;
    Spread triangle_cap;       ///< the cap each frame ran under (the frame budget moves it)
    Spread error_bound_pixels; ///< tau, or what the cap forced (FrameStats::error_bound_pixels)
    std::uint64_t upload_bytes = 0; ///< vertex + index bytes sent to the GL
    std::uint64_t vertex_bytes = 0;
    std::uint64_t index_bytes = 0;
    Spread upload_bytes_per_frame;
    std::string upload_path;             ///< persistent | map-range
    std::uint64_t gpu_copies = 0;        ///< glCopyBufferSubData calls, all told
    Spread copies_per_frame;             ///< GPU copies a frame's uploads took
    std::uint64_t ring_waits = 0;        ///< uploads that waited for the GPU (ring full)
    std::int64_t after_holes = -1;       ///< sky pixels below the horizon in after.png (-1: none)
    std::int64_t gl_errors = -1;         ///< KHR_debug errors with --gl-debug (-1: not asked)
    std::int64_t gl_messages = -1;       ///< every KHR_debug message with --gl-debug
    std::int64_t buffer_mismatches = -1; ///< --validate-buffers: vertices + indices that differed
    std::uint64_t bytes_in = 0;          ///< from the server, all frames
    std::uint64_t op_bytes_in = 0;       ///< of which op broadcasts
    double rtt_ms = 0.0;
    std::string renderer; ///< GL renderer string, empty without rendering
    std::vector<std::string> pngs;
    std::string error; ///< empty when the run went as scripted
};

std::string toJson(const BotReport& report);
/// Errors: kIo (cannot read), kBadFormat (not a report: the field that is missing or wrong).
Result<BotReport> readReport(const std::filesystem::path& path);
Status writeReport(const std::filesystem::path& path, const BotReport& report);

/// Prints one row per report and the verdict; true when every report is synced, has no error,
/// and holds the same seq and world hash.
bool printTable(const std::vector<BotReport>& reports, std::FILE* out);

} // namespace terrain::bot
