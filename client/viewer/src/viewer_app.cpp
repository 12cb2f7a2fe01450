#include "viewer_app.h"

#include "viewer_overlay.h"
#include "window_input.h"

#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/client/terrain_view.h>
#include <terrain/client/tessellation_worker.h>
#include <terrain/procedural_map.h>
#include <terrain/render/glfw_window.h>
#include <terrain/render/gpu_timer.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>
#include <terrain/surface_query.h>
#include <terrain/viewer/fly_camera.h>
#include <terrain/viewer/in_process_server.h>
#include <terrain/viewer/rolling_median.h>
#include <terrain/viewer/viewer_report.h>

#include <GLFW/glfw3.h>

#include <algorithm>
#include <array>
#include <asio.hpp>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace terrain::viewer {

namespace {

using Clock = std::chrono::steady_clock;

double secondsBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
}

constexpr double kPi = 3.14159265358979323846;
/// The eye stays this far above the surface under it (metres): the near plane is 0.5 m.
constexpr double kClearance = 2.0;
/// The scripted flight moves by a fixed step per frame, so its frames are the same at any speed.
constexpr double kScriptedDt = 1.0 / 30.0;
constexpr double kOrbitRadiansPerSecond = 9.0 * kPi / 180.0;
/// Rim height of a crater as a fraction of its depth (OpRequest::strength).
constexpr double kCraterRim = 0.3;
/// After the last frame: time allowed for outstanding crater replies and their ops.
constexpr double kDrainSeconds = 5.0;

/// Set by SIGINT/SIGTERM: the loop ends after the frame in flight, so the report and the
/// screenshot are still written.
volatile std::sig_atomic_t g_stop_requested = 0;

extern "C" void requestStop(int) {
    g_stop_requested = 1;
}

render::DrawMode drawModeOf(int index) {
    switch (index) {
    case 1:
        return render::DrawMode::kShadedWireframe;
    case 2:
        return render::DrawMode::kWireframe;
    default:
        return render::DrawMode::kShaded;
    }
}

/// Above the south-west quarter, looking at the map centre from a height that shows the sky.
FlyCamera startCamera(const Terrain& terrain) {
    const WorldSpec& spec = terrain.spec();
    const double ex = spec.extentX();
    const double ey = spec.extentY();
    const double extent = std::max(ex, ey);
    const glm::dvec3 centre(0.5 * ex, 0.5 * ey, surfaceHeight(terrain, 0.5 * ex, 0.5 * ey));
    const double x = 0.25 * ex;
    const double y = 0.25 * ey;
    const double above = std::max(20.0, 0.06 * extent);
    const double z = std::max(surfaceHeight(terrain, x, y), centre.z) + above;
    FlyCamera camera = FlyCamera::lookingAt({x, y, z}, centre);
    camera.speed = std::max(10.0, 0.05 * extent);
    return camera;
}

/// terrain-viewer-0001.png, or the first number not taken in the current directory.
std::string nextScreenshotName() {
    char name[40];
    for (int i = 1; i < 10000; ++i) {
        std::snprintf(name, sizeof name, "terrain-viewer-%04d.png", i);
        std::error_code ec;
        if (!std::filesystem::exists(name, ec))
            break;
    }
    return name;
}

const char* stateName(client::Connection::State s) {
    switch (s) {
    case client::Connection::State::kIdle:
        return "idle";
    case client::Connection::State::kConnecting:
        return "connecting";
    case client::Connection::State::kJoining:
        return "joining";
    case client::Connection::State::kLive:
        return "live";
    case client::Connection::State::kWaiting:
        return "reconnecting";
    case client::Connection::State::kClosed:
        return "closed";
    }
    return "?";
}

class Viewer {
  public:
    explicit Viewer(const ViewerOptions& options) : options_(options) {
        controls_.tau_pixels = static_cast<float>(options.tau_pixels);
        controls_.draw_mode = options.wireframe ? 1 : 0;
        controls_.crater_radius = static_cast<float>(options.crater_radius);
        controls_.crater_depth = static_cast<float>(options.crater_depth);
        keep_all_ = options.frames > 0 || !options.report.empty();
    }
    ~Viewer() {
        if (connection_)
            connection_->stop();
    }

