#pragma once

// A headless client for tests, load and the demo: joins a server, flies its script, blasts
// craters where its "clicks" hit the replica's surface, tessellates every frame, optionally
// renders offscreen (OSMesa) and writes PNG frames, then waits until the world is quiet and
// reports what it saw: hash agreement, frame times, triangles, bytes.

#include <terrain/bot/bot_report.h>
#include <terrain/bot/bot_script.h>
#include <terrain/client/op_pacing.h>
#include <terrain/render/offscreen.h>
#include <terrain/render/upload_ring.h>
#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace terrain::bot {

struct BotConfig {
    std::string name = "bot";
    std::string host = "127.0.0.1";
    std::uint16_t port = 7777;
    std::string token;
    ScriptOptions script;
    double tau_pixels = 2.0;
    std::int64_t max_triangles = 400000;
    /// Frame time to hold by steering the triangle cap below max_triangles (client/frame_budget.h);
    /// 0: off; negative: kDefaultRenderFrameMs when rendering, off otherwise.
    double frame_ms = -1.0;
    /// Ops applied per frame at least (a burst waits for the next frames; client/op_pacing.h);
    /// 0: each op as it arrives.
    int ops_per_frame = client::kDefaultOpsPerFrame;
    bool render = false; ///< offscreen: frame times include drawing
    /// Frames a second the flight keeps, sleeping out what a frame leaves, as a game's loop
    /// does (0: as fast as frames go; a headless bot's frames then take microseconds, and a
    /// worker's steps span hundreds of them).
    double fps = 0.0;
    /// The tessellation runs on a worker thread (client::TessellationWorker): the frame posts its
    /// camera and takes the newest finished tiles, never waiting. false: on the frame thread
    /// (TerrainView, the synchronous path).
    bool async_tessellation = true;
    render::OffscreenBackend backend = render::OffscreenBackend::kOsmesa;
    /// A debug context: every KHR_debug message logged (stderr), errors counted in the report.
    bool gl_debug = false;
    /// The renderer reads its buffers back after every sync and compares them with the
    /// tessellator (RendererOptions::validate); mismatches are counted in the report. Slow.
    bool validate_buffers = false;
    render::UploadPath upload_path = render::UploadPath::kAuto;
    /// Bytes of mesh changes a frame may cause a renderer to upload; the rest waits
    /// (roam::TessellatorOptions::upload_budget_bytes).
    std::int64_t upload_budget_bytes = -1; ///< negative: the tessellator's default
    std::filesystem::path png_dir;         ///< before.png, after.png (+ every png_every frames)
    int png_every = 0;
    double join_timeout_seconds = 60.0;
    /// After the script: the world counts as settled once no op arrived for this long and every
    /// crater request was answered.
    double settle_seconds = 1.5;
    double settle_timeout_seconds = 60.0;
    /// Bots started together can wait for each other before settling, so they end at the same
    /// seq: each writes `<name>.done` here once its own craters are answered, and settles only
    /// when `peers` such files exist (itself included). Empty: no barrier.
    std::filesystem::path barrier_dir;
    int peers = 1;
    /// The map this bot ships with (the server's genesis: the same seed and size, or the same
    /// DEM): it starts from it, resumes from seq 0 while the server holds every op, and joins
    /// by a genesis delta otherwise. Empty: joins by the whole snapshot.
    std::optional<Terrain> genesis;
};

/// llvmpipe at 1280 x 720 on 2 cores spends about 20 ms a frame filling pixels and 0.3 ms per
/// thousand lit triangles (BENCHMARKS.md, Rendering): 50 ms (20 frames a second) holds about
/// 90,000 triangles there.
inline constexpr double kDefaultRenderFrameMs = 50.0;

/// Errors: kIo when it cannot join (the message says why); kUnsupported when rendering was asked
/// for and no offscreen context could be made; the renderer's errors. A run that joined always
/// returns its report: what went wrong after that (no settling in time, a PNG not written) is in
/// its `error`.
Result<BotReport> runBot(const BotConfig& config);

} // namespace terrain::bot
