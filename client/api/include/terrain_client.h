/* The terrain client's C ABI (C99; also C++17): what a game, an engine on another toolchain or
 * another language (ctypes, P/Invoke, GDExtension) calls. libterrain_client.so exports these
 * functions and nothing else.
 *
 * One terrain_client joins a terrain server, keeps the world's replica exact (every op applied
 * and its world hash checked; repairs and snapshots when not), sends the player's deformations,
 * and tessellates the terrain for the game's camera on a worker thread, handing over per-tile
 * vertex and index buffers with what changed since the game last uploaded them.
 *
 * Rules:
 * - Every function returns a terrain_status (or a value that cannot fail); on an error,
 *   terrain_client_last_error() names the rule broken. No C++ exception crosses this ABI.
 * - A client is used from one thread at a time (the game's frame loop); different clients are
 *   independent. The tessellation runs on the client's own worker thread.
 * - After terrain_client_close(), every call answers TERRAIN_CLOSED. terrain_client_destroy()
 *   frees the client; the handle is then gone.
 * - Pointers handed out (tile buffers, messages) stay valid until the next call on the same
 *   client that changes them: terrain_client_tessellate() for tiles, any call for messages.
 *
 * Coordinates: metres, x east and y north from the map's corner (vertex 0, 0), z up. A y-up
 * engine swaps y and z (and flips the winding, which is counter-clockwise seen from above).
 *
 * The frame loop (see docs/EMBEDDING.md):
 *   terrain_client_options o; terrain_client_options_init(&o); o.host = ...; o.token = ...;
 *   terrain_client_create(&o, &c); terrain_client_connect(c); terrain_client_wait_synced(c, 10);
 *   each frame: terrain_client_pump(c); terrain_client_tessellate(c, &camera, &changed);
 *               for each tile t with terrain_client_tile_changed(c, t): terrain_client_tile(),
 *               upload its dirty pages and vertex runs, terrain_client_mark_uploaded(c, t);
 *   terrain_client_destroy(c);
 */
#ifndef TERRAIN_CLIENT_H
#define TERRAIN_CLIENT_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32) && defined(TERRAIN_CLIENT_BUILD)
#define TERRAIN_API __declspec(dllexport)
#elif defined(_WIN32)
#define TERRAIN_API __declspec(dllimport)
#else
#define TERRAIN_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* This header's ABI version; terrain_abi_version() is the library's. 2 added the replica on its
 * own (terrain_replica.h), the statuses BAD_DATA and SEQ_GAP, and options.network_thread (so a
 * program built against 1 must be rebuilt). */
#define TERRAIN_CLIENT_ABI_VERSION 2u

typedef enum terrain_status {
    TERRAIN_OK = 0,
    TERRAIN_BAD_PARAMETER = 1,     /* an argument breaks a rule (the message names it) */
    TERRAIN_NOT_CONNECTED = 2,     /* no link to the server is up: nothing was sent */
    TERRAIN_NOT_SYNCED = 3,        /* no world yet (the first join has not completed) */
    TERRAIN_TIMED_OUT = 4,         /* a wait ran out, or the client gave up (CONNECT_TIMEOUT) */
    TERRAIN_CLOSED = 5,            /* closed (terrain_client_close or a final refusal) */
    TERRAIN_REFUSED_BY_SERVER = 6, /* bad token, wrong version, ... (the message says which) */
    TERRAIN_INTERNAL = 7,          /* out of memory or a bug: the message says what was thrown */
    TERRAIN_BAD_DATA = 8,          /* bytes or an op that a rule refuses (terrain_replica.h) */
    TERRAIN_SEQ_GAP = 9            /* an op past seq + 1: ops were missed (terrain_replica.h) */
} terrain_status;