    int run();

  private:
    Status startServer();
    Status openWindow();
    Status join();
    Status loop();
    void drain();
    int finish();

    void requestCraterAt(const roam::Camera& camera, double px, double py);
    Status writeScreenshot(const std::string& path);
    std::string hashStatus() const;
    OverlayView overlayView() const;
    void pollNetwork();

    ViewerOptions options_;
    std::string address_;
    // members in teardown order, last first: the server outlives its client, the window
    // outlives everything drawing into it, and the replica outlives the connection's handlers
    std::unique_ptr<InProcessServer> server_;
    std::unique_ptr<render::GlfwWindow> window_;
    std::unique_ptr<render::TerrainRenderer> renderer_;
    std::unique_ptr<render::GpuTimer> gpu_timer_;
    std::unique_ptr<ViewerOverlay> overlay_;
    std::optional<WindowInput> input_;
    client::Replica replica_;
    asio::io_context io_;
    std::shared_ptr<client::Connection> connection_;
    /// The synchronous path (--sync-tessellation, or geomorphing): replica -> tessellator, the
    /// triangle budget, on the frame thread.
    std::unique_ptr<client::TerrainView> view_;
    /// The default: the tessellation on a worker thread; the frame draws its newest tiles.
    std::unique_ptr<client::TessellationWorker> worker_;
    roam::DrawnMesh mesh_;
    double steer_ms_ = 0.0;
    /// The drawn mesh's tessellation; none before the join (a report of a failed join).
    roam::FrameStats lastStats() const {
        if (worker_)
            return worker_->taken().stats;
        return view_ ? view_->lastStats() : roam::FrameStats{};
    }
    std::optional<FlyCamera> camera_;

    OverlayControls controls_;
    double applied_tau_ = 0.0;
    /// What the tessellator refines to for a drawn bound of `tau`: a share of it when
    /// geomorphing (the slide spends the rest).
    double refineTau(double tau) const {
        return options_.geomorph > 0.0 ? tau * options_.geomorph : tau;
    }
    std::string message_;
    ViewerReport report_;
    std::int64_t answers_pending_ = 0;
    std::uint64_t last_accepted_seq_ = 0;
    RollingMedian tess_ms_{60};
    RollingMedian draw_ms_{60};
    RollingMedian gpu_ms_{60};
    std::vector<double> all_gpu_ms_;
    RollingMedian frame_ms_{60};
    /// Whole-run timings, for the report and the exit summary of a scripted run.
    bool keep_all_ = false;
    std::vector<double> all_tess_ms_;
    std::vector<double> all_draw_ms_;
    std::vector<double> all_frame_ms_;
    render::UploadStats last_upload_;
};

int Viewer::run() {
    if (Status s = startServer(); !s) {
        std::fprintf(stderr, "terrain-viewer: %s\n", s.error().message.c_str());
        return 1;
    }
    if (Status s = openWindow(); !s) {
        std::fprintf(stderr, "terrain-viewer: %s\n", s.error().message.c_str());
        return 1;
    }
    if (Status s = join(); !s) {
        std::fprintf(stderr, "terrain-viewer: %s\n", s.error().message.c_str());
        return 1;
    }
    if (Status s = loop(); !s) {
        std::fprintf(stderr, "terrain-viewer: %s\n", s.error().message.c_str());
        return 1;
    }
    drain();
    return finish();
}

