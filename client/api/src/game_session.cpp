// Session: the implementation behind the C ABI (terrain_client.h): a facade over the replica, the
// connection (on an io_context the game's thread polls, or on the client's own network thread)
// and the tessellation worker, with the frame's copy of the tiles in metres.

#include "game_session.h"

#include "network_thread.h"

#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/client/tessellation_worker.h>
#include <terrain/roam/drawn_mesh.h>
#include <terrain/surface_query.h>

#include <asio.hpp>
#include <chrono>
#include <cmath>
#include <thread>
#include <utility>

namespace terrain::game::detail {

const std::uint32_t Session::kIndicesPerPage = roam::MeshDelta::kPageIndices;

namespace {

ClientResult fail(ClientError error, std::string message) {
    return {error, std::move(message), 0};
}

bool finite3(const double v[3]) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

} // namespace

struct Session::Impl {
    explicit Impl(ClientOptions o) : options(std::move(o)) {}

    ClientOptions options;
    asio::io_context io;
    client::Replica replica; // the frame's: the worker and heightAt() read it
    std::shared_ptr<client::Connection> connection;
    // network_thread mode: the connection and its replica on their own thread; the frame's
    // replica follows theirs by the tiles each change touched (no op applied twice)
    std::unique_ptr<NetworkThread> network;
    NetworkNews latest; // the network thread's flags as last taken (syncs and answers moved out)
    std::unique_ptr<client::TessellationWorker> worker;
    roam::DrawnMesh mesh{roam::DrawnMesh::Units::kMetres};
    std::vector<OpAnswer> answers;
    std::string last_error;
    std::string closed_reason; // why it closed, as the closed client's answers say
    bool closed = false;
    ClientError closed_because = ClientError::kClosed;

    bool connected() const { return connection || network; }
    bool live() const {
        if (network)
            return latest.live;
        return connection && connection->state() == client::Connection::State::kLive;
    }
    bool synced() const {
        if (network)
            return latest.synced && replica.seq() == latest.seq;
        return connection && connection->synced();
    }

    /// The connection closed itself (a final refusal, a give up): the client is closed.
    void noticeClosed() {
        if (closed)
            return;
        if (network ? !latest.closed
                    : !connection || connection->state() != client::Connection::State::kClosed)
            return;
        closed = true;
        last_error = network ? latest.last_disconnect : connection->lastDisconnect();
        closed_reason = last_error;
        closed_because = last_error.rfind("CONNECT_TIMEOUT", 0) == 0 ? ClientError::kTimedOut
                         : last_error.rfind("INTERNAL", 0) == 0      ? ClientError::kInternal
                                                                : ClientError::kRefusedByServer;
    }

    ClientResult closedResult() const {
        return fail(closed_because, "the client is closed: " + closed_reason);
    }

    void poll() {
        if (network) {
            takeNews();
            return;
        }
        io.restart();
        io.poll();
        noticeClosed();
    }

    /// network_thread mode: what the network thread did since the last look; the frame's
    /// replica follows it (microseconds a crater: the tiles it changed, copied).
    void takeNews() {
        NetworkNews news = network->take();
        for (const client::ReplicaSync& sync : news.syncs)
            replica.follow(sync);
        for (client::DeformAnswer& a : news.answers)
            answers.push_back({a.request_id, a.accepted, a.seq, std::move(a.reason)});
        if (!news.last_disconnect.empty() && news.last_disconnect != latest.last_disconnect)
            last_error = news.last_disconnect;
        news.syncs.clear();
        news.answers.clear();
        latest = std::move(news);
        noticeClosed();
    }

    void applyArrived() {
        if (!network) // the network thread's mode: followed as taken
            connection->applyArrived();
    }
    void applyAllArrived() {
        if (!network)
            connection->applyAllArrived();
    }

