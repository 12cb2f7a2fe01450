#include <terrain/bot/bot.h>
#include <terrain/client/connection.h>
#include <terrain/client/crater_latency.h>
#include <terrain/client/replica.h>
#include <terrain/client/terrain_view.h>
#include <terrain/client/tessellation_worker.h>
#include <terrain/render/gpu_timer.h>
#include <terrain/render/sky_holes.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>
#include <array>
#include <asio.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

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

/// Per frame: where the time went and what the mesh was.
struct FrameSamples {
    std::vector<double> tessellate_ms;
    std::vector<double> render_ms;
    std::vector<double> sync_ms;
    std::vector<double> draw_ms;
    std::vector<double> present_ms;
    std::vector<double> gpu_ms;
    std::vector<double> frame_ms;
    std::vector<double> triangles;
    std::vector<double> visible;
    std::vector<double> uploads;
    std::vector<double> copies;
    std::vector<double> caps;
    std::vector<double> error_bounds;
    std::vector<double> lags;
};

/// One bot's run, phase by phase: join, open the renderer, fly the script's frames (a crater
/// at the script's clicks), settle, report.
class BotRun {
  public:
    explicit BotRun(const BotConfig& config) : config_(config) { report_.name = config.name; }
    BotRun(const BotRun&) = delete;
    BotRun& operator=(const BotRun&) = delete;
    /// Every way out closes the connection while the replica and io_context it uses still live.
    ~BotRun() {
        if (connection_)
            connection_->stop();
    }

    Result<BotReport> run() {
        if (Status s = join(); !s)
            return s.error();
        makeView();
        if (config_.render)
            if (Status s = openRenderer(); !s)
                return s.error();
        const Clock::time_point run_start = Clock::now();
        fly();
        // the after frame from the first frame's camera (placed on the ground as it is before
        // settling), so before.png and after.png compare
        const roam::Camera first = script_->camera(0, replica_.terrain());
        const bool settled = settle();
        frame(first, true);
        connection_->applyAllArrived(); // the report speaks for every op received
        if (gpu_.terrain && !config_.png_dir.empty())
            writePng("after.png");
        report_.seconds = secondsSince(run_start);
        finishReport(settled);
        return report_;
    }

  private:
    /// Loads the genesis (if given), connects and waits until the replica is synced.
    Status join() {
        if (config_.genesis)
            if (Status s = replica_.loadGenesis(*config_.genesis); !s)
                return s;
        client::ConnectionConfig cc;
        cc.host = config_.host;
        cc.port = config_.port;
        cc.token = config_.token;
        cc.client_name = "terrain-bot/" + config_.name;
        cc.pacing.ops_per_frame = config_.ops_per_frame;
        connection_ = std::make_shared<client::Connection>(io_, cc, replica_);
        connection_->on_deform_reply = [this](const client::DeformAnswer& a) {
            --answers_pending_;
            if (a.accepted)
                ++report_.craters_accepted;
            else
                ++report_.craters_refused;
        };
        last_op_ = Clock::now();
        connection_->on_applied = [this](std::uint64_t) { last_op_ = Clock::now(); };
        connection_->start();
        const Clock::time_point join_start = Clock::now();
        // a final refusal (a bad token) closes the connection for good: no point waiting
        pollUntil(io_, config_.join_timeout_seconds, [&] {
            connection_->applyAllArrived(); // no frames yet
            return connection_->synced() ||
                   connection_->state() == client::Connection::State::kClosed;
        });
        if (!connection_->synced()) {
            const std::string why = connection_->lastDisconnect();
            return makeError(
                ErrorCode::kIo,
                "could not join " + config_.host + ":" + std::to_string(config_.port) + " within " +
                    seconds(config_.join_timeout_seconds) + " s" + (why.empty() ? "" : ": " + why));
        }
        report_.join_seconds = secondsSince(join_start);
        return Ok{};
    }

    /// The script over the world joined, and the view: the tessellator starts from that state.
    void makeView() {
        script_.emplace(config_.script, replica_.terrain().spec());
        client::TerrainViewOptions vo;
        vo.tessellation.tau_pixels = config_.tau_pixels;
        vo.tessellation.max_triangles = config_.max_triangles;
        if (config_.upload_budget_bytes >= 0)
            vo.tessellation.upload_budget_bytes = config_.upload_budget_bytes;
        vo.budget.target_ms = config_.frame_ms >= 0.0 ? config_.frame_ms
                              : config_.render        ? kDefaultRenderFrameMs
                                                      : 0.0;
        vo.budget.max_triangles = config_.max_triangles;
        if (!config_.async_tessellation) {
            view_ = std::make_unique<client::TerrainView>(replica_, vo);
            return;
        }
        client::TessellationWorkerOptions wo;
        wo.view = vo;
        worker_ = std::make_unique<client::TessellationWorker>(replica_, wo);
        // the first frame shows the world joined (a game's loading screen ends here)
        worker_->finish(script_->camera(0, replica_.terrain()), mesh_);
    }

