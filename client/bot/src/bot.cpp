#include <terrain/bot/bot.h>
#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/client/terrain_view.h>
#include <terrain/render/gpu_timer.h>
#include <terrain/render/sky_holes.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>
#include <array>
#include <asio.hpp>
#include <chrono>
#include <fstream>
#include <memory>
#include <thread>

namespace terrain::bot {

namespace {
using Clock = std::chrono::steady_clock;

double msBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
}

double msSince(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double secondsSince(Clock::time_point t0) {
    return msSince(t0) / 1000.0;
}

std::string seconds(double s) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", s);
    return text;
}

/// Polls the connection until `done()` or the timeout; false on timeout.
template <typename Done> bool pollUntil(asio::io_context& io, double timeout_seconds, Done done) {
    const Clock::time_point t0 = Clock::now();
    while (!done()) {
        if (secondsSince(t0) > timeout_seconds)
            return false;
        io.run_for(std::chrono::milliseconds(5));
        io.restart();
    }
    return true;
}

/// The offscreen half of a bot: context, renderer and GPU timer.
struct Renderer {
    std::unique_ptr<render::GlContext> context;
    std::unique_ptr<render::TerrainRenderer> terrain;
    std::unique_ptr<render::GpuTimer> timer;
};
} // namespace

Result<BotReport> runBot(const BotConfig& config) {
    BotReport report;
    report.name = config.name;
    asio::io_context io;
    client::Replica replica;
    if (config.genesis)
        if (Status s = replica.loadGenesis(*config.genesis); !s)
            return s.error();
    client::ConnectionConfig cc;
    cc.host = config.host;
    cc.port = config.port;
    cc.token = config.token;
    cc.client_name = "terrain-bot/" + config.name;
    cc.pacing.ops_per_frame = config.ops_per_frame;
    auto connection = std::make_shared<client::Connection>(io, cc, replica);
    int answers_pending = 0;
    connection->on_deform_reply = [&](const client::DeformAnswer& a) {
        --answers_pending;
        if (a.accepted)
            ++report.craters_accepted;
        else
            ++report.craters_refused;
    };
    Clock::time_point last_op = Clock::now();
    connection->on_applied = [&](std::uint64_t) { last_op = Clock::now(); };
    connection->start();
    // every way out closes the connection while the replica and io_context it uses still live
    struct StopOnExit {
        client::Connection& c;
        ~StopOnExit() { c.stop(); }
    } stop_on_exit{*connection};

    const Clock::time_point join_start = Clock::now();
    // a final refusal (a bad token) closes the connection for good: no point waiting
    pollUntil(io, config.join_timeout_seconds, [&] {
        connection->applyAllArrived(); // no frames yet
        return connection->synced() || connection->state() == client::Connection::State::kClosed;
    });
    if (!connection->synced()) {
        const std::string why = connection->lastDisconnect();
        return makeError(
            ErrorCode::kIo, "could not join " + config.host + ":" + std::to_string(config.port) +
                                " within " + seconds(config.join_timeout_seconds) + " s" +
                                (why.empty() ? "" : ": " + why));
    }
    report.join_seconds = secondsSince(join_start);

    ScriptOptions script_options = config.script;
    BotScript script(script_options, replica.terrain().spec());
    client::TerrainViewOptions vo; // the tessellator starts from the state just joined
    vo.tessellation.tau_pixels = config.tau_pixels;
    vo.tessellation.max_triangles = config.max_triangles;
    if (config.upload_budget_bytes >= 0)
        vo.tessellation.upload_budget_bytes = config.upload_budget_bytes;
    vo.budget.target_ms = config.frame_ms >= 0.0 ? config.frame_ms
                          : config.render        ? kDefaultRenderFrameMs
                                                 : 0.0;
    vo.budget.max_triangles = config.max_triangles;
    client::TerrainView view(replica, vo);
    roam::Tessellator& tess = view.tessellator(); // the renderer takes its changes

    Renderer gpu;
    if (config.render) {
        render::ContextOptions co;
        co.debug = config.gl_debug;
        auto context = render::createOffscreenContext(
            config.backend, script_options.viewport_width, script_options.viewport_height, co);
        if (!context)
            return context.error();
        gpu.context = std::move(*context);
        render::RendererOptions ro;
        ro.upload = config.upload_path;
        ro.validate = config.validate_buffers;
        auto renderer = render::TerrainRenderer::create(*gpu.context, ro);
        if (!renderer)
            return renderer.error();
        gpu.terrain = std::move(*renderer);
        gpu.timer = std::make_unique<render::GpuTimer>(gpu.context->gl());
        report.renderer = gpu.context->describe();
        report.upload_path = render::toString(gpu.terrain->uploadPath());
        if (!config.png_dir.empty())
            std::filesystem::create_directories(config.png_dir);
    }
    // a PNG that cannot be written is reported; the run goes on
    const auto writePng = [&](const std::string& file) {
        const std::filesystem::path path = config.png_dir / file;
        const io::RgbImage image = gpu.context->readPixels();
        if (file == "after.png")
            report.after_holes = render::countSkyHoles(image, render::RenderOptions{}.sky).count;
        Status s = io::writeRgbPng(path, image);
        if (s)
            report.pngs.push_back(path.string());
        else if (report.error.empty())
            report.error = s.error().message;
    };

    std::vector<double> tessellate_ms;
    std::vector<double> render_ms;
    std::vector<double> sync_ms;
    std::vector<double> draw_ms;
    std::vector<double> present_ms;
    std::vector<double> gpu_ms;
    std::array<double, render::GpuTimer::kQueries> gpu_done{};
    std::vector<double> frame_ms;
    std::vector<double> triangles;
    std::vector<double> visible;
    std::vector<double> uploads;
    std::vector<double> copies;
    std::vector<double> caps;
    std::vector<double> error_bounds;
    // what the replica changed goes to the tessellator (the renderer reads it from there)
    const auto absorb = [&] { view.absorb(); };
    const auto frame = [&](const roam::Camera& camera) {
        const Clock::time_point t0 = Clock::now();
        io.poll();
        io.restart();
        connection->applyArrived(); // this frame's share of what arrived
        absorb();
        const Clock::time_point t1 = Clock::now();
        caps.push_back(static_cast<double>(tess.options().max_triangles));
        const roam::FrameStats& fs = view.update(camera);
        tessellate_ms.push_back(msSince(t1));
        error_bounds.push_back(fs.error_bound_pixels);
        triangles.push_back(static_cast<double>(fs.triangles));
        visible.push_back(static_cast<double>(fs.visible_triangles));
        if (gpu.terrain) {
            const Clock::time_point t2 = Clock::now();
            gpu.timer->begin();
            const render::UploadStats up = gpu.terrain->sync(tess, replica.terrain());
            const Clock::time_point t3 = Clock::now();
            gpu.terrain->draw(tess, camera, render::RenderOptions{});
            gpu.timer->end();
            const Clock::time_point t4 = Clock::now();
            gpu.context->present();
            render_ms.push_back(msSince(t2));
            sync_ms.push_back(msBetween(t2, t3));
            draw_ms.push_back(msBetween(t3, t4));
            present_ms.push_back(msSince(t4));
            const std::size_t done = gpu.timer->collect(gpu_done);
            gpu_ms.insert(
                gpu_ms.end(), gpu_done.begin(),
                gpu_done.begin() + static_cast<std::ptrdiff_t>(done));
            uploads.push_back(static_cast<double>(up.bytes()));
            copies.push_back(
                static_cast<double>(up.vertex_uploads + up.index_uploads + up.grown_buffers));
        }
        frame_ms.push_back(msSince(t0));
        // the GPU works behind the CPU: where its time is known, the budget steers on the
        // larger of the two
        const double gpu_frame = gpu.timer && gpu.timer->latestMs() ? *gpu.timer->latestMs() : 0.0;
        view.steer(std::max(frame_ms.back(), gpu_frame));
    };

    const Clock::time_point run_start = Clock::now();
    const int frames = script_options.frames;
    for (int f = 0; f < frames; ++f) {
        const roam::Camera camera = script.camera(f, replica.terrain());
        frame(camera);
        if (f == 0 && gpu.terrain && !config.png_dir.empty())
            writePng("before.png");
        if (gpu.terrain && config.png_every > 0 && f % config.png_every == 0 &&
            !config.png_dir.empty()) {
            char name[32];
            std::snprintf(name, sizeof name, "frame_%05d.png", f);
            writePng(name);
        }
        if (f % 30 == 0)
            connection->ping();
        if (script.craterDue(f)) {
            // a click: the ray through the shot's pixel, against the replica's true surface
            const CraterShot shot = script.shot(f);
            const std::optional<OpRequest> request = client::craterAtPixel(
                replica.terrain(), camera, shot.pixel_x, shot.pixel_y,
                {.radius = shot.radius, .depth = shot.depth, .rim = 0.3});
            if (!request) {
                ++report.craters_missed;
                continue;
            }
            connection->requestDeform(*request);
            ++report.craters_requested;
            ++answers_pending;
        }
    }

    // settle: every request answered and the op stream quiet, then the after frame from the
    // first frame's camera (so before.png and after.png compare)
    const roam::Camera first = script.camera(0, replica.terrain());
    const Clock::time_point settle_start = Clock::now();
    const auto timeLeft = [&] {
        return config.settle_timeout_seconds - secondsSince(settle_start);
    };
    bool settled = pollUntil(io, timeLeft(), [&] {
        connection->applyAllArrived(); // settling draws no frames
        absorb();
        return answers_pending <= 0;
    });
    if (settled && !config.barrier_dir.empty()) {
        // every op this bot made is broadcast by now (the server acknowledges after it
        // broadcasts): say so, and wait until every peer has said the same
        std::filesystem::create_directories(config.barrier_dir);
        std::ofstream(config.barrier_dir / (config.name + ".done")) << replica.seq() << "\n";
        settled = pollUntil(io, timeLeft(), [&] {
            connection->applyAllArrived();
            absorb();
            int done = 0;
            std::error_code ec;
            for (const auto& entry : std::filesystem::directory_iterator(config.barrier_dir, ec))
                done += entry.path().extension() == ".done" ? 1 : 0;
            return done >= config.peers;
        });
    }
    if (settled)
        settled = pollUntil(io, timeLeft(), [&] {
            connection->applyAllArrived();
            absorb();
            return secondsSince(last_op) >= config.settle_seconds && connection->synced();
        });
    frame(first);
    connection->applyAllArrived(); // the report speaks for every op received
    if (gpu.terrain && !config.png_dir.empty())
        writePng("after.png");
    report.seconds = secondsSince(run_start);
    report.frames = frames;
    report.final_seq = replica.seq();
    report.world_hash = replica.worldHash();
    report.synced = settled && connection->synced();
    report.ops_applied = replica.stats().ops_applied;
    report.hash_mismatches = replica.stats().hash_mismatches;
    report.repairs = replica.stats().repairs;
    report.snapshots = replica.stats().snapshots;
    report.genesis_deltas = connection->stats().genesis_deltas;
    report.snapshot_bytes = connection->stats().snapshot_bytes;
    report.tessellate_ms = Spread::of(tessellate_ms);
    report.render_ms = Spread::of(render_ms);
    report.sync_ms = Spread::of(sync_ms);
    report.draw_ms = Spread::of(draw_ms);
    report.present_ms = Spread::of(present_ms);
    report.gpu_ms = Spread::of(gpu_ms);
    report.gpu_frames = static_cast<int>(gpu_ms.size());
    report.frame_ms = Spread::of(frame_ms);
    report.triangles = Spread::of(triangles);
    report.visible_triangles = Spread::of(visible);
    report.triangle_cap = Spread::of(caps);
    report.error_bound_pixels = Spread::of(error_bounds);
    report.upload_bytes_per_frame = Spread::of(uploads);
    report.copies_per_frame = Spread::of(copies);
    if (gpu.terrain) {
        report.vertex_bytes = gpu.terrain->totals().vertex_bytes;
        report.index_bytes = gpu.terrain->totals().index_bytes;
        report.upload_bytes = gpu.terrain->totals().bytes();
        report.gpu_copies = gpu.terrain->ringStats().copies;
        report.ring_waits = gpu.terrain->ringStats().waits;
        if (config.validate_buffers) {
            const render::ValidationReport& v = gpu.terrain->validation();
            report.buffer_mismatches = static_cast<std::int64_t>(
                v.vertex_mismatches + v.index_mismatches + v.short_buffers);
            if (!v.clean() && report.error.empty())
                report.error = "buffers differ from the mesh: " + v.first_problem;
        }
        if (const render::GlDebugLog* log = gpu.context->debugLog()) {
            report.gl_errors = static_cast<std::int64_t>(log->errors());
            report.gl_messages = static_cast<std::int64_t>(log->messages());
            if (log->errors() > 0 && report.error.empty())
                report.error = "the GL reported " + std::to_string(log->errors()) + " errors";
        }
    }
    report.bytes_in = connection->stats().bytes_in;
    report.op_bytes_in = connection->stats().op_bytes_in;
    report.rtt_ms = connection->roundTripSeconds() * 1000.0;
    if (!settled)
        report.error = "the world did not settle within " + seconds(config.settle_timeout_seconds) +
                       " s (" + std::to_string(answers_pending) + " crater requests unanswered" +
                       (config.barrier_dir.empty() ? "" : ", or peers not done") + ")";
    return report;
}

} // namespace terrain::bot