    ClientResult validate() const {
        if (options.host.empty())
            return fail(ClientError::kBadParameter, "host: empty");
        if (options.port == 0)
            return fail(
                ClientError::kBadParameter, "port: 0 (the server's game port, 7777 by default)");
        if (options.token.empty())
            return fail(
                ClientError::kBadParameter, "token: empty (the server signs one per player)");
        if (!(options.connect_timeout_seconds >= 0.0) || !(options.give_up_seconds >= 0.0))
            return fail(ClientError::kBadParameter, "timeouts: must be finite and >= 0");
        if (!(options.tau_pixels > 0.0 && options.tau_pixels <= 1000.0))
            return fail(ClientError::kBadParameter, "tau_pixels: must be in (0, 1000]");
        if (options.ops_per_frame < 0 || options.catch_up_frames < 1)
            return fail(ClientError::kBadParameter, "ops_per_frame >= 0 and catch_up_frames >= 1");
        if (options.max_triangles < 1000)
            return fail(ClientError::kBadParameter, "max_triangles: must be at least 1000");
        return {};
    }
};

Session::Session(ClientOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

Session::~Session() {
    close();
}

ClientResult Session::connect() {
    Impl& m = *impl_;
    if (m.closed)
        return m.closedResult();
    if (m.connected())
        return fail(ClientError::kBadParameter, "connect: already called");
    if (ClientResult r = m.validate(); !r)
        return r;
    client::ConnectionConfig config;
    config.host = m.options.host;
    config.port = m.options.port;
    config.token = m.options.token;
    config.client_name = m.options.client_name;
    config.reconnect = m.options.reconnect;
    config.connect_timeout_seconds = m.options.connect_timeout_seconds;
    config.give_up_seconds = m.options.give_up_seconds;
    config.pacing.ops_per_frame = m.options.ops_per_frame;
    config.pacing.catch_up_frames = m.options.catch_up_frames;
    if (m.options.network_thread) {
        m.network = std::make_unique<NetworkThread>(std::move(config));
        return {};
    }
    m.connection = std::make_shared<client::Connection>(m.io, config, m.replica);
    m.connection->on_deform_reply = [&m](const client::DeformAnswer& a) {
        m.answers.push_back({a.request_id, a.accepted, a.seq, a.reason});
    };
    m.connection->on_disconnect = [&m](const std::string& why) { m.last_error = why; };
    m.connection->start();
    return {};
}

ClientResult Session::waitSynced(double timeout_seconds) {
    Impl& m = *impl_;
    if (m.closed)
        return m.closedResult();
    if (!m.connected())
        return fail(ClientError::kNotConnected, "waitSynced: connect() first");
    if (!(timeout_seconds >= 0.0))
        return fail(ClientError::kBadParameter, "timeout_seconds: must be >= 0");
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(timeout_seconds));
    while (true) {
        if (m.network) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            m.takeNews();
        } else {
            m.io.restart();
            m.io.run_for(std::chrono::milliseconds(5));
            m.noticeClosed();
        }
        if (m.closed)
            return m.closedResult();
        m.applyAllArrived(); // a loading screen draws no frames
        if (m.synced())
            return {};
        if (std::chrono::steady_clock::now() >= deadline)
            return fail(
                ClientError::kTimedOut,
                "waitSynced: not synced after " + std::to_string(timeout_seconds) + " s" +
                    (m.last_error.empty() ? std::string() : " (last error: " + m.last_error + ")"));
    }
}

ClientResult Session::pump() {
    Impl& m = *impl_;
    if (m.closed)
        return m.closedResult();
    if (!m.connected())
        return fail(ClientError::kNotConnected, "pump: connect() first");
    m.poll();
    if (m.closed)
        return m.closedResult();
    m.applyArrived();
    return {};
}