    Status openRenderer() {
        render::ContextOptions co;
        co.debug = config_.gl_debug;
        auto context = render::createOffscreenContext(
            config_.backend, config_.script.viewport_width, config_.script.viewport_height, co);
        if (!context)
            return context.error();
        gpu_.context = std::move(*context);
        render::RendererOptions ro;
        ro.upload = config_.upload_path;
        ro.validate = config_.validate_buffers;
        auto renderer = render::TerrainRenderer::create(*gpu_.context, ro);
        if (!renderer)
            return renderer.error();
        gpu_.terrain = std::move(*renderer);
        gpu_.timer = std::make_unique<render::GpuTimer>(gpu_.context->gl());
        report_.renderer = gpu_.context->describe();
        report_.upload_path = render::toString(gpu_.terrain->uploadPath());
        if (!config_.png_dir.empty())
            std::filesystem::create_directories(config_.png_dir);
        return Ok{};
    }

    /// A PNG that cannot be written is reported; the run goes on.
    void writePng(const std::string& file) {
        const std::filesystem::path path = config_.png_dir / file;
        const io::RgbImage image = gpu_.context->readPixels();
        if (file == "after.png")
            report_.after_holes = render::countSkyHoles(image, render::RenderOptions{}.sky).count;
        Status s = io::writeRgbPng(path, image);
        if (s)
            report_.pngs.push_back(path.string());
        else if (report_.error.empty())
            report_.error = s.error().message;
    }

    /// What arrived this frame (the connection's share) to the replica and on to the view (a
    /// worker takes it with the next frame's camera).
    void absorb() {
        if (view_)
            view_->absorb();
    }

    /// A frame: take what arrived, tessellate, draw and present (when rendering), steer the
    /// triangle cap on the frame's time.
    void frame(const roam::Camera& camera, bool final = false) {
        const Clock::time_point t0 = Clock::now();
        io_.poll();
        io_.restart();
        connection_->applyArrived(); // this frame's share of what arrived
        absorb();
        const Clock::time_point t1 = Clock::now();
        if (worker_) {
            // the frame posts its camera and takes the newest tiles the worker finished; the
            // last frame waits for everything (the after picture)
            if (final)
                worker_->finish(camera, mesh_);
            else {
                worker_->post(camera, steer_ms_);
                worker_->take(mesh_);
            }
            samples_.tessellate_ms.push_back(msSince(t1));
            const client::WorkerStep& step = worker_->taken();
            const auto index = static_cast<std::int64_t>(samples_.frame_ms.size()) + 1;
            latency_.applied(index, replica_.seq());
            latency_.drawn(index, step.seq, step.settled_seq, step.stats.error_bound_pixels);
            samples_.caps.push_back(static_cast<double>(step.max_triangles));
            samples_.error_bounds.push_back(step.stats.error_bound_pixels);
            samples_.triangles.push_back(static_cast<double>(step.stats.triangles));
            samples_.visible.push_back(static_cast<double>(step.stats.visible_triangles));
            samples_.lags.push_back(static_cast<double>(worker_->lag()));
        } else {
            const roam::Tessellator& tess = view_->tessellator();
            samples_.caps.push_back(static_cast<double>(tess.options().max_triangles));
            const roam::FrameStats& fs = view_->update(camera);
            samples_.tessellate_ms.push_back(msSince(t1));
            samples_.error_bounds.push_back(fs.error_bound_pixels);
            samples_.triangles.push_back(static_cast<double>(fs.triangles));
            samples_.visible.push_back(static_cast<double>(fs.visible_triangles));
        }
        if (gpu_.terrain)
            draw(camera);
        samples_.frame_ms.push_back(msSince(t0));
        // the GPU works behind the CPU: where its time is known, the budget steers on the
        // larger of the two
        const double gpu_frame =
            gpu_.timer && gpu_.timer->latestMs() ? *gpu_.timer->latestMs() : 0.0;
        steer_ms_ = std::max(samples_.frame_ms.back(), gpu_frame);
        if (view_)
            view_->steer(steer_ms_);
    }

