// The C ABI (terrain_client.h) over the game client's Session: argument checks, status codes,
// messages kept per client, and no exception across it.

#include "abi_guard.h"
#include "game_session.h"

#include <terrain_client.h>

#include <cmath>
#include <deque>
#include <string>
#include <utility>

using terrain::game::ClientError;
using terrain::game::ClientResult;
using terrain::game::detail::Session;

struct terrain_client {
    explicit terrain_client(terrain::game::ClientOptions options) : session(std::move(options)) {}
    Session session;
    std::deque<terrain::game::OpAnswer> answers; // arrived, not handed out yet
    std::string answer_reason;                   // the reason of the answer last handed out
};

namespace {

terrain_status statusOf(ClientError e) {
    return static_cast<terrain_status>(e);
}

terrain_status report(terrain_client* c, const ClientResult& r) {
    if (!r)
        c->session.noteError(r.message);
    return statusOf(r.error);
}

terrain_status badArgument(terrain_client* c, const char* what) {
    if (c != nullptr)
        c->session.noteError(what);
    return TERRAIN_BAD_PARAMETER;
}

// Runs `f` with every exception turned into TERRAIN_INTERNAL and its message kept.
template <typename F> terrain_status guarded(terrain_client* c, F&& f) {
    return terrain::game::detail::guardedCall(
        [c](std::string message) {
            if (c != nullptr)
                c->session.noteError(std::move(message));
        },
        std::forward<F>(f));
}

} // namespace

