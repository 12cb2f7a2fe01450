#pragma once

// The terrain client a game links, in C++ (17 or later): an inline wrapper over the C ABI
// (terrain_client.h, libterrain_client.so), so that a game built with another compiler or
// standard library links it all the same. One object joins a terrain server, keeps the world's
// replica exact (every op applied and its world hash checked; repairs and snapshots when not),
// sends the player's deformations, and tessellates the terrain for the game's camera on a
// worker thread, handing the game per-tile vertex and index buffers and what changed in them
// since it last uploaded.
//
// Threading: every call from one thread, the game's (the frame loop). The network is pumped by
// pump() and the tessellation runs on the client's own worker thread; nothing here blocks but
// waitSynced() and close().
//
// Coordinates: metres, x east and y north from the map's corner (vertex 0, 0), z up (heights
// above the map's zero). A y-up engine swaps y and z (and so flips the triangles' winding, which
// is counter-clockwise seen from above).
//
// The game loop (docs/EMBEDDING.md):
//   terrain::game::Client client(options);
//   client.connect();                           // refused at once with a reason if bad
//   client.waitSynced(10.0);                    // a loading screen, or pump() until synced
//   each frame: client.pump();                  // network and this frame's share of the ops
//               client.tessellate(camera);      // the camera in, the newest finished tiles out
//               for each tile with tileChanged(t): upload tile(t)'s dirty parts, markUploaded(t)
//               client.requestCrater(...);      // a shot; its answer in takeAnswers()

#include <terrain_client.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <vector>

