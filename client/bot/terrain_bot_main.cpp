// terrain-bot: a headless client for tests, load and the demo.
//   terrain-bot [run] --connect host:port --token T [options]   fly, blast, report (JSON)
//   terrain-bot table a.json b.json ...                          compare reports; exit 1 unless
//                                                                 every one holds the same world

#include <terrain/bot/bot.h>
#include <terrain/io/dem_import.h>
#include <terrain/procedural_map.h>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <limits>

namespace {

using namespace terrain;

Result<std::uint16_t> parseEndpoint(const std::string& endpoint, std::string& host) {
    const std::size_t colon = endpoint.rfind(':');
    if (colon == std::string::npos || colon == 0)
        return makeError(
            ErrorCode::kBadFormat, "--connect must be host:port, got '" + endpoint + "'");
    host = endpoint.substr(0, colon);
    const std::string port_text = endpoint.substr(colon + 1);
    char* end = nullptr;
    const unsigned long port = std::strtoul(port_text.c_str(), &end, 10);
    if (port_text.empty() || *end != '\0' || port == 0 || port > 65535)
        return makeError(
            ErrorCode::kOutOfRange, "--connect port must be 1..65535, got '" + port_text + "'");
    return static_cast<std::uint16_t>(port);
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"terrain-bot: headless terrain client (scripted flight, craters, report)"};
    app.require_subcommand(0, 1);
    bot::BotConfig config;
    std::string connect = "127.0.0.1:7777";
    std::string report_path;
    std::string backend_name = "osmesa";
    std::string upload_path = "auto";
    std::vector<std::string> tables;
    // the map the bot ships with: terrain-server's --seed/--size/--tolerance or --dem
    std::string map_dem;
    ProceduralMapOptions map;
    bool map_procedural = false;

    CLI::App* run = app.add_subcommand("run", "fly the script against a server (the default)");
    for (CLI::App* a : {static_cast<CLI::App*>(&app), run}) {
        // options live on the top level too, so `terrain-bot --connect ...` works without `run`
        a->add_option("--connect", connect, "server host:port")->envname("TERRAIN_CONNECT");
        a->add_option("--token", config.token, "access token (terrain-server token)")
            ->envname("TERRAIN_TOKEN");
        a->add_option("--name", config.name, "label in reports");
        a->add_option("--seed", config.script.seed, "script seed: focus point, flight, shots");
        a->add_option("--frames", config.script.frames, "frames to fly")
            ->check(CLI::Range(1, 1000000));
        a->add_option("--craters", config.script.craters, "craters to blast over the run")
            ->check(CLI::Range(0, 100000));
        a->add_option("--width", config.script.viewport_width)->check(CLI::Range(16, 8192));
        a->add_option("--height", config.script.viewport_height)->check(CLI::Range(16, 8192));
        a->add_option("--tau", config.tau_pixels, "screen-space error bound, pixels")
            ->check(CLI::PositiveNumber);
        a->add_option("--max-triangles", config.max_triangles, "triangle cap (0: none)")
            ->check(CLI::NonNegativeNumber);
        a->add_option(
             "--frame-ms", config.frame_ms,
             "frame time to hold by lowering the triangle cap (0: off; default 50 when "
             "rendering, off otherwise)")
            ->check(CLI::NonNegativeNumber);
        a->add_option(
             "--fps", config.fps,
             "frames a second to keep, sleeping out the rest of each frame as a game does (0: as "
             "fast as they go)")
            ->check(CLI::Range(0.0, 1000.0));
        a->add_option(
             "--ops-per-frame", config.ops_per_frame,
             "ops applied per frame at least; a burst waits for the next frames (0: each op as "
             "it arrives)")
            ->check(CLI::NonNegativeNumber);
        a->add_option(
            "--barrier", config.barrier_dir,
            "directory where bots started together meet before settling");
        a->add_option("--peers", config.peers, "bots meeting at --barrier, this one included")
            ->check(CLI::Range(1, 100000));
        a->add_option("--orbit", config.script.orbit_radius_metres, "orbit radius, metres")
            ->check(CLI::PositiveNumber);
        a->add_option("--altitude", config.script.altitude_metres, "above the focus, metres")
            ->check(CLI::PositiveNumber);
        a->add_flag("--render", config.render, "render every frame offscreen");
        a->add_flag(
            "!--sync-tessellation", config.async_tessellation,
            "tessellate on the frame thread (default: on a worker thread; the frame never waits)");
        a->add_option("--gl", backend_name, "offscreen backend: osmesa | egl")
            ->check(CLI::IsMember({"osmesa", "egl"}));
        a->add_flag(
            "--gl-debug", config.gl_debug,
            "a debug GL context: every KHR_debug message to stderr, errors in the report");
        a->add_flag(
            "--validate-buffers", config.validate_buffers,
            "read the GPU buffers back after every sync and compare them with the mesh (slow)");
        a->add_option("--upload-path", upload_path, "auto | persistent | map-range")
            ->check(CLI::IsMember({"auto", "persistent", "map-range"}));
        a->add_option(
             "--upload-budget", config.upload_budget_bytes,
             "bytes of mesh changes a frame may upload; the rest waits (default 2 MiB, 0: none)")
            ->check(CLI::NonNegativeNumber);
        a->add_option(
            "--png-dir", config.png_dir, "write before.png and after.png here (implies --render)");
        a->add_option("--png-every", config.png_every, "also write every Nth frame")
            ->check(CLI::NonNegativeNumber);
        a->add_option("--settle", config.settle_seconds, "quiet seconds that end the run")
            ->check(CLI::NonNegativeNumber);
        a->add_option("--join-timeout", config.join_timeout_seconds, "seconds to join the server")
            ->check(CLI::PositiveNumber);
        a->add_option("--report", report_path, "write the JSON report here (default: stdout)");
        a->add_option(
            "--map-dem", map_dem,
            "ship this DEM (the server's --dem): join by genesis delta when it is the server's");
        a->add_flag(
            "--map", map_procedural,
            "ship the procedural map of --map-seed/--map-size/--map-tolerance (the server's "
            "--seed/--size/--tolerance): join by genesis delta when it is the server's");
        a->add_option("--map-seed", map.seed, "with --map: the server's --seed");
        a->add_option("--map-size", map.width, "with --map: the server's --size")
            ->check(CLI::Range(65, 8193));
        a->add_option("--map-tolerance", map.patch_tolerance_metres, "with --map: --tolerance")
            ->check(CLI::Range(1.0 / 1024, 10.0));
    }
    CLI::App* table = app.add_subcommand("table", "compare reports: exit 1 unless all agree");
    table->add_option("reports", tables, "report files")->required()->check(CLI::ExistingFile);
    CLI11_PARSE(app, argc, argv);