void Session::close() {
    Impl& m = *impl_;
    if (m.closed && !m.connected() && !m.worker)
        return;
    if (m.network) {
        m.network->stop();
        m.network.reset();
    }
    if (m.connection) {
        m.connection->stop();
        m.io.restart();
        m.io.poll(); // let the cancelled handlers run (they hold the connection)
        m.connection.reset();
    }
    m.worker.reset();
    if (!m.closed) {
        m.last_error = "closed by the game";
        m.closed_reason = m.last_error;
    }
    m.closed = true;
    m.closed_because = ClientError::kClosed;
}

ClientResult
Session::requestOp(OpKind kind, double x, double y, double radius, double height, double strength) {
    Impl& m = *impl_;
    if (m.closed)
        return m.closedResult();
    if (!m.connected())
        return fail(ClientError::kNotConnected, "requestOp: connect() first");
    if (static_cast<int>(kind) < 1 || static_cast<int>(kind) > 4)
        return fail(ClientError::kBadParameter, "kind: not an op kind (1-4)");
    if (!m.replica.ready())
        return fail(
            ClientError::kNotSynced, "requestOp: no world yet (the join has not completed)");
    const OpRequest request{static_cast<terrain::OpKind>(kind), x, y, radius, height, strength};
    if (Result<DeformOp> op = quantizeOp(request, m.replica.terrain().spec()); !op)
        return fail(ClientError::kBadParameter, op.error().message);
    if (!m.live())
        return fail(
            ClientError::kNotConnected,
            "NOT_CONNECTED: no live link to the server; nothing was sent");
    if (m.network) // refused in its answer if the link drops before the network thread sends it
        return {ClientError::kNone, "", m.network->requestDeform(request)};
    const std::uint32_t id = m.connection->requestDeform(request);
    if (id == 0)
        return fail(ClientError::kNotConnected, m.connection->lastRefusal());
    ClientResult r;
    r.request_id = id;
    return r;
}

std::vector<OpAnswer> Session::takeAnswers() {
    std::vector<OpAnswer> out;
    out.swap(impl_->answers);
    return out;
}

WorldState Session::world() const {
    const Impl& m = *impl_;
    WorldState w;
    w.loaded = m.replica.ready();
    w.seq = m.replica.seq();
    w.world_hash = m.replica.worldHash();
    w.live = !m.closed && m.live();
    w.synced = !m.closed && m.synced();
    w.closed = m.closed;
    // the ops and checks are the network replica's in network_thread mode (the frame's copy
    // follows it, applying nothing)
    const client::ReplicaStats& s = m.network ? m.latest.stats : m.replica.stats();
    w.ops_applied = s.ops_applied;
    w.hash_mismatches = s.hash_mismatches;
    w.repairs = s.repairs;
    w.snapshots = s.snapshots;
    if (w.loaded) {
        w.extent_x = m.replica.terrain().spec().extentX();
        w.extent_y = m.replica.terrain().spec().extentY();
    }
    return w;
}

const std::string& Session::lastError() const {
    return impl_->last_error;
}

void Session::noteError(std::string message) {
    impl_->last_error = std::move(message);
}

bool Session::heightAt(double x, double y, double& height_out) const {
    const Impl& m = *impl_;
    if (!m.replica.ready() || !std::isfinite(x) || !std::isfinite(y))
        return false;
    const WorldSpec& spec = m.replica.terrain().spec();
    if (x < 0.0 || y < 0.0 || x > spec.extentX() || y > spec.extentY())
        return false;
    height_out = surfaceHeight(m.replica.terrain(), x, y);
    return true;
}