namespace terrain::game {

/// Why a call did not do what it was asked; kNone when it did (terrain_status's values).
enum class ClientError {
    kNone = TERRAIN_OK,
    kBadParameter = TERRAIN_BAD_PARAMETER, ///< an argument breaks a rule (the message names it)
    kNotConnected = TERRAIN_NOT_CONNECTED, ///< no link to the server is up: nothing was sent
    kNotSynced = TERRAIN_NOT_SYNCED,       ///< no world yet (the first join has not completed)
    kTimedOut = TERRAIN_TIMED_OUT,         ///< a wait ran out, or the client gave up
    kClosed = TERRAIN_CLOSED,              ///< closed (close(), or a final refusal)
    kRefusedByServer = TERRAIN_REFUSED_BY_SERVER, ///< bad token, version (the message says which)
    kInternal = TERRAIN_INTERNAL, ///< out of memory or a bug (the message says what)
    kBadData = TERRAIN_BAD_DATA,  ///< bytes or an op a rule refuses (the replica alone)
    kSeqGap = TERRAIN_SEQ_GAP     ///< an op past seq + 1 (the replica alone)
};

/// The name of an error ("BAD_PARAMETER", ...).
inline const char* errorName(ClientError error) {
    return terrain_status_name(static_cast<int>(error));
}

/// A call's outcome: error kNone, or the error and a message naming the rule broken.
struct ClientResult {
    ClientError error = ClientError::kNone;
    std::string message;
    std::uint32_t request_id = 0; ///< requests: the id their answer will carry
    explicit operator bool() const { return error == ClientError::kNone; }
};

namespace detail {
/// A call's status as a ClientResult, with the handle's message when it failed.
inline ClientResult resultOf(terrain_status status, const char* last_error) {
    ClientResult r;
    r.error = static_cast<ClientError>(status);
    if (status != TERRAIN_OK)
        r.message = last_error;
    return r;
}
} // namespace detail

struct ClientOptions {
    std::string host = "127.0.0.1";
    std::uint16_t port = 7777;
    /// The server's signed token for this player (its role decides whether it may deform).
    std::string token;
    std::string client_name = "game";
    /// An attempt whose TCP connect takes longer is abandoned and retried (with backoff).
    double connect_timeout_seconds = 5.0;
    /// With no live link for this long (from connect(), or since the link was lost), the client
    /// gives up: kTimedOut, and it stays closed. 0: keep trying.
    double give_up_seconds = 30.0;
    /// Reconnect when a live link drops (resuming from the replica's seq).
    bool reconnect = true;
    /// Ops applied per pump() at least (a burst of craters is spread over frames, each frame's
    /// share at most a backlog / catch_up_frames more); 0: every op as soon as it arrives. With
    /// network_thread the ops are applied on that thread as they are read, and pump() brings
    /// the frame's copy up to date whole (the tiles they changed, copied): no pacing.
    int ops_per_frame = 2;
    int catch_up_frames = 8;
    /// The tessellation's screen-space error bound (pixels) and triangle cap.
    double tau_pixels = 1.0;
    std::int64_t max_triangles = 400000;
    /// Threads the tessellation worker may spread a step over (its own included); 0: min(cores -
    /// 1, 4). The meshes are the same at any count.
    unsigned worker_threads = 0;
    /// The network on the client's own thread: the link is read, answered and kept alive however
    /// long the game's frames take, and a join's snapshot is decoded and every op applied and
    /// its hash checked there; pump() copies the tiles the checked changes touched into the
    /// frame's world (microseconds a crater, where applying one is a millisecond or more). It
    /// costs a second copy of the world's heights (patch lists are shared). Off: pump() reads
    /// the network and applies the ops on the game's thread.
    bool network_thread = false;
};

/// The world the client holds.
struct WorldState {
    std::uint64_t seq = 0;        ///< the last op applied (the server numbers them from 1)
    std::uint64_t world_hash = 0; ///< the replica's world hash at seq
    bool loaded = false;          ///< a world is held (after the first join)
    bool live = false;            ///< a link to the server is up and joined
    bool synced = false;          ///< live, every op received applied, and the hashes agree
    bool closed = false;          ///< closed for good (close(), a final refusal, give up)
    std::uint64_t ops_applied = 0;
    std::uint64_t hash_mismatches = 0; ///< each was repaired (repairs) or resynced (snapshots)
    std::uint64_t repairs = 0;
    std::uint64_t snapshots = 0;
    double extent_x = 0.0; ///< the map's size in metres (0 until loaded)
    double extent_y = 0.0;
};

/// The server's answer to a deformation request.
struct OpAnswer {
    std::uint32_t request_id = 0;
    bool accepted = false;
    std::uint64_t seq = 0; ///< accepted: the seq its op was given (broadcast to every client)
    std::string reason;    ///< refused: "REASON_...: message"
};

/// What a deformation does (the server's op kinds, numbered as on the wire).
enum class OpKind {
    kCrater = TERRAIN_OP_CRATER, ///< a bowl `height` deep below the ground around it, its rim
                                 ///< `strength * height`
    kRaise = 2,                  ///< a smooth mound of signed height `height` (negative digs)
    kFlatten = 3, ///< blends towards the absolute level `height` by `strength`, fading to the edge
    kSmooth = 4   ///< relaxes towards the neighbours' average by `strength`, fading to the edge
};

/// A perspective camera in the world frame above (metres, z up).
struct Camera {
    double eye[3] = {0.0, 0.0, 100.0};
    double forward[3] = {1.0, 0.0, 0.0}; ///< need not be unit length
    double up[3] = {0.0, 0.0, 1.0};
    double fovy_radians = 1.0471975511965976; ///< 60 degrees
    int viewport_width = 1280;
    int viewport_height = 720;
    double near_plane = 0.5; ///< metres
};

/// One vertex, 16 bytes: position in metres (the world frame) and the unit normal packed as
/// signed 10:10:10:2 (x in bits 0-9, y 10-19, z 20-29, each a two's-complement value over 511;
/// OpenGL's GL_INT_2_10_10_10_REV normalised, Vulkan's VK_FORMAT_A2B10G10R10_SNORM_PACK32).
using Vertex = terrain_vertex;
/// A run [begin, end) of a tile's vertex array.
using VertexRun = terrain_vertex_run;

/// One tile's buffers as the game draws them, and what changed since markUploaded(tile). The
/// pointers stay valid until the next tessellate() or close(). The vertices are those the
/// tile's triangles use, each at a slot of its own while used; a slot no index refers to (free
/// for the next vertex) holds an old vertex or a point of the tile: draw by index.
struct TileBuffers {
    bool visible = false; ///< in the camera's view (draw only these)
    const Vertex* vertices = nullptr;
    std::uint32_t vertex_count = 0;
    /// Three per triangle, into this tile's vertices; every triangle is drawn.
    const std::uint32_t* indices = nullptr;
    std::uint32_t index_count = 0;
    // changes since markUploaded()
    bool indices_rewritten = false; ///< upload every index
    /// Pages of Client::indicesPerPage() indices written (ascending): indices [page * n,
    /// min((page + 1) * n, index_count)). A page past index_count needs nothing.
    const std::uint32_t* dirty_pages = nullptr;
    std::uint32_t dirty_page_count = 0;
    bool vertices_all_changed = false;      ///< upload every vertex
    const VertexRun* vertex_runs = nullptr; ///< runs written (they may overlap)
    std::uint32_t vertex_run_count = 0;
};

class Client {
  public:
    /// Indices per dirty page.
    static std::uint32_t indicesPerPage() { return terrain_indices_per_page(); }