Status Viewer::startServer() {
    if (!options_.inProcess()) {
        address_ = options_.host + ":" + std::to_string(options_.port);
        return Ok{};
    }
    ProceduralMapOptions map;
    map.seed = options_.seed;
    map.width = options_.size;
    map.height = options_.size;
    const Clock::time_point t0 = Clock::now();
    Result<Terrain> terrain = makeProceduralMap(map);
    if (!terrain)
        return makeError(terrain.error().code, "map: " + terrain.error().message);
    Result<std::unique_ptr<InProcessServer>> server = InProcessServer::start(std::move(*terrain));
    if (!server)
        return makeError(server.error().code, "in-process server: " + server.error().message);
    server_ = std::move(*server);
    options_.port = server_->port();
    options_.token = server_->deformerToken();
    address_ = options_.host + ":" + std::to_string(options_.port);
    std::printf(
        "terrain-viewer: in-process server on %s (%dx%d map, seed %llu, made in %.0f ms)\n",
        address_.c_str(), options_.size, options_.size,
        static_cast<unsigned long long>(options_.seed), 1000.0 * secondsBetween(t0, Clock::now()));
    return Ok{};
}

Status Viewer::openWindow() {
    // a scripted run draws as fast as it can; an interactive one waits for the display
    const bool vsync = options_.frames == 0;
    render::ContextOptions co;
    co.debug = options_.gl_debug;
    Result<std::unique_ptr<render::GlfwWindow>> window = render::GlfwWindow::create(
        options_.width, options_.height, "terrain-viewer - " + address_, vsync, co);
    if (!window)
        return window.error();
    window_ = std::move(*window);
    render::RendererOptions ro;
    ro.upload = *render::parseUploadPath(options_.upload_path); // checked with the options
    ro.validate = options_.validate_buffers;
    Result<std::unique_ptr<render::TerrainRenderer>> renderer =
        render::TerrainRenderer::create(*window_, ro);
    if (!renderer)
        return renderer.error();
    renderer_ = std::move(*renderer);
    gpu_timer_ = std::make_unique<render::GpuTimer>(window_->gl());
    renderer_->setGeomorph(options_.geomorph);
    Result<std::unique_ptr<ViewerOverlay>> overlay = ViewerOverlay::create(window_->handle());
    if (!overlay)
        return overlay.error();
    overlay_ = std::move(*overlay);
    input_.emplace(window_->handle());
    report_.renderer = window_->describe();
    std::printf("terrain-viewer: %s\n", report_.renderer.c_str());
    return Ok{};
}

void Viewer::pollNetwork() {
    // poll() stops the context when it runs out of work; restart so the next poll runs
    io_.restart();
    io_.poll();
    if (connection_)
        connection_->applyArrived(); // this frame's share of what arrived
}

