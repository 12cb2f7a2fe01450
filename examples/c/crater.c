/* A game's first steps with the terrain client, in plain C99 against libterrain_client.so:
 * join a server, wait for the world, fire a crater where the camera looks, follow the ops until
 * the server's answer and the op have arrived, tessellate, read a tile's buffers.
 *
 *   crater HOST PORT TOKEN      prints "seq N hash H triangles T" and exits 0, else 1
 */
#include <stdio.h>
#include <stdlib.h>
#include <terrain_client.h>

static int fail(terrain_client* c, terrain_status s, const char* what) {
    fprintf(
        stderr, "crater: %s: %s: %s\n", what, terrain_status_name(s), terrain_client_last_error(c));
    terrain_client_destroy(c);
    return 1;
}

int main(int argc, char** argv) {
    terrain_client_options options;
    terrain_client* client = NULL;
    terrain_world_state world;
    terrain_camera camera;
    terrain_op_answer answer;
    terrain_status s;
    uint32_t request = 0;
    int answered = 0, changed = 0, frame, got;
    int32_t tile;
    long triangles = 0;

    if (argc != 4) {
        fprintf(stderr, "usage: crater HOST PORT TOKEN\n");
        return 2;
    }
    terrain_client_options_init(&options);
    options.host = argv[1];
    options.port = (uint16_t)atoi(argv[2]);
    options.token = argv[3];
    options.give_up_seconds = 10.0;
    if ((s = terrain_client_create(&options, &client)) != TERRAIN_OK)
        return fail(client, s, "create");
    if ((s = terrain_client_connect(client)) != TERRAIN_OK)
        return fail(client, s, "connect");
    if ((s = terrain_client_wait_synced(client, 20.0)) != TERRAIN_OK)
        return fail(client, s, "wait_synced");
    terrain_client_world(client, &world);

    /* a camera 30 m above the map's corner region, looking across it */
    terrain_camera_init(&camera);
    camera.eye[0] = 20.0;
    camera.eye[1] = 20.0;
    camera.eye[2] = 70.0;
    camera.forward[0] = 1.0;
    camera.forward[1] = 1.0;
    camera.forward[2] = -0.5;

    /* a crater 3 m wide, 1.5 m deep, in the middle of the map */
    s = terrain_client_request_op(
        client, TERRAIN_OP_CRATER, world.extent_x / 2, world.extent_y / 2, 3.0, 1.5, 0.3, &request);
    if (s != TERRAIN_OK)
        return fail(client, s, "request_op");

    /* the frame loop: pump, tessellate, look for the answer, until the op is in the world */
    for (frame = 0; frame < 5000; ++frame) {
        if ((s = terrain_client_pump(client)) != TERRAIN_OK)
            return fail(client, s, "pump");
        if ((s = terrain_client_tessellate(client, &camera, &changed)) != TERRAIN_OK)
            return fail(client, s, "tessellate");
        while (terrain_client_next_answer(client, &answer, &got) == TERRAIN_OK && got) {
            if (answer.request_id != request)
                continue;
            if (!answer.accepted) {
                fprintf(stderr, "crater: refused: %s\n", answer.reason);
                terrain_client_destroy(client);
                return 1;
            }
            answered = 1;
        }
        terrain_client_world(client, &world);
        if (answered && world.synced && world.seq >= 1)
            break;
    }
    if (!answered || !world.synced)
        return fail(client, TERRAIN_TIMED_OUT, "the crater did not come back");

    /* the tiles an engine would upload: the visible ones' triangles */
    for (tile = 0; tile < terrain_client_tile_count(client); ++tile) {
        terrain_tile t;
        if ((s = terrain_client_tile(client, tile, &t)) != TERRAIN_OK)
            return fail(client, s, "tile");
        if (t.visible)
            triangles += (long)(t.index_count / 3);
        terrain_client_mark_uploaded(client, tile);
    }
    printf(
        "seq %llu hash %016llx triangles %ld\n", (unsigned long long)world.seq,
        (unsigned long long)world.world_hash, triangles);
    terrain_client_destroy(client);
    return triangles > 0 ? 0 : 1;
}