    /// Makes the client (nothing connects yet). Throws std::bad_alloc if it cannot.
    explicit Client(const ClientOptions& options) {
        terrain_client_options o;
        terrain_client_options_init(&o);
        o.host = options.host.c_str();
        o.port = options.port;
        o.token = options.token.c_str();
        o.client_name = options.client_name.c_str();
        o.connect_timeout_seconds = options.connect_timeout_seconds;
        o.give_up_seconds = options.give_up_seconds;
        o.reconnect = options.reconnect ? 1 : 0;
        o.ops_per_frame = options.ops_per_frame;
        o.catch_up_frames = options.catch_up_frames;
        o.tau_pixels = options.tau_pixels;
        o.max_triangles = options.max_triangles;
        o.worker_threads = options.worker_threads;
        o.network_thread = options.network_thread ? 1 : 0;
        if (terrain_client_create(&o, &client_) != TERRAIN_OK)
            throw std::bad_alloc();
    }
    /// Closes (joins the worker thread).
    ~Client() { terrain_client_destroy(client_); }
    Client(const Client&) = delete;
    Client& operator=(const Client&) = delete;

    /// Starts connecting (returns at once). kBadParameter for options that break a rule (no
    /// host, port 0, no token, tau or cap out of range); kClosed after close().
    ClientResult connect() { return result(terrain_client_connect(client_)); }
    /// Pumps until the world is loaded and synced, up to `timeout_seconds`: kTimedOut, or the
    /// reason the client closed (a bad token: kRefusedByServer).
    ClientResult waitSynced(double timeout_seconds) {
        return result(terrain_client_wait_synced(client_, timeout_seconds));
    }
    /// Once a frame: reads the network and applies this frame's share of the ops (a burst is
    /// spread over frames). kClosed once closed (lastError() says why).
    ClientResult pump() { return result(terrain_client_pump(client_)); }
    /// Closes the link for good and stops the worker. Later calls answer kClosed.
    void close() { terrain_client_close(client_); }

    /// A deformation centred at (x, y) metres of `radius` metres (a crater's footprint, rim
    /// included, is twice that): `height` and `strength` (in [0, 1]) as OpKind says. Refused at
    /// once, nothing sent: kNotConnected, kNotSynced, kBadParameter (the rule broken), kClosed.
    /// Sent: the id its answer (takeAnswers()) will carry; the server may still refuse it.
    ClientResult requestOp(
        OpKind kind, double x, double y, double radius, double height, double strength = 1.0) {
        std::uint32_t id = 0;
        ClientResult r = result(terrain_client_request_op(
            client_, static_cast<int>(kind), x, y, radius, height, strength, &id));
        r.request_id = id;
        return r;
    }
    /// A crater `depth` metres deep with a rim `rim_ratio * depth` high (0.375 puts the cavity's
    /// volume back as ejecta).
    ClientResult
    requestCrater(double x, double y, double radius, double depth, double rim_ratio = 0.3) {
        return requestOp(OpKind::kCrater, x, y, radius, depth, rim_ratio);
    }
    /// The server's answers that arrived since the last call.
    std::vector<OpAnswer> takeAnswers() {
        std::vector<OpAnswer> out;
        terrain_op_answer a;
        int got = 0;
        while (terrain_client_next_answer(client_, &a, &got) == TERRAIN_OK && got != 0)
            out.push_back({a.request_id, a.accepted != 0, a.seq, a.reason});
        return out;
    }