Status Viewer::join() {
    client::ConnectionConfig config;
    config.host = options_.host;
    config.port = options_.port;
    config.token = options_.token;
    config.client_name = "terrain-viewer";
    config.pacing.ops_per_frame = options_.ops_per_frame;
    connection_ = std::make_shared<client::Connection>(io_, config, replica_);
    connection_->on_deform_reply = [this](const client::DeformAnswer& a) {
        --answers_pending_;
        if (a.accepted) {
            ++report_.craters_accepted;
            last_accepted_seq_ = std::max(last_accepted_seq_, a.seq);
        } else {
            ++report_.craters_refused;
            message_ = "crater refused: " + a.reason;
            std::fprintf(stderr, "terrain-viewer: %s\n", message_.c_str());
        }
    };
    connection_->on_disconnect = [this](const std::string& why) {
        // a server that is down refuses every reconnect (5 a second): say so once
        if (message_ != "disconnected: " + why)
            std::fprintf(stderr, "terrain-viewer: disconnected: %s\n", why.c_str());
        message_ = "disconnected: " + why;
    };
    connection_->start();

    const Clock::time_point t0 = Clock::now();
    while (!connection_->synced()) {
        // closed: the server refused us for good (a bad token), so waiting longer cannot help
        const std::string why = connection_->lastDisconnect();
        if (connection_->state() == client::Connection::State::kClosed)
            return makeError(
                ErrorCode::kIo,
                "could not join " + address_ + ": " + (why.empty() ? std::string("closed") : why));
        if (secondsBetween(t0, Clock::now()) > options_.join_timeout_seconds) {
            char limit[32];
            std::snprintf(limit, sizeof limit, "%g", options_.join_timeout_seconds);
            return makeError(
                ErrorCode::kIo, "could not join " + address_ + " within " + limit + " s (" +
                                    stateName(connection_->state()) + ")" +
                                    (why.empty() ? "" : ": " + why));
        }
        glfwPollEvents();
        if (window_->shouldClose() || g_stop_requested != 0)
            return makeError(ErrorCode::kIo, "stopped while joining " + address_);
        io_.restart();
        io_.run_for(std::chrono::milliseconds(10));
        connection_->applyAllArrived(); // no terrain drawn yet
        // keep the window alive: the sky and the overlay saying what it waits for
        const render::GlApi& gl = window_->gl();
        gl.Viewport(0, 0, window_->width(), window_->height());
        gl.ClearColor(0.62f, 0.74f, 0.88f, 1.0f);
        gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        overlay_->draw(overlayView(), controls_);
        window_->present();
    }
    std::printf(
        "terrain-viewer: joined %s in %.0f ms at seq %llu\n", address_.c_str(),
        1000.0 * secondsBetween(t0, Clock::now()), static_cast<unsigned long long>(replica_.seq()));

    // the tessellator starts from the state just received; later snapshots reset it through
    // absorb() (the terrain object stays the same one)
    client::TerrainViewOptions vo;
    vo.tessellation.tau_pixels = refineTau(options_.tau_pixels);
    vo.tessellation.max_triangles = options_.max_triangles;
    vo.budget = {.target_ms = options_.frame_ms, .max_triangles = options_.max_triangles};
    applied_tau_ = options_.tau_pixels;
    camera_.emplace(startCamera(replica_.terrain()));
    // geomorphing slides each vertex for the frame's camera from the tessellator's bounds:
    // only the synchronous path has them on the frame thread
    if (options_.async_tessellation && options_.geomorph <= 0.0) {
        client::TessellationWorkerOptions wo;
        wo.view = vo;
        worker_ = std::make_unique<client::TessellationWorker>(replica_, wo);
        const int w = std::max(window_->width(), 1);
        const int h = std::max(window_->height(), 1);
        worker_->finish(camera_->camera(w, h), mesh_); // the first frame shows the world
    } else {
        view_ = std::make_unique<client::TerrainView>(replica_, vo);
    }
    controls_.speed = static_cast<float>(camera_->speed);
    return Ok{};
}

