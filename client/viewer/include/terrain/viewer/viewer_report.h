#pragma once

// What a viewer run leaves behind for tests and scripts (--report): JSON with the world it ended
// on, whether the replica agreed with the server, and what drawing cost.

#include <terrain/result.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace terrain::viewer {

struct ViewerReport {
    std::string server; ///< host:port
    bool in_process = false;
    std::string renderer; ///< GL renderer / version
    int width = 0;        ///< framebuffer at the end
    int height = 0;
    double tau_pixels = 0.0;

    std::int64_t frames = 0;
    std::uint64_t seq = 0;
    std::uint64_t world_hash = 0;
    std::uint64_t verified_seq = 0;
    std::uint64_t hash_mismatches = 0;
    std::uint64_t repairs = 0;
    bool synced = false;
    bool diverged = false;
    /// The in-process server's seq and hash after the run (absent when joined elsewhere).
    std::optional<std::uint64_t> server_seq;
    std::optional<std::uint64_t> server_world_hash;

    std::int64_t triangles = 0; ///< last frame
    std::int64_t visible_triangles = 0;
    double median_frame_ms = 0.0;
    double median_tessellation_ms = 0.0;
    double median_draw_ms = 0.0; ///< sync + draw, the CPU's part
    double median_gpu_ms = 0.0;  ///< GL_TIME_ELAPSED of the uploads and draws (0: no timer)
    std::uint64_t bytes_uploaded = 0;
    std::string upload_path;             ///< persistent | map-range
    std::int64_t gl_errors = -1;         ///< with --gl-debug: KHR_debug errors (-1: not asked)
    std::int64_t gl_messages = -1;       ///< with --gl-debug: every message
    std::int64_t buffer_mismatches = -1; ///< with --validate-buffers
    double rtt_ms = 0.0;

    std::int64_t craters_requested = 0;
    std::int64_t craters_accepted = 0;
    std::int64_t craters_refused = 0;
    std::int64_t craters_missed = 0; ///< clicks whose ray hit no terrain
    std::string screenshot;
};

/// Errors: kIo naming the path.
Status writeViewerReport(const std::filesystem::path& path, const ViewerReport& report);

/// 16 lowercase hex digits, as terrain-server prints hashes.
std::string hashHex(std::uint64_t hash);

} // namespace terrain::viewer