    WorldState world() const {
        terrain_world_state s;
        terrain_client_world(client_, &s);
        WorldState w;
        w.seq = s.seq;
        w.world_hash = s.world_hash;
        w.loaded = s.loaded != 0;
        w.live = s.live != 0;
        w.synced = s.synced != 0;
        w.closed = s.closed != 0;
        w.ops_applied = s.ops_applied;
        w.hash_mismatches = s.hash_mismatches;
        w.repairs = s.repairs;
        w.snapshots = s.snapshots;
        w.extent_x = s.extent_x;
        w.extent_y = s.extent_y;
        return w;
    }
    /// The last error (a refusal, a lost link, a give up); "" if none yet.
    std::string lastError() const { return terrain_client_last_error(client_); }
    /// The ground height at (x, y) metres in the replica (exact, not the mesh); false off the
    /// map or before the world is loaded.
    bool heightAt(double x, double y, double& height_out) const {
        return terrain_client_height_at(client_, x, y, &height_out) == TERRAIN_OK;
    }

    /// The camera in, the newest finished tiles out: hands the camera to the worker (which
    /// tessellates the newest one it has) and takes its newest finished tiles. `changed` (when
    /// given) says whether any tile changed. kNotSynced before the world is loaded.
    ClientResult tessellate(const Camera& camera, bool* changed = nullptr) {
        terrain_camera c;
        for (int i = 0; i < 3; ++i) {
            c.eye[i] = camera.eye[i];
            c.forward[i] = camera.forward[i];
            c.up[i] = camera.up[i];
        }
        c.fovy_radians = camera.fovy_radians;
        c.viewport_width = camera.viewport_width;
        c.viewport_height = camera.viewport_height;
        c.near_plane = camera.near_plane;
        int any = 0;
        ClientResult r = result(terrain_client_tessellate(client_, &c, &any));
        if (changed != nullptr)
            *changed = any != 0;
        return r;
    }
    /// Frames the tiles are behind the newest camera (0: the worker keeps up).
    std::uint64_t meshLag() const { return terrain_client_mesh_lag(client_); }
    /// The tessellation's error bound for the tiles held, at their camera (pixels).
    double meshErrorPixels() const { return terrain_client_mesh_error_pixels(client_); }

    /// Tiles (0 before the first tessellate() with a world).
    std::int32_t tileCount() const { return terrain_client_tile_count(client_); }
    /// A tile's buffers and changes; kBadParameter for a tile out of range.
    ClientResult tile(std::int32_t tile, TileBuffers& out) const {
        terrain_tile t;
        const ClientResult r = result(terrain_client_tile(client_, tile, &t));
        if (!r)
            return r;
        out.visible = t.visible != 0;
        out.vertices = t.vertices;
        out.vertex_count = t.vertex_count;
        out.indices = t.indices;
        out.index_count = t.index_count;
        out.indices_rewritten = t.indices_rewritten != 0;
        out.dirty_pages = t.dirty_pages;
        out.dirty_page_count = t.dirty_page_count;
        out.vertices_all_changed = t.vertices_all_changed != 0;
        out.vertex_runs = t.vertex_runs;
        out.vertex_run_count = t.vertex_run_count;
        return r;
    }
    /// Whether the tile changed since markUploaded(tile).
    bool tileChanged(std::int32_t tile) const {
        return terrain_client_tile_changed(client_, tile) != 0;
    }
    /// The game uploaded the tile's changes: they are forgotten.
    void markUploaded(std::int32_t tile) { terrain_client_mark_uploaded(client_, tile); }

    /// The C handle, for calls this class does not wrap.
    terrain_client* handle() const { return client_; }

  private:
    ClientResult result(terrain_status status) const {
        return detail::resultOf(status, terrain_client_last_error(client_));
    }

    terrain_client* client_ = nullptr;
};

} // namespace terrain::game