    void draw(const roam::Camera& camera) {
        const Clock::time_point t2 = Clock::now();
        gpu_.timer->begin();
        // the renderer takes the changes of what it draws: the worker's tiles, or the
        // tessellator's
        const render::UploadStats up =
            worker_ ? gpu_.terrain->sync(mesh_)
                    : gpu_.terrain->sync(view_->tessellator(), replica_.terrain());
        const Clock::time_point t3 = Clock::now();
        if (worker_)
            gpu_.terrain->draw(mesh_, camera, render::RenderOptions{});
        else
            gpu_.terrain->draw(view_->tessellator(), camera, render::RenderOptions{});
        gpu_.timer->end();
        const Clock::time_point t4 = Clock::now();
        gpu_.context->present();
        samples_.render_ms.push_back(msSince(t2));
        samples_.sync_ms.push_back(msBetween(t2, t3));
        samples_.draw_ms.push_back(msBetween(t3, t4));
        samples_.present_ms.push_back(msSince(t4));
        const std::size_t done = gpu_.timer->collect(gpu_done_);
        samples_.gpu_ms.insert(
            samples_.gpu_ms.end(), gpu_done_.begin(),
            gpu_done_.begin() + static_cast<std::ptrdiff_t>(done));
        samples_.uploads.push_back(static_cast<double>(up.bytes()));
        samples_.copies.push_back(
            static_cast<double>(up.vertex_uploads + up.index_uploads + up.grown_buffers));
    }