ClientResult Session::tessellate(const Camera& camera, bool* changed) {
    Impl& m = *impl_;
    if (changed != nullptr)
        *changed = false;
    if (m.closed)
        return m.closedResult();
    if (!finite3(camera.eye) || !finite3(camera.forward) || !finite3(camera.up) ||
        (camera.forward[0] == 0.0 && camera.forward[1] == 0.0 && camera.forward[2] == 0.0))
        return fail(
            ClientError::kBadParameter,
            "camera: eye, forward and up must be finite, forward not 0");
    if (!(camera.fovy_radians > 0.0 && camera.fovy_radians < 3.1) || camera.viewport_width <= 0 ||
        camera.viewport_height <= 0 || !(camera.near_plane > 0.0))
        return fail(
            ClientError::kBadParameter,
            "camera: fovy in (0, 3.1) radians, a viewport of at least 1 x 1, near plane > 0");
    if (!m.replica.ready())
        return fail(
            ClientError::kNotSynced, "tessellate: no world yet (the join has not completed)");
    roam::Camera c; // the tessellator's
    c.eye = {camera.eye[0], camera.eye[1], camera.eye[2]};
    c.forward = {camera.forward[0], camera.forward[1], camera.forward[2]};
    c.up = {camera.up[0], camera.up[1], camera.up[2]};
    c.fovy_radians = camera.fovy_radians;
    c.viewport_width = camera.viewport_width;
    c.viewport_height = camera.viewport_height;
    c.near_plane = camera.near_plane;
    bool took = false;
    if (!m.worker) {
        client::TessellationWorkerOptions wo;
        wo.view.tessellation.tau_pixels = m.options.tau_pixels;
        wo.view.tessellation.max_triangles = m.options.max_triangles;
        wo.threads = m.options.worker_threads;
        m.worker = std::make_unique<client::TessellationWorker>(m.replica, wo);
        m.worker->finish(c, m.mesh); // the first frame shows the whole world, not nothing
        took = true;
    } else {
        m.worker->post(c);
        took = m.worker->take(m.mesh);
    }
    if (changed != nullptr)
        *changed = took;
    return {};
}

std::uint64_t Session::meshLag() const {
    return impl_->worker ? impl_->worker->lag() : 0;
}

double Session::meshErrorPixels() const {
    return impl_->worker ? impl_->worker->taken().stats.error_bound_pixels : 0.0;
}

std::int32_t Session::tileCount() const {
    return impl_->worker ? impl_->mesh.tileCount() : 0;
}

ClientResult Session::tile(std::int32_t tile, TileBuffers& out) const {
    const roam::DrawnMesh& mesh = impl_->mesh;
    if (tile < 0 || tile >= tileCount())
        return fail(
            ClientError::kBadParameter, "tile: " + std::to_string(tile) + " is not in [0, " +
                                            std::to_string(tileCount()) + ")");
    static_assert(sizeof(Vertex) == sizeof(roam::DrawVertex));
    static_assert(sizeof(VertexRun) == sizeof(roam::VertexRange));
    out = TileBuffers{};
    out.visible = mesh.tileVisible(tile);
    const auto vertices = mesh.vertices(tile);
    out.vertices = reinterpret_cast<const Vertex*>(vertices.data());
    out.vertex_count = static_cast<std::uint32_t>(vertices.size());
    const auto indices = mesh.indices(tile);
    out.indices = indices.data();
    out.index_count = static_cast<std::uint32_t>(indices.size());
    out.indices_rewritten = mesh.indicesRewritten(tile);
    const auto pages = mesh.dirtyPages(tile);
    out.dirty_pages = pages.data();
    out.dirty_page_count = static_cast<std::uint32_t>(pages.size());
    out.vertices_all_changed = mesh.verticesAllChanged(tile);
    const auto runs = mesh.vertexChanges(tile);
    out.vertex_runs = reinterpret_cast<const VertexRun*>(runs.data());
    out.vertex_run_count = static_cast<std::uint32_t>(runs.size());
    return {};
}

bool Session::tileChanged(std::int32_t tile) const {
    if (tile < 0 || tile >= tileCount())
        return false;
    const roam::DrawnMesh& mesh = impl_->mesh;
    return mesh.indicesDirty(tile) || mesh.verticesAllChanged(tile) ||
           !mesh.vertexChanges(tile).empty();
}

void Session::markUploaded(std::int32_t tile) {
    if (tile >= 0 && tile < tileCount())
        impl_->mesh.takeChanges(tile);
}

} // namespace terrain::game::detail
