#pragma once

// terrain-viewer's command line: what to join (or serve in-process), the window, the
// tessellation, and the scripted-run options that tests use (--frames, --fly, --auto-crater,
// --screenshot, --report).

#include <terrain/client/op_pacing.h>
#include <terrain/result.h>

#include <cstdint>
#include <string>

namespace CLI {
class App;
}

namespace terrain::viewer {

struct ViewerOptions {
    // where the world comes from
    std::string connect; ///< "host:port"; empty: an in-process server
    std::string token;   ///< with --connect (or TERRAIN_TOKEN)
    std::int32_t size = 1025;
    std::uint64_t seed = 1;
    double join_timeout_seconds = 20.0;
    // window and view
    int width = 1280;
    int height = 720;
    double tau_pixels = 2.0; ///< llvmpipe draws about 10 M triangles/s
    /// Geomorphing (TerrainRenderer::setGeomorph): refine to this share of tau, draw vertices
    /// sliding so that no split or merge pops; 0: off (BENCHMARKS: it costs CPU per frame).
    double geomorph = 0.0;
    /// The tessellation on a worker thread (client::TessellationWorker): the frame never waits
    /// for it. false (--sync-tessellation), or geomorphing on: on the frame thread.
    bool async_tessellation = true;
    std::int64_t max_triangles = 300'000;
    /// Frame time (tessellation + drawing) to hold by lowering the triangle cap; 0: off. 50 ms
    /// is 20 frames a second from llvmpipe at 720p (about 90,000 lit triangles).
    double frame_ms = 50.0;
    /// Ops applied per frame at least; a burst waits for the next frames (0: each op as it
    /// arrives; client/op_pacing.h).
    int ops_per_frame = client::kDefaultOpsPerFrame;
    bool wireframe = false;
    /// A debug GL context: every KHR_debug message to stderr, errors in the report.
    bool gl_debug = false;
    /// How the renderer streams its uploads: auto, persistent (GL 4.4) or map-range (GL 3.3).
    std::string upload_path = "auto";
    /// Read the GPU buffers back after every sync and compare them with the mesh (slow).
    bool validate_buffers = false;
    double crater_radius = 8.0; ///< metres
    double crater_depth = 3.0;  ///< metres
    // scripted runs
    int frames = 0; ///< 0: until the window closes
    std::string screenshot;
    int auto_crater = 0; ///< a crater at the centre-of-screen hit every this many frames
    bool fly = false;
    std::string report;

    // derived by finishViewerOptions
    std::string host;
    std::uint16_t port = 0;
    bool inProcess() const { return connect.empty(); }
};

/// Registers every option on `app`, writing into `options`.
void addViewerOptions(CLI::App& app, ViewerOptions& options);

/// The rules CLI11 does not check, after parsing: ranges, --connect's form (host and port are
/// filled in), a token when joining. The error names the rule ("--tau must be > 0").
Status finishViewerOptions(ViewerOptions& options);

} // namespace terrain::viewer