Status Viewer::loop() {
    const WorldSpec spec = replica_.terrain().spec();
    const glm::dvec2 centre(0.5 * spec.extentX(), 0.5 * spec.extentY());
    // the eye may leave the map by a quarter of it, to look at it from outside
    const glm::dvec2 lo(-0.25 * spec.extentX(), -0.25 * spec.extentY());
    const glm::dvec2 hi(1.25 * spec.extentX(), 1.25 * spec.extentY());
    // haze for depth on large maps; a small one would drown in it
    render::RenderOptions render_options;
    render_options.haze_metres =
        static_cast<float>(std::max(1000.0, 0.75 * std::max(spec.extentX(), spec.extentY())));

    Clock::time_point last_start = Clock::now();
    Clock::time_point last_ping = last_start;
    connection_->ping();
    for (bool first = true;; first = false) {
        const Clock::time_point start = Clock::now();
        const double dt = secondsBetween(last_start, start);
        if (!first) {
            frame_ms_.push(1000.0 * dt);
            if (keep_all_)
                all_frame_ms_.push_back(1000.0 * dt);
        }
        last_start = start;

        glfwPollEvents();
        // a long stall (a snapshot, a dragged window) must not fling the camera
        const double step = std::min(dt, 0.1);
        const FrameInput in = input_->read(step, overlay_->wantsMouse(), overlay_->wantsKeyboard());
        bool last_frame = in.quit || window_->shouldClose() || g_stop_requested != 0;
        if (in.cycle_draw_mode)
            controls_.draw_mode = (controls_.draw_mode + 1) % kDrawModes;

        // the network first, so this frame shows every op that has arrived
        pollNetwork();
        if (view_)
            view_->absorb(); // (a worker takes the replica's changes with the camera)
        const Terrain& terrain = replica_.terrain();

        camera_->speed = controls_.speed;
        if (options_.fly)
            camera_->step(
                orbitInput(*camera_, centre, kOrbitRadiansPerSecond, kScriptedDt), kScriptedDt);
        else
            camera_->step(in.fly, step);
        camera_->keepWithin(lo, hi);
        camera_->keepAbove(surfaceHeight(terrain, camera_->eye().x, camera_->eye().y), kClearance);

        if (static_cast<double>(controls_.tau_pixels) != applied_tau_ &&
            controls_.tau_pixels > 0.0f) {
            applied_tau_ = static_cast<double>(controls_.tau_pixels);
            if (worker_)
                worker_->setTau(refineTau(applied_tau_));
            else
                view_->tessellator().setTau(refineTau(applied_tau_));
        }

        const int fb_w = window_->width();
        const int fb_h = window_->height();
        if (fb_w <= 0 || fb_h <= 0) {
            // minimised: nothing to draw into
            glfwWaitEventsTimeout(0.05);
            if (last_frame)
                break;
            continue;
        }
        const roam::Camera camera = camera_->camera(fb_w, fb_h);
        const Clock::time_point t0 = Clock::now();
        if (worker_) {
            // the frame's camera to the worker, its newest tiles to the frame: no wait
            worker_->post(camera, steer_ms_);
            worker_->take(mesh_);
        } else {
            view_->update(camera);
        }
        const Clock::time_point t1 = Clock::now();
        gpu_timer_->begin();
        render_options.mode = drawModeOf(controls_.draw_mode);
        if (worker_) {
            last_upload_ = renderer_->sync(mesh_);
            renderer_->draw(mesh_, camera, render_options);
        } else {
            roam::Tessellator& tess = view_->tessellator();
            last_upload_ = renderer_->sync(tess, terrain);
            const render::UploadStats morphed = renderer_->morph(tess, camera);
            last_upload_.vertex_bytes += morphed.vertex_bytes;
            renderer_->draw(tess, camera, render_options);
        }
        gpu_timer_->end();
        // the CPU's part only: the GPU's comes back from its timer a few frames later, and
        // waiting for it here (glFinish) would stall every frame
        const Clock::time_point t2 = Clock::now();
        const double tess_ms = 1000.0 * secondsBetween(t0, t1);
        const double draw_ms = 1000.0 * secondsBetween(t1, t2);
        tess_ms_.push(tess_ms);
        draw_ms_.push(draw_ms);
        std::array<double, render::GpuTimer::kQueries> gpu_done{};
        const std::size_t done = gpu_timer_->collect(gpu_done);
        for (std::size_t k = 0; k < done; ++k) {
            gpu_ms_.push(gpu_done[k]);
            if (keep_all_)
                all_gpu_ms_.push_back(gpu_done[k]);
        }
        // the budget steers on the slower of the two where the GPU's time is known
        const double gpu_frame = gpu_timer_->latestMs().value_or(0.0);
        steer_ms_ = std::max(tess_ms + draw_ms, gpu_frame);
        if (view_)
            view_->steer(steer_ms_);
        if (keep_all_) {
            all_tess_ms_.push_back(tess_ms);
            all_draw_ms_.push_back(draw_ms);
        }
        ++report_.frames;
        if (options_.frames > 0 && report_.frames >= options_.frames)
            last_frame = true;

        // clicks and the scripted crater use the camera this frame was drawn with
        if (in.crater)
            requestCraterAt(camera, in.crater_x, in.crater_y);
        if (options_.auto_crater > 0 && report_.frames % options_.auto_crater == 0)
            requestCraterAt(camera, 0.5 * fb_w, 0.5 * fb_h);

        // screenshots hold the terrain only: read before the overlay and the swap
        if (in.screenshot) {
            const std::string name = nextScreenshotName();
            Status s = writeScreenshot(name);
            message_ = s ? "screenshot: " + name : s.error().message;
        }
        if (last_frame && !options_.screenshot.empty()) {
            if (Status s = writeScreenshot(options_.screenshot); !s)
                return s;
            report_.screenshot = options_.screenshot;
        }

        overlay_->draw(overlayView(), controls_);
        window_->present();

        if (secondsBetween(last_ping, Clock::now()) >= 1.0) {
            connection_->ping();
            last_ping = Clock::now();
        }
        if (last_frame)
            break;
    }
    return Ok{};
}