    if (table->parsed()) {
        std::vector<bot::BotReport> reports;
        for (const std::string& path : tables) {
            Result<bot::BotReport> r = bot::readReport(path);
            if (!r) {
                std::fprintf(stderr, "terrain-bot: %s\n", r.error().message.c_str());
                return 2;
            }
            reports.push_back(std::move(*r));
        }
        return bot::printTable(reports, stdout) ? 0 : 1;
    }

    Result<std::uint16_t> port = parseEndpoint(connect, config.host);
    if (!port) {
        std::fprintf(stderr, "terrain-bot: %s\n", port.error().message.c_str());
        return 2;
    }
    config.port = *port;
    if (config.max_triangles == 0)
        config.max_triangles = std::numeric_limits<std::int64_t>::max();
    config.backend = *render::parseOffscreenBackend(backend_name); // checked by CLI11
    config.upload_path = *render::parseUploadPath(upload_path);    // checked by CLI11
    if (!config.png_dir.empty())
        config.render = true;
    if (map_procedural && !map_dem.empty()) {
        std::fprintf(stderr, "terrain-bot: --map and --map-dem name two maps; give one\n");
        return 2;
    }
    if (map_procedural || !map_dem.empty()) {
        map.height = map.width;
        Result<Terrain> genesis = [&]() -> Result<Terrain> {
            if (map_procedural)
                return makeProceduralMap(map);
            Result<io::ImportedDem> dem = io::importDem(map_dem, {});
            if (!dem)
                return dem.error();
            return std::move(dem->terrain);
        }();
        if (!genesis) {
            std::fprintf(stderr, "terrain-bot: map: %s\n", genesis.error().message.c_str());
            return 2;
        }
        config.genesis.emplace(std::move(*genesis));
    }
    Result<bot::BotReport> report = bot::runBot(config);
    if (!report) {
        std::fprintf(
            stderr, "terrain-bot %s: %s\n", config.name.c_str(), report.error().message.c_str());
        return 1;
    }
    if (report_path.empty()) {
        std::fputs(bot::toJson(*report).c_str(), stdout);
    } else {
        Status s = bot::writeReport(report_path, *report);
        if (!s) {
            std::fprintf(stderr, "terrain-bot: %s\n", s.error().message.c_str());
            return 1;
        }
    }
    if (!report->error.empty())
        std::fprintf(stderr, "terrain-bot %s: %s\n", config.name.c_str(), report->error.c_str());
    else if (!report->synced)
        std::fprintf(
            stderr, "terrain-bot %s: replica not verified at the end\n", config.name.c_str());
    return report->synced && report->error.empty() ? 0 : 1;
}