    /// The script's frames, with its PNGs, pings and crater clicks.
    void fly() {
        const auto period = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(config_.fps > 0.0 ? 1.0 / config_.fps : 0.0));
        Clock::time_point deadline = Clock::now();
        for (int f = 0; f < config_.script.frames; ++f) {
            const roam::Camera camera = script_->camera(f, replica_.terrain());
            frame(camera);
            if (f == 0 && gpu_.terrain && !config_.png_dir.empty())
                writePng("before.png");
            if (gpu_.terrain && config_.png_every > 0 && f % config_.png_every == 0 &&
                !config_.png_dir.empty()) {
                char name[32];
                std::snprintf(name, sizeof name, "frame_%05d.png", f);
                writePng(name);
            }
            if (f % 30 == 0)
                connection_->ping();
            if (script_->craterDue(f))
                click(f, camera);
            if (config_.fps > 0.0) {
                // a late frame starts the next period from now rather than catching up
                deadline = std::max(deadline + period, Clock::now());
                std::this_thread::sleep_until(deadline);
            }
        }
    }

    /// A click: the ray through the shot's pixel, against the replica's true surface.
    void click(int f, const roam::Camera& camera) {
        const CraterShot shot = script_->shot(f);
        const std::optional<OpRequest> request = client::craterAtPixel(
            replica_.terrain(), camera, shot.pixel_x, shot.pixel_y,
            {.radius = shot.radius, .depth = shot.depth, .rim = 0.3});
        if (!request) {
            ++report_.craters_missed;
            return;
        }
        connection_->requestDeform(*request);
        ++report_.craters_requested;
        ++answers_pending_;
    }

    /// Every request answered, every peer done (with a barrier) and the op stream quiet, within
    /// the settle timeout; whether it settled.
    bool settle() {
        const Clock::time_point settle_start = Clock::now();
        const auto timeLeft = [&] {
            return config_.settle_timeout_seconds - secondsSince(settle_start);
        };
        bool settled = pollUntil(io_, timeLeft(), [&] {
            connection_->applyAllArrived(); // settling draws no frames
            absorb();
            return answers_pending_ <= 0;
        });
        if (settled && !config_.barrier_dir.empty()) {
            // every op this bot made is broadcast by now (the server acknowledges after it
            // broadcasts): say so, and wait until every peer has said the same
            std::filesystem::create_directories(config_.barrier_dir);
            std::ofstream(config_.barrier_dir / (config_.name + ".done")) << replica_.seq() << "\n";
            settled = pollUntil(io_, timeLeft(), [&] {
                connection_->applyAllArrived();
                absorb();
                int done = 0;
                std::error_code ec;
                for (const auto& entry :
                     std::filesystem::directory_iterator(config_.barrier_dir, ec))
                    done += entry.path().extension() == ".done" ? 1 : 0;
                return done >= config_.peers;
            });
        }
        if (settled)
            settled = pollUntil(io_, timeLeft(), [&] {
                connection_->applyAllArrived();
                absorb();
                return secondsSince(last_op_) >= config_.settle_seconds && connection_->synced();
            });
        return settled;
    }

    void finishReport(bool settled) {
        BotReport& r = report_;
        r.frames = config_.script.frames;
        r.final_seq = replica_.seq();
        r.world_hash = replica_.worldHash();
        r.synced = settled && connection_->synced();
        r.ops_applied = replica_.stats().ops_applied;
        r.hash_mismatches = replica_.stats().hash_mismatches;
        r.repairs = replica_.stats().repairs;
        r.snapshots = replica_.stats().snapshots;
        r.genesis_deltas = connection_->stats().genesis_deltas;
        r.snapshot_bytes = connection_->stats().snapshot_bytes;
        r.tessellate_ms = Spread::of(samples_.tessellate_ms);
        r.async_tessellation = worker_ != nullptr;
        r.lag_frames = Spread::of(samples_.lags);
        r.crater_frames_to_drawn = Spread::of(latency_.framesToDrawn());
        r.crater_frames_to_converged = Spread::of(latency_.framesToConverged());
        r.crater_error_bound_until_converged_px = Spread::of(latency_.boundUntilConverged());
        r.render_ms = Spread::of(samples_.render_ms);
        r.sync_ms = Spread::of(samples_.sync_ms);
        r.draw_ms = Spread::of(samples_.draw_ms);
        r.present_ms = Spread::of(samples_.present_ms);
        r.gpu_ms = Spread::of(samples_.gpu_ms);
        r.gpu_frames = static_cast<int>(samples_.gpu_ms.size());
        r.frame_ms = Spread::of(samples_.frame_ms);
        r.triangles = Spread::of(samples_.triangles);
        r.visible_triangles = Spread::of(samples_.visible);
        r.triangle_cap = Spread::of(samples_.caps);
        r.error_bound_pixels = Spread::of(samples_.error_bounds);
        r.upload_bytes_per_frame = Spread::of(samples_.uploads);
        r.copies_per_frame = Spread::of(samples_.copies);
        if (gpu_.terrain)
            reportRenderer();
        r.bytes_in = connection_->stats().bytes_in;
        r.op_bytes_in = connection_->stats().op_bytes_in;
        r.rtt_ms = connection_->roundTripSeconds() * 1000.0;
        if (!settled)
            r.error = "the world did not settle within " + seconds(config_.settle_timeout_seconds) +
                      " s (" + std::to_string(answers_pending_) + " crater requests unanswered" +
                      (config_.barrier_dir.empty() ? "" : ", or peers not done") + ")";
    }

    /// The renderer's totals, its buffers' validation and the GL's errors.
    void reportRenderer() {
        BotReport& r = report_;
        r.vertex_bytes = gpu_.terrain->totals().vertex_bytes;
        r.index_bytes = gpu_.terrain->totals().index_bytes;
        r.upload_bytes = gpu_.terrain->totals().bytes();
        r.gpu_copies = gpu_.terrain->ringStats().copies;
        r.ring_waits = gpu_.terrain->ringStats().waits;
        if (config_.validate_buffers) {
            const render::ValidationReport& v = gpu_.terrain->validation();
            r.buffer_mismatches = static_cast<std::int64_t>(
                v.vertex_mismatches + v.index_mismatches + v.short_buffers);
            if (!v.clean() && r.error.empty())
                r.error = "buffers differ from the mesh: " + v.first_problem;
        }
        if (const render::GlDebugLog* log = gpu_.context->debugLog()) {
            r.gl_errors = static_cast<std::int64_t>(log->errors());
            r.gl_messages = static_cast<std::int64_t>(log->messages());
            if (log->errors() > 0 && r.error.empty())
                r.error = "the GL reported " + std::to_string(log->errors()) + " errors";
        }
    }

    const BotConfig& config_;
    BotReport report_;
    asio::io_context io_;
    client::Replica replica_;
    std::shared_ptr<client::Connection> connection_;
    int answers_pending_ = 0;
    Clock::time_point last_op_{};
    std::optional<BotScript> script_;
    std::unique_ptr<client::TerrainView> view_; ///< the synchronous path
    std::unique_ptr<client::TessellationWorker> worker_;
    roam::DrawnMesh mesh_;          ///< the worker's tiles, as the frame draws them
    client::CraterLatency latency_; ///< per op: frames to drawn, to converged (with a worker)
    double steer_ms_ = 0.0;         ///< the last frame's time, for the triangle budget
    Renderer gpu_;
    std::array<double, render::GpuTimer::kQueries> gpu_done_{};
    FrameSamples samples_;
};
} // namespace

Result<BotReport> runBot(const BotConfig& config) {
    return BotRun(config).run();
}

} // namespace terrain::bot