void Viewer::requestCraterAt(const roam::Camera& camera, double px, double py) {
    // the sliders move apart; a crater is at most as deep as it is wide (the server's rule)
    const std::optional<OpRequest> request = client::craterAtPixel(
        replica_.terrain(), camera, px, py,
        {.radius = static_cast<double>(controls_.crater_radius),
         .depth = static_cast<double>(std::min(controls_.crater_depth, controls_.crater_radius)),
         .rim = kCraterRim});
    if (!request) {
        ++report_.craters_missed;
        message_ = "the click missed the terrain";
        return;
    }
    if (connection_->state() != client::Connection::State::kLive) {
        // the connection drops requests while it is down: say so instead of waiting
        message_ = "not connected: crater not sent";
        return;
    }
    connection_->requestDeform(*request);
    ++report_.craters_requested;
    ++answers_pending_;
}

Status Viewer::writeScreenshot(const std::string& path) {
    Status s = io::writeRgbPng(path, window_->readPixels());
    if (!s)
        return makeError(s.error().code, "screenshot " + path + ": " + s.error().message);
    std::printf("terrain-viewer: wrote %s\n", path.c_str());
    return Ok{};
}

void Viewer::drain() {
    // a crater asked for on the last frame is answered and applied after it: wait for that (and
    // for its op) so the report and the exit code speak for the finished world
    const Clock::time_point t0 = Clock::now();
    while (
        connection_->state() == client::Connection::State::kLive &&
        (answers_pending_ > 0 || replica_.seq() < last_accepted_seq_ || !connection_->synced())) {
        if (secondsBetween(t0, Clock::now()) > kDrainSeconds)
            break;
        io_.restart();
        io_.run_for(std::chrono::milliseconds(10));
        connection_->applyAllArrived(); // the last frame is drawn
    }
}

std::string Viewer::hashStatus() const {
    if (replica_.diverged())
        return "diverged";
    if (connection_ && connection_->synced())
        return "verified";
    return connection_ ? stateName(connection_->state()) : "starting";
}

OverlayView Viewer::overlayView() const {
    OverlayView v;
    v.server = address_;
    v.in_process = options_.inProcess();
    v.renderer = report_.renderer;
    v.status = hashStatus();
    v.seq = replica_.seq();
    v.verified_seq = replica_.verifiedSeq();
    v.world_hash = replica_.worldHash();
    v.rtt_ms = connection_ ? 1000.0 * connection_->roundTripSeconds() : 0.0;
    v.triangles = lastStats().triangles;
    v.visible_triangles = lastStats().visible_triangles;
    v.tessellation_ms = tess_ms_.median();
    v.draw_ms = draw_ms_.median();
    v.gpu_ms = gpu_ms_.median();
    v.frame_ms = frame_ms_.median();
    v.upload_bytes = last_upload_.bytes();
    v.upload_bytes_total = renderer_ ? renderer_->totals().bytes() : 0;
    v.craters_requested = report_.craters_requested;
    v.craters_accepted = report_.craters_accepted;
    v.craters_refused = report_.craters_refused;
    if (camera_) {
        v.eye[0] = camera_->eye().x;
        v.eye[1] = camera_->eye().y;
        v.eye[2] = camera_->eye().z;
    }
    v.message = message_;
    return v;
}

