// A client joining a grown world: from the snapshot's bytes to the first tessellated frame, and
// what the client holds then. The world is srtm_n44w072 after --craters random craters (radius
// 50-400 m, as net_bench's join), or a procedural map of --map-size vertices (--craters on it
// too). Built and encoded untimed; then, timed on this thread:
//   decode     decodeSnapshot (checks every invariant) and Replica::loadSnapshot
//   tessellate the Tessellator's construction (detail blocks, bounds) and its first update
// for a camera 300 m above the map's centre looking at it, 1280 x 720, tau 1 px, 400,000 cap.
// Memory: the tessellator's own count (memoryBytes) and the process's resident set (which
// includes the authority's copy of the world and the snapshot's bytes: a client holds neither).
// Exit status: 0; 2 on a bad option or a missing DEM when one was asked for.

#include "support/bench_facts.h"
#include "support/tessellator_memory.h"

#include <terrain/client/replica.h>
#include <terrain/genesis_delta.h>
#include <terrain/io/dem_import.h>
#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/tessellator.h>
#include <terrain/snapshot.h>
#include <terrain/surface_query.h>
#include <terrain/wire/compression.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#ifndef TERRAIN_DEM_DIR
#define TERRAIN_DEM_DIR "../shared/data/dem"
#endif

int main(int argc, char** argv) {
    using namespace terrain;
    CLI::App app{"client_join_bench: snapshot bytes to the first tessellated frame"};
    std::string world = "srtm";
    std::string dem_dir = TERRAIN_DEM_DIR;
    int map_size = 4097;
    int craters = 5000;
    std::string out;
    app.add_option("--world", world, "srtm | procedural")
        ->check(CLI::IsMember({"srtm", "procedural"}));
    app.add_option("--dem-dir", dem_dir, "folder holding srtm_n44w072/");
    app.add_option("--map-size", map_size, "procedural map size in vertices")
        ->check(CLI::Range(65, 8193));
    app.add_option("--craters", craters, "random craters before the join")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--out", out, "JSON report");
    CLI11_PARSE(app, argc, argv);

    std::optional<Terrain> authority;
    std::string name;
    if (world == "srtm") {
        const auto path = std::filesystem::path(dem_dir) / "srtm_n44w072";
        auto dem = io::importDem(path, {});
        if (!dem) {
            std::fprintf(
                stderr, "client_join_bench: cannot import %s: %s\n", path.c_str(),
                dem.error().message.c_str());
            return 2;
        }
        authority.emplace(std::move(dem->terrain));
        name = "srtm_n44w072";
    } else {
        ProceduralMapOptions map;
        map.width = map_size;
        map.height = map_size;
        auto t = makeProceduralMap(map);
        if (!t) {
            std::fprintf(stderr, "client_join_bench: %s\n", t.error().message.c_str());
            return 2;
        }
        authority.emplace(std::move(*t));
        name = "procedural " + std::to_string(map_size) + " x " + std::to_string(map_size);
    }
    const Terrain genesis = *authority; // what a client that ships the map holds
    CraterSeries series;
    series.seed = 7;
    series.count = craters;
    series.min_radius = 50.0;
    series.max_radius = 400.0;
    int applied = 0;
    for (const OpRequest& r : randomCraters(authority->spec(), series))
        if (auto op = quantizeOp(r, authority->spec()); op && authority->apply(*op))
            ++applied;
    const std::vector<std::uint8_t> bytes = encodeSnapshot(*authority, 0);
    // the same world for a client that holds its genesis: the delta, and its decode on it
    const std::vector<std::uint8_t> delta =
        encodeGenesisDelta(*authority, 0, authority->genesisHash());
    const std::size_t snapshot_zstd = wire::compress(bytes).size();
    const std::size_t delta_zstd = wire::compress(delta).size();
    std::int32_t tiles_differing = 0;
    for (std::int32_t tile = 0; tile < authority->spec().tileCount(); ++tile)
        tiles_differing += authority->differsFromGenesis(tile) ? 1 : 0;
    double delta_decode_ms = 0.0;
    {
        const auto td = bench::Clock::now();
        auto from_genesis = decodeGenesisDelta(delta, genesis);
        delta_decode_ms = bench::msSince(td);
        if (!from_genesis || from_genesis->terrain.worldHash() != authority->worldHash()) {
            std::fprintf(
                stderr, "client_join_bench: the genesis delta did not rebuild the world\n");
            return 2;
        }
    }
    const std::size_t rss_before = bench::residentBytes();

    const auto t0 = bench::Clock::now();
    auto snapshot = decodeSnapshot(bytes);
    if (!snapshot) {
        std::fprintf(stderr, "client_join_bench: %s\n", snapshot.error().message.c_str());
        return 2;
    }
    client::Replica replica;
    replica.loadSnapshot(std::move(*snapshot));
    replica.takeDirty();
    const double decode_ms = bench::msSince(t0);
    const auto t1 = bench::Clock::now();
    roam::TessellatorOptions to;
    to.tau_pixels = 1.0;
    to.max_triangles = 400'000;
    roam::Tessellator tess(replica.terrain(), to);
    const double build_ms = bench::msSince(t1);
    const WorldSpec& spec = replica.terrain().spec();
    roam::Camera c;
    c.viewport_width = 1280;
    c.viewport_height = 720;
    const double cx = spec.extentX() / 2;
    const double cy = spec.extentY() / 2;
    const double ground = surfaceHeight(replica.terrain(), cx, cy);
    c.eye = {cx - 300.0, cy - 300.0, ground + 300.0};
    c.forward = glm::dvec3(cx, cy, ground) - c.eye;
    const auto t2 = bench::Clock::now();
    const roam::FrameStats fs = tess.update(c);
    const double frame_ms = bench::msSince(t2);
    const double join_ms = bench::msSince(t0);
    const double tess_mib = bench::mib(tess.memoryBytes());
    const double rss_mib = bench::mib(bench::residentBytes());

    nlohmann::ordered_json report{
        {"benchmark", "client_join_bench"},
        {"date", bench::isoNow()},
        {"cpu", bench::cpuModel()},
        {"world", name},
        {"craters", applied},
        {"patches", replica.terrain().patchCount()},
        {"snapshot_mib", bench::mib(bytes.size())},
        {"snapshot_zstd_mib", bench::mib(snapshot_zstd)},
        {"tiles", authority->spec().tileCount()},
        {"tiles_differing", tiles_differing},
        {"genesis_delta_mib", bench::mib(delta.size())},
        {"genesis_delta_zstd_mib", bench::mib(delta_zstd)},
        {"genesis_delta_decode_ms", delta_decode_ms},
        {"decode_ms", decode_ms},
        {"tessellator_build_ms", build_ms},
        {"first_update_ms", frame_ms},
        {"join_to_first_frame_ms", join_ms},
        {"triangles", fs.triangles},
        {"detail_blocks", tess.blockCount()},
        {"tessellator_mib", tess_mib},
        {"tessellator_memory_mib", bench::tessellatorMemoryJson(tess)},
        {"rss_mib", rss_mib},
        {"rss_before_join_mib", bench::mib(rss_before)},
        {"goals", {{"join_le_1s", join_ms <= 1000.0}, {"tessellator_le_64mb", tess_mib <= 64.0}}}};
    std::printf(
        "client_join_bench: %s, %d craters, %zu patches, snapshot %.1f MiB\n"
        "  join to first frame %.0f ms (decode %.0f, tessellator %.0f, first update %.0f); "
        "%lld triangles\n"
        "  tessellator %.1f MiB (%d detail blocks); RSS %.1f MiB (%.1f before the join)\n",
        name.c_str(), applied, static_cast<std::size_t>(replica.terrain().patchCount()),
        bench::mib(bytes.size()), join_ms, decode_ms, build_ms, frame_ms,
        static_cast<long long>(fs.triangles), tess_mib, tess.blockCount(), rss_mib,
        bench::mib(rss_before));
    std::printf(
        "  on the wire (zstd 1): snapshot %.2f MiB, genesis delta %.2f MiB (%d of %d tiles; "
        "decode on the genesis %.0f ms)\n",
        bench::mib(snapshot_zstd), bench::mib(delta_zstd), tiles_differing,
        authority->spec().tileCount(), delta_decode_ms);
    bench::printTessellatorMemory(tess);
    if (!out.empty()) {
        std::ofstream file(out);
        if (!file) {
            std::fprintf(stderr, "client_join_bench: cannot write %s\n", out.c_str());
            return 2;
        }
        file << report.dump(2) << "\n";
    }
    return 0;
}
