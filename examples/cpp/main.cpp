// A game's first steps with the terrain client in C++17, built against the installed package
// (examples/cpp/CMakeLists.txt: find_package(terrain), terrain::client): join, fire craters
// where the camera looks, follow the world until the server's answers and ops are in, and copy
// the tiles' changes into "engine" buffers as an engine would upload them.
//
//   game_example HOST PORT TOKEN    prints "seq N hash H triangles T uploaded B" and exits 0

#include <terrain/game/client.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: game_example HOST PORT TOKEN\n");
        return 2;
    }
    terrain::game::ClientOptions options;
    options.host = argv[1];
    options.port = static_cast<std::uint16_t>(std::atoi(argv[2]));
    options.token = argv[3];
    options.give_up_seconds = 10.0;
    terrain::game::Client client(options);
    auto check = [](const terrain::game::ClientResult& r, const char* what) {
        if (!r) {
            std::fprintf(
                stderr, "game_example: %s: %s: %s\n", what, terrain::game::errorName(r.error),
                r.message.c_str());
            std::exit(1);
        }
    };
    check(client.connect(), "connect");
    check(client.waitSynced(20.0), "waitSynced");
    const terrain::game::WorldState start = client.world();

    terrain::game::Camera camera;
    camera.eye[0] = start.extent_x * 0.3;
    camera.eye[1] = start.extent_y * 0.3;
    camera.eye[2] = 60.0;
    camera.forward[0] = 1.0;
    camera.forward[1] = 1.0;
    camera.forward[2] = -0.6;

    // three craters ahead of the camera
    for (int i = 0; i < 3; ++i)
        check(
            client.requestCrater(
                start.extent_x * (0.45 + 0.05 * i), start.extent_y * 0.5, 3.0, 1.5),
            "requestCrater");

    // the engine's copies of the tiles: what it would keep in GPU buffers
    std::vector<std::vector<terrain::game::Vertex>> engine_vertices;
    std::vector<std::vector<std::uint32_t>> engine_indices;
    std::size_t uploaded = 0, answered = 0;
    for (int frame = 0; frame < 5000; ++frame) {
        check(client.pump(), "pump");
        check(client.tessellate(camera), "tessellate");
        for (const terrain::game::OpAnswer& a : client.takeAnswers()) {
            if (!a.accepted) {
                std::fprintf(stderr, "game_example: refused: %s\n", a.reason.c_str());
                return 1;
            }
            ++answered;
        }
        engine_vertices.resize(static_cast<std::size_t>(client.tileCount()));
        engine_indices.resize(static_cast<std::size_t>(client.tileCount()));
        for (std::int32_t t = 0; t < client.tileCount(); ++t) {
            if (!client.tileChanged(t))
                continue;
            terrain::game::TileBuffers b;
            check(client.tile(t, b), "tile");
            auto& v = engine_vertices[static_cast<std::size_t>(t)];
            auto& ix = engine_indices[static_cast<std::size_t>(t)];
            v.resize(b.vertex_count);
            ix.resize(b.index_count);
            // a real engine would copy only the dirty pages and runs; this one checks them too
            if (b.vertices_all_changed)
                std::memcpy(v.data(), b.vertices, b.vertex_count * sizeof(terrain::game::Vertex));
            for (std::uint32_t r = 0; r < b.vertex_run_count; ++r)
                std::memcpy(
                    v.data() + b.vertex_runs[r].begin, b.vertices + b.vertex_runs[r].begin,
                    (b.vertex_runs[r].end - b.vertex_runs[r].begin) *
                        sizeof(terrain::game::Vertex));
            const std::uint32_t per_page = terrain::game::Client::indicesPerPage();
            if (b.indices_rewritten)
                std::memcpy(ix.data(), b.indices, b.index_count * sizeof(std::uint32_t));
            for (std::uint32_t p = 0; p < b.dirty_page_count; ++p) {
                const std::uint32_t from = b.dirty_pages[p] * per_page;
                if (from >= b.index_count)
                    continue;
                const std::uint32_t n = std::min(per_page, b.index_count - from);
                std::memcpy(ix.data() + from, b.indices + from, n * sizeof(std::uint32_t));
            }
            uploaded += b.vertex_count;
            client.markUploaded(t);
        }
        const terrain::game::WorldState w = client.world();
        if (answered == 3 && w.synced && w.seq >= start.seq + 3 && client.meshLag() <= 1)
            break;
    }
    // the engine's copies equal the client's tiles, index for index and vertex for vertex
    std::size_t triangles = 0;
    for (std::int32_t t = 0; t < client.tileCount(); ++t) {
        terrain::game::TileBuffers b;
        check(client.tile(t, b), "tile");
        const auto& v = engine_vertices[static_cast<std::size_t>(t)];
        const auto& ix = engine_indices[static_cast<std::size_t>(t)];
        if (v.size() != b.vertex_count || ix.size() != b.index_count ||
            std::memcmp(v.data(), b.vertices, v.size() * sizeof(terrain::game::Vertex)) != 0 ||
            std::memcmp(ix.data(), b.indices, ix.size() * sizeof(std::uint32_t)) != 0) {
            std::fprintf(stderr, "game_example: tile %d: the engine's copy differs\n", t);
            return 1;
        }
        if (b.visible)
            triangles += b.index_count / 3;
    }
    const terrain::game::WorldState w = client.world();
    std::printf(
        "seq %llu hash %016llx triangles %zu uploaded %zu\n",
        static_cast<unsigned long long>(w.seq), static_cast<unsigned long long>(w.world_hash),
        triangles, uploaded);
    return answered == 3 && w.synced && triangles > 0 ? 0 : 1;
}