int Viewer::finish() {
    ViewerReport& r = report_;
    r.server = address_;
    r.in_process = options_.inProcess();
    r.width = window_->width();
    r.height = window_->height();
    r.tau_pixels = applied_tau_;
    r.seq = replica_.seq();
    r.world_hash = replica_.worldHash();
    r.verified_seq = replica_.verifiedSeq();
    r.hash_mismatches = replica_.stats().hash_mismatches;
    r.repairs = replica_.stats().repairs;
    r.synced = connection_->synced();
    r.diverged = replica_.diverged();
    r.triangles = lastStats().triangles;
    r.visible_triangles = lastStats().visible_triangles;
    r.median_frame_ms = medianOf(all_frame_ms_);
    r.median_tessellation_ms = medianOf(all_tess_ms_);
    r.median_draw_ms = medianOf(all_draw_ms_);
    r.median_gpu_ms = medianOf(all_gpu_ms_);
    r.bytes_uploaded = renderer_->totals().bytes();
    r.upload_path = render::toString(renderer_->uploadPath());
    if (const render::GlDebugLog* log = window_->debugLog()) {
        r.gl_errors = static_cast<std::int64_t>(log->errors());
        r.gl_messages = static_cast<std::int64_t>(log->messages());
    }
    if (options_.validate_buffers) {
        const render::ValidationReport& v = renderer_->validation();
        r.buffer_mismatches =
            static_cast<std::int64_t>(v.vertex_mismatches + v.index_mismatches + v.short_buffers);
        if (!v.clean())
            std::fprintf(stderr, "terrain-viewer: buffers differ: %s\n", v.first_problem.c_str());
    }
    r.rtt_ms = 1000.0 * connection_->roundTripSeconds();
    const std::string status = hashStatus();
    const std::string disconnect = connection_->lastDisconnect();
    connection_->stop();
    if (server_) {
        const InProcessServer::State s = server_->state();
        r.server_seq = s.seq;
        r.server_world_hash = s.world_hash;
    }

    std::printf(
        "terrain-viewer: %lld frames, seq %llu, hash %s (%s), %lld triangles, median ms: frame "
        "%.2f, tessellate %.2f, draw %.2f; craters %lld asked, %lld made\n",
        static_cast<long long>(r.frames), static_cast<unsigned long long>(r.seq),
        hashHex(r.world_hash).c_str(), status.c_str(), static_cast<long long>(r.triangles),
        keep_all_ ? r.median_frame_ms : frame_ms_.median(),
        keep_all_ ? r.median_tessellation_ms : tess_ms_.median(),
        keep_all_ ? r.median_draw_ms : draw_ms_.median(),
        static_cast<long long>(r.craters_requested), static_cast<long long>(r.craters_accepted));
    int code = 0;
    if (!options_.report.empty()) {
        if (Status s = writeViewerReport(options_.report, r); !s) {
            std::fprintf(stderr, "terrain-viewer: %s\n", s.error().message.c_str());
            code = 1;
        }
    }
    if (r.diverged) {
        std::fprintf(
            stderr,
            "terrain-viewer: the replica diverged from the server (%llu hash mismatches, verified "
            "to seq %llu of %llu)\n",
            static_cast<unsigned long long>(r.hash_mismatches),
            static_cast<unsigned long long>(r.verified_seq),
            static_cast<unsigned long long>(r.seq));
        code = 1;
    } else if (options_.frames > 0 && !r.synced) {
        // a scripted run must end on the server's state; an interactive one may end offline
        std::fprintf(
            stderr, "terrain-viewer: not in sync with %s at the end (%s)%s%s\n", address_.c_str(),
            status.c_str(), disconnect.empty() ? "" : ": ", disconnect.c_str());
        code = 1;
    }
    if (r.server_seq && *r.server_seq == r.seq && *r.server_world_hash != r.world_hash) {
        std::fprintf(
            stderr, "terrain-viewer: replica hash %s differs from the server's %s at seq %llu\n",
            hashHex(r.world_hash).c_str(), hashHex(*r.server_world_hash).c_str(),
            static_cast<unsigned long long>(r.seq));
        code = 1;
    }
    return code;
}

} // namespace

int runViewer(const ViewerOptions& options) {
    std::signal(SIGINT, requestStop);
    std::signal(SIGTERM, requestStop);
    Viewer viewer(options);
    return viewer.run();
}

} // namespace terrain::viewer