/* Op kinds: the wire's kind + 1, as in the journal (0 is no kind). */
typedef enum terrain_op_kind {
    TERRAIN_OP_CRATER = 1,  /* a bowl `height` deep, its rim `strength * height` high */
    TERRAIN_OP_RAISE = 2,   /* a smooth mound of signed height `height` */
    TERRAIN_OP_FLATTEN = 3, /* towards the absolute level `height` by `strength` */
    TERRAIN_OP_SMOOTH = 4   /* towards the neighbours' average by `strength` */
} terrain_op_kind;

typedef struct terrain_client terrain_client;

typedef struct terrain_client_options {
    const char* host;               /* "127.0.0.1" */
    uint16_t port;                  /* 7777 */
    const char* token;              /* the server's signed token for this player (required) */
    const char* client_name;        /* "game" */
    double connect_timeout_seconds; /* 5: an attempt's TCP connect is abandoned after this */
    double give_up_seconds;         /* 30: no live link for this long closes the client; 0: never */
    int reconnect;                  /* 1: reconnect (resume) when a live link drops */
    int ops_per_frame;              /* 2: ops applied per pump at least; 0: all as they arrive
                                       (not with network_thread: applied there, unpaced) */
    int catch_up_frames;            /* 8: a backlog is applied within this many pumps */
    double tau_pixels;              /* 1: the tessellation's screen-space error bound */
    int64_t max_triangles;          /* 400000: the triangle cap */
    uint32_t worker_threads;        /* 0: min(cores - 1, 4) */
    int network_thread; /* 0: pump() reads the network; 1: the client's own thread does (ABI 2) */
} terrain_client_options;

typedef struct terrain_world_state {
    uint64_t seq;        /* the last op applied */
    uint64_t world_hash; /* the replica's world hash at seq (the server's at the same seq) */
    int loaded, live, synced, closed;
    uint64_t ops_applied, hash_mismatches, repairs, snapshots;
    double extent_x, extent_y; /* the map's size in metres */
} terrain_world_state;

typedef struct terrain_op_answer {
    uint32_t request_id;
    int accepted;
    uint64_t seq;       /* accepted: the op's seq */
    const char* reason; /* refused: "REASON_...: message"; "" when accepted */
} terrain_op_answer;

typedef struct terrain_camera {
    double eye[3];
    double forward[3]; /* need not be unit length */
    double up[3];
    double fovy_radians;
    int viewport_width, viewport_height;
    double near_plane; /* metres */
} terrain_camera;

/* 16 bytes: metres, and the unit normal packed as signed 10:10:10:2 (x bits 0-9, y 10-19, z 20-29,
 * two's complement over 511; GL_INT_2_10_10_10_REV normalised). */
typedef struct terrain_vertex {
    float x, y, z;
    uint32_t normal;
} terrain_vertex;

typedef struct terrain_vertex_run {
    uint32_t begin, end; /* [begin, end) of the tile's vertices */
} terrain_vertex_run;

/* One tile's buffers and what changed since terrain_client_mark_uploaded(). Dirty index pages
 * hold terrain_indices_per_page() indices each: [page * n, min((page + 1) * n, index_count)).
 * The vertices are those the tile's triangles use, each at a slot of its own while used; a slot
 * no index refers to (free for the next vertex) holds an old vertex or a point of the tile: draw
 * by index. */
typedef struct terrain_tile {
    int visible; /* in the camera's view: draw only these */
    const terrain_vertex* vertices;
    uint32_t vertex_count;
    const uint32_t* indices; /* three per triangle */
    uint32_t index_count;
    int indices_rewritten; /* upload every index */
    const uint32_t* dirty_pages;
    uint32_t dirty_page_count;
    int vertices_all_changed;              /* upload every vertex */
    const terrain_vertex_run* vertex_runs; /* they may overlap */
    uint32_t vertex_run_count;
} terrain_tile;

TERRAIN_API uint32_t terrain_abi_version(void);
/* "OK", "BAD_PARAMETER", ... for a terrain_status; "UNKNOWN" for any other value. */
TERRAIN_API const char* terrain_status_name(int status);
/* Indices per dirty page. */
TERRAIN_API uint32_t terrain_indices_per_page(void);