extern "C" {

uint32_t terrain_abi_version(void) {
    return TERRAIN_CLIENT_ABI_VERSION;
}

const char* terrain_status_name(int status) {
    switch (status) {
    case TERRAIN_OK:
        return "OK";
    case TERRAIN_BAD_PARAMETER:
        return "BAD_PARAMETER";
    case TERRAIN_NOT_CONNECTED:
        return "NOT_CONNECTED";
    case TERRAIN_NOT_SYNCED:
        return "NOT_SYNCED";
    case TERRAIN_TIMED_OUT:
        return "TIMED_OUT";
    case TERRAIN_CLOSED:
        return "CLOSED";
    case TERRAIN_REFUSED_BY_SERVER:
        return "REFUSED_BY_SERVER";
    case TERRAIN_INTERNAL:
        return "INTERNAL";
    case TERRAIN_BAD_DATA:
        return "BAD_DATA";
    case TERRAIN_SEQ_GAP:
        return "SEQ_GAP";
    }
    return "UNKNOWN";
}

uint32_t terrain_indices_per_page(void) {
    return Session::kIndicesPerPage;
}

void terrain_client_options_init(terrain_client_options* o) {
    if (o == nullptr)
        return;
    const terrain::game::ClientOptions d;
    o->host = "127.0.0.1";
    o->port = d.port;
    o->token = "";
    o->client_name = "game";
    o->connect_timeout_seconds = d.connect_timeout_seconds;
    o->give_up_seconds = d.give_up_seconds;
    o->reconnect = d.reconnect ? 1 : 0;
    o->ops_per_frame = d.ops_per_frame;
    o->catch_up_frames = d.catch_up_frames;
    o->tau_pixels = d.tau_pixels;
    o->max_triangles = d.max_triangles;
    o->worker_threads = d.worker_threads;
    o->network_thread = d.network_thread ? 1 : 0;
}

void terrain_camera_init(terrain_camera* c) {
    if (c == nullptr)
        return;
    const terrain::game::Camera d;
    for (int i = 0; i < 3; ++i) {
        c->eye[i] = d.eye[i];
        c->forward[i] = d.forward[i];
        c->up[i] = d.up[i];
    }
    c->fovy_radians = d.fovy_radians;
    c->viewport_width = d.viewport_width;
    c->viewport_height = d.viewport_height;
    c->near_plane = d.near_plane;
}

terrain_status terrain_client_create(const terrain_client_options* o, terrain_client** out) {
    if (out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    *out = nullptr;
    if (o == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(nullptr, [&] {
        terrain::game::ClientOptions options;
        // NULL strings are empty ones: connect() names the rule they break
        options.host = o->host != nullptr ? o->host : "";
        options.port = o->port;
        options.token = o->token != nullptr ? o->token : "";
        options.client_name = o->client_name != nullptr ? o->client_name : "";
        options.connect_timeout_seconds = o->connect_timeout_seconds;
        options.give_up_seconds = o->give_up_seconds;
        options.reconnect = o->reconnect != 0;
        options.ops_per_frame = o->ops_per_frame;
        options.catch_up_frames = o->catch_up_frames;
        options.tau_pixels = o->tau_pixels;
        options.max_triangles = o->max_triangles;
        options.worker_threads = o->worker_threads;
        options.network_thread = o->network_thread != 0;
        *out = new terrain_client(std::move(options));
        return TERRAIN_OK;
    });
}

void terrain_client_destroy(terrain_client* c) {
    if (c == nullptr)
        return;
    guarded(c, [&] {
        c->session.close();
        return TERRAIN_OK;
    });
    delete c;
}

const char* terrain_client_last_error(const terrain_client* c) {
    if (c == nullptr)
        return "BAD_PARAMETER: client is NULL";
    return c->session.lastError().c_str();
}

terrain_status terrain_client_connect(terrain_client* c) {
    if (c == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(c, [&] { return report(c, c->session.connect()); });
}

terrain_status terrain_client_wait_synced(terrain_client* c, double timeout_seconds) {
    if (c == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(c, [&] { return report(c, c->session.waitSynced(timeout_seconds)); });
}

terrain_status terrain_client_pump(terrain_client* c) {
    if (c == nullptr)
        return TERRAIN_BAD_PARAMETER;
    return guarded(c, [&] { return report(c, c->session.pump()); });
}

void terrain_client_close(terrain_client* c) {
    if (c == nullptr)
        return;
    guarded(c, [&] {
        c->session.close();
        return TERRAIN_OK;
    });
}

terrain_status terrain_client_world(const terrain_client* c, terrain_world_state* out) {
    if (c == nullptr || out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    const terrain::game::WorldState w = c->session.world();
    out->seq = w.seq;
    out->world_hash = w.world_hash;
    out->loaded = w.loaded ? 1 : 0;
    out->live = w.live ? 1 : 0;
    out->synced = w.synced ? 1 : 0;
    out->closed = w.closed ? 1 : 0;
    out->ops_applied = w.ops_applied;
    out->hash_mismatches = w.hash_mismatches;
    out->repairs = w.repairs;
    out->snapshots = w.snapshots;
    out->extent_x = w.extent_x;
    out->extent_y = w.extent_y;
    return TERRAIN_OK;
}

terrain_status
terrain_client_height_at(const terrain_client* c, double x, double y, double* height_out) {
    if (c == nullptr || height_out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    if (!c->session.world().loaded)
        return TERRAIN_NOT_SYNCED;
    return c->session.heightAt(x, y, *height_out) ? TERRAIN_OK : TERRAIN_BAD_PARAMETER;
}

terrain_status terrain_client_request_op(
    terrain_client* c,
    int kind,
    double x,
    double y,
    double radius,
    double height,
    double strength,
    uint32_t* request_id) {
    if (c == nullptr)
        return TERRAIN_BAD_PARAMETER;
    if (request_id != nullptr)
        *request_id = 0;
    return guarded(c, [&] {
        const ClientResult r = c->session.requestOp(
            static_cast<terrain::game::OpKind>(kind), x, y, radius, height, strength);
        if (r && request_id != nullptr)
            *request_id = r.request_id;
        return report(c, r);
    });
}

terrain_status terrain_client_next_answer(terrain_client* c, terrain_op_answer* out, int* got) {
    if (c == nullptr)
        return TERRAIN_BAD_PARAMETER;
    if (out == nullptr || got == nullptr)
        return badArgument(c, "BAD_PARAMETER: out and got must not be NULL");
    return guarded(c, [&] {
        for (terrain::game::OpAnswer& a : c->session.takeAnswers())
            c->answers.push_back(std::move(a));
        *got = 0;
        if (c->answers.empty())
            return TERRAIN_OK;
        const terrain::game::OpAnswer& a = c->answers.front();
        c->answer_reason = a.reason;
        out->request_id = a.request_id;
        out->accepted = a.accepted ? 1 : 0;
        out->seq = a.seq;
        out->reason = c->answer_reason.c_str();
        c->answers.pop_front();
        *got = 1;
        return TERRAIN_OK;
    });
}

terrain_status
terrain_client_tessellate(terrain_client* c, const terrain_camera* camera, int* changed) {
    if (c == nullptr)
        return TERRAIN_BAD_PARAMETER;
    if (changed != nullptr)
        *changed = 0;
    if (camera == nullptr)
        return badArgument(c, "BAD_PARAMETER: camera must not be NULL");
    return guarded(c, [&] {
        terrain::game::Camera cam;
        for (int i = 0; i < 3; ++i) {
            cam.eye[i] = camera->eye[i];
            cam.forward[i] = camera->forward[i];
            cam.up[i] = camera->up[i];
        }
        cam.fovy_radians = camera->fovy_radians;
        cam.viewport_width = camera->viewport_width;
        cam.viewport_height = camera->viewport_height;
        cam.near_plane = camera->near_plane;
        bool any = false;
        const terrain_status s = report(c, c->session.tessellate(cam, &any));
        if (changed != nullptr)
            *changed = any ? 1 : 0;
        return s;
    });
}

uint64_t terrain_client_mesh_lag(const terrain_client* c) {
    return c != nullptr ? c->session.meshLag() : 0;
}

double terrain_client_mesh_error_pixels(const terrain_client* c) {
    return c != nullptr ? c->session.meshErrorPixels() : 0.0;
}

int32_t terrain_client_tile_count(const terrain_client* c) {
    return c != nullptr ? c->session.tileCount() : 0;
}

terrain_status terrain_client_tile(const terrain_client* c, int32_t tile, terrain_tile* out) {
    if (c == nullptr || out == nullptr)
        return TERRAIN_BAD_PARAMETER;
    terrain::game::TileBuffers b;
    const ClientResult r = c->session.tile(tile, b);
    if (!r) {
        // the message is not the tile's state: noting it is allowed on a const client
        const_cast<terrain_client*>(c)->session.noteError(r.message);
        return statusOf(r.error);
    }
    out->visible = b.visible ? 1 : 0;
    out->vertices = b.vertices;
    out->vertex_count = b.vertex_count;
    out->indices = b.indices;
    out->index_count = b.index_count;
    out->indices_rewritten = b.indices_rewritten ? 1 : 0;
    out->dirty_pages = b.dirty_pages;
    out->dirty_page_count = b.dirty_page_count;
    out->vertices_all_changed = b.vertices_all_changed ? 1 : 0;
    out->vertex_runs = b.vertex_runs;
    out->vertex_run_count = b.vertex_run_count;
    return TERRAIN_OK;
}

int terrain_client_tile_changed(const terrain_client* c, int32_t tile) {
    return c != nullptr && c->session.tileChanged(tile) ? 1 : 0;
}

terrain_status terrain_client_mark_uploaded(terrain_client* c, int32_t tile) {
    if (c == nullptr)
        return TERRAIN_BAD_PARAMETER;
    if (tile < 0 || tile >= c->session.tileCount())
        return badArgument(c, "BAD_PARAMETER: tile out of range");
    c->session.markUploaded(tile);
    return TERRAIN_OK;
}

} // extern "C"