/* The defaults above. */
TERRAIN_API void terrain_client_options_init(terrain_client_options* options);
TERRAIN_API void terrain_camera_init(terrain_camera* camera);

/* Makes a client (the options are copied; nothing connects yet). */
TERRAIN_API terrain_status
terrain_client_create(const terrain_client_options* options, terrain_client** out);
/* Closes and frees; NULL is allowed. */
TERRAIN_API void terrain_client_destroy(terrain_client* client);
/* The message of the last call that failed on this client, or why it closed; "" if none. */
TERRAIN_API const char* terrain_client_last_error(const terrain_client* client);

/* Starts connecting (returns at once); BAD_PARAMETER names an option that breaks a rule. */
TERRAIN_API terrain_status terrain_client_connect(terrain_client* client);
/* Pumps until synced, up to timeout_seconds: TIMED_OUT, or why the client closed. */
TERRAIN_API terrain_status
terrain_client_wait_synced(terrain_client* client, double timeout_seconds);
/* Once a frame: the network, and this frame's share of the ops. */
TERRAIN_API terrain_status terrain_client_pump(terrain_client* client);
/* Closes the link for good and stops the worker; later calls answer CLOSED. */
TERRAIN_API void terrain_client_close(terrain_client* client);

TERRAIN_API terrain_status
terrain_client_world(const terrain_client* client, terrain_world_state* out);
/* The exact ground height at (x, y) metres; BAD_PARAMETER off the map, NOT_SYNCED before a world.
 */
TERRAIN_API terrain_status
terrain_client_height_at(const terrain_client* client, double x, double y, double* height_out);

/* Sends a deformation of kind `kind` (a terrain_op_kind, passed as an int so that any value a
 * foreign caller passes is checked, not undefined); refused at once (nothing sent) with
 * NOT_CONNECTED, NOT_SYNCED, BAD_PARAMETER or CLOSED. request_id (may be NULL) gets the id its
 * answer will carry. With network_thread, the thread sends it: if the link drops before it
 * does, the answer is the refusal (NOT_CONNECTED); as without it, a request sent on a link that
 * then drops gets no answer. */
TERRAIN_API terrain_status terrain_client_request_op(
    terrain_client* client,
    int kind,
    double x,
    double y,
    double radius,
    double height,
    double strength,
    uint32_t* request_id);
/* The next answer from the server, if any: *got 1 and *out filled (its reason valid until the
 * next call on the client), else *got 0. */
TERRAIN_API terrain_status
terrain_client_next_answer(terrain_client* client, terrain_op_answer* out, int* got);

/* The camera in, the newest finished tiles out; *changed (may be NULL) says whether any tile
 * changed. NOT_SYNCED before a world. */
TERRAIN_API terrain_status
terrain_client_tessellate(terrain_client* client, const terrain_camera* camera, int* changed);
/* Frames the tiles are behind the newest camera, and their error bound (pixels). */
TERRAIN_API uint64_t terrain_client_mesh_lag(const terrain_client* client);
TERRAIN_API double terrain_client_mesh_error_pixels(const terrain_client* client);
/* Tiles (0 before the first tessellate with a world). */
TERRAIN_API int32_t terrain_client_tile_count(const terrain_client* client);
TERRAIN_API terrain_status
terrain_client_tile(const terrain_client* client, int32_t tile, terrain_tile* out);
/* 1 if the tile changed since it was last marked uploaded, else 0 (also for a bad tile). */
TERRAIN_API int terrain_client_tile_changed(const terrain_client* client, int32_t tile);
TERRAIN_API terrain_status terrain_client_mark_uploaded(terrain_client* client, int32_t tile);

#ifdef __cplusplus
}
#endif

#endif /* TERRAIN_CLIENT_H */
