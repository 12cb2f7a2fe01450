// Battle benchmark: the battle generator's shots (rays from moving cameras at grazing and steep
// angles, each cast against the surface the earlier shots left) applied to a map, timed per shot,
// with the stability figures of tests/support/battle_checks.h: how high any point rose above the
// original ground near it, needles, the steepest slope, patches and memory. Optionally writes a
// shaded-relief PNG of the battle zone and the canonical ops (a replayable script).
// Exit status: 0, or 2 on a bad option, DEM or output file. Timings are reported, never asserted.

#include "support/battle_checks.h"
#include "support/bench_facts.h"

#include <terrain/battle.h>
#include <terrain/genesis_delta.h>
#include <terrain/io/dem_import.h>
#include <terrain/io/png_image.h>
#include <terrain/io/shaded_relief.h>
#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/render/offscreen.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>
#include <terrain/snapshot.h>
#include <terrain/surface_query.h>
#include <terrain/task_runner.h>
#include <terrain/terrain.h>
#include <terrain/wire/compression.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

namespace {

using namespace terrain;
using Json = nlohmann::ordered_json;

// A picture of the battle zone from a low oblique camera: OSMesa, ROAM at tau = 1 px.
terrain::Status
renderView(const terrain::Terrain& t, const terrain::BattleOptions& o, const std::string& path) {
    using namespace terrain;
    constexpr int kWidth = 960;
    constexpr int kHeight = 540;
    auto context =
        render::createOffscreenContext(render::OffscreenBackend::kOsmesa, kWidth, kHeight);
    if (!context)
        return context.error();
    auto renderer = render::TerrainRenderer::create(**context);
    if (!renderer)
        return renderer.error();
    roam::TessellatorOptions options;
    options.tau_pixels = 1.0;
    options.work_budget = 1 << 30;
    roam::Tessellator tess(t, options);
    const double reach = o.zone_radius + 3.0 * o.max_radius;
    const glm::dvec3 target(o.zone_x, o.zone_y, surfaceHeight(t, o.zone_x, o.zone_y));
    roam::Camera camera;
    camera.eye = glm::dvec3(
        std::clamp(o.zone_x - 1.6 * reach, 0.0, t.spec().extentX()),
        std::clamp(o.zone_y - 1.1 * reach, 0.0, t.spec().extentY()), 0.0);
    camera.eye.z = std::max(target.z, surfaceHeight(t, camera.eye.x, camera.eye.y)) + 0.9 * reach;
    camera.forward = target - camera.eye;
    camera.viewport_width = kWidth;
    camera.viewport_height = kHeight;
    camera.near_plane = 0.5;
    tess.update(camera);
    (*renderer)->sync(tess, t);
    (*renderer)->draw(tess, camera, {});
    return io::writeRgbPng(path, (*context)->readPixels());
}

Json summaryJson(const bench::Summary& s) {
    return Json{{"n", s.n}, {"p50", s.p50}, {"p99", s.p99}, {"max", s.max}, {"mean", s.mean}};
}

/// The command line.
struct Settings {
    std::string dem;
    int shots = 10000;
    BattleOptions battle;
    double zone_x = -1.0;
    double zone_y = -1.0;
    double radius_scale = 0.0;
    double needle_height = 1.0;
    double spacing = 0.0;
    double vertical_scale = 0.0;
    ProceduralMapOptions map;
    unsigned threads = 1;
    std::string out;
    std::string relief;
    std::string ops_path;
    std::string view;
};

/// Parses the command line into `s`; an exit status when main should stop (help, bad input).
std::optional<int> parseSettings(int argc, char** argv, Settings& s) {
    CLI::App app{"battle_bench: craters aimed like players aim them, timed and checked"};
    app.add_option("--dem", s.dem, "DEM sidecar (.json); default: the default procedural map");
    app.add_option("--spacing", s.spacing, "DEM grid spacing in metres, where the DEM states none");
    app.add_option("--vertical-scale", s.vertical_scale, "DEM metres per stored unit");
    app.add_option("--map-size", s.map.width, "procedural map size in vertices")
        ->check(CLI::Range(65, 8193));
    app.add_option("--map-seed", s.map.seed, "procedural map seed");
    app.add_option("--shots", s.shots, "shots to fire")->check(CLI::PositiveNumber);
    app.add_option("--threads", s.threads, "Terrain::apply's thread pool (1: the serial path)")
        ->check(CLI::Range(1, 64));
    app.add_option("--seed", s.battle.seed, "battle seed");
    app.add_option("--zone-x", s.zone_x, "battle zone centre, metres (default: map centre)");
    app.add_option("--zone-y", s.zone_y, "battle zone centre, metres (default: map centre)");
    app.add_option("--zone-radius", s.battle.zone_radius, "battle zone radius, metres");
    app.add_option(
        "--radius-scale", s.radius_scale,
        "multiply every length of the battle (radii, ranges, zone) by this; default: "
        "the grid spacing in metres");
    app.add_option(
        "--needle-height", s.needle_height,
        "a vertex this far (metres, times the scale) above all 8 neighbours is a needle");
    app.add_option("--out", s.out, "JSON report");
    app.add_option("--relief", s.relief, "shaded-relief PNG of the battle zone");
    app.add_option(
        "--ops", s.ops_path, "write the accepted ops as canonical integers, one per line");
    app.add_option("--view", s.view, "rendered view (OSMesa, 960 x 540) of the battle zone, PNG");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    return std::nullopt;
}

struct World {
    Terrain terrain;
    std::string name;
};

/// The procedural map, or the DEM named by --dem.
std::optional<World> loadWorld(Settings& s) {
    if (s.dem.empty()) {
        s.map.height = s.map.width;
        std::string name = "procedural " + std::to_string(s.map.width) + " x " +
                           std::to_string(s.map.width) + " (seed " + std::to_string(s.map.seed) +
                           ")";
        return World{std::move(*makeProceduralMap(s.map)), std::move(name)};
    }
    io::DemImportOptions options;
    if (s.spacing > 0.0)
        options.spacing_metres = s.spacing;
    if (s.vertical_scale > 0.0)
        options.vertical_scale = s.vertical_scale;
    auto imported = io::importDem(s.dem, options);
    if (!imported) {
        std::fprintf(
            stderr, "battle_bench: %s: %s\n", s.dem.c_str(), imported.error().message.c_str());
        return std::nullopt;
    }
    return World{std::move(imported->terrain), imported->info.name};
}

/// The battle placed on the map (the zone at the centre unless given) and every length scaled.
void placeBattle(BattleOptions& o, const Settings& s, const WorldSpec& spec, double scale) {
    o.zone_x = s.zone_x >= 0.0 ? s.zone_x : spec.extentX() / 2;
    o.zone_y = s.zone_y >= 0.0 ? s.zone_y : spec.extentY() / 2;
    o.zone_radius *= scale;
    o.min_range *= scale;
    o.max_range *= scale;
    o.min_altitude *= scale;
    o.max_altitude *= scale;
    o.follow_spread *= scale;
    o.min_radius *= scale;
    o.max_radius *= scale;
}

/// What firing the shots measured.
struct Fired {
    testing::BattleFigures counts;
    std::vector<double> apply_ms;
    std::vector<double> aim_ms;
    double seconds = 0.0;
};

/// Fires the generator's shots into `t`, timing the aim and the apply of each, the watch
/// observing every crater; each accepted op to `ops_file` if it is open.
Fired fireShots(
    Terrain& t,
    BattleGenerator& generator,
    int shots,
    ThreadPool& pool,
    testing::BattleWatch& watch,
    std::ofstream& ops_file) {
    Fired fired;
    testing::BattleFigures& counts = fired.counts;
    const auto started = bench::Clock::now();
    for (int i = 0; i < shots; ++i) {
        auto t0 = bench::Clock::now();
        const BattleShot shot = generator.next(t);
        fired.aim_ms.push_back(bench::msSince(t0));
        ++counts.shots;
        if (!shot.crater) {
            ++counts.missed;
            continue;
        }
        auto op = quantizeOp(*shot.crater, t.spec());
        if (!op) {
            ++counts.refused;
            continue;
        }
        t0 = bench::Clock::now();
        auto effect = t.apply(*op, &pool);
        fired.apply_ms.push_back(bench::msSince(t0));
        if (!effect) {
            ++counts.refused;
            continue;
        }
        ++counts.craters;
        watch.observe(t, *effect);
        if (ops_file)
            ops_file << formatCanonicalOp(*op) << '\n';
    }
    fired.seconds = bench::msSince(started) / 1000.0;
    return fired;
}

/// What a joiner downloads: the whole snapshot, or the delta from the genesis it holds, raw and
/// compressed at three zstd levels, with the time each takes.
Json joinBytesJson(const Terrain& t) {
    const WorldSpec& spec = t.spec();
    const std::uint64_t genesis_hash = t.genesisHash();
    std::int32_t differing = 0;
    for (std::int32_t tile = 0; tile < spec.tileCount(); ++tile)
        differing += t.differsFromGenesis(tile) ? 1 : 0;
    auto t0 = bench::Clock::now();
    const auto full = encodeSnapshot(t, 0);
    const double full_ms = bench::msSince(t0);
    t0 = bench::Clock::now();
    const auto delta = encodeGenesisDelta(t, 0, genesis_hash);
    const double delta_ms = bench::msSince(t0);
    Json join;
    join["tiles"] = spec.tileCount();
    join["tiles_differing"] = differing;
    join["snapshot_raw_mib"] = bench::mib(full.size());
    join["snapshot_encode_ms"] = full_ms;
    join["delta_raw_mib"] = bench::mib(delta.size());
    join["delta_encode_ms"] = delta_ms;
    join["delta_raw_bytes_per_patch"] =
        static_cast<double>(delta.size()) /
        static_cast<double>(std::max<std::size_t>(1, t.patchCount()));
    for (int level : {1, 3, 9}) {
        t0 = bench::Clock::now();
        const auto zf = wire::compress(full, level);
        const double zf_ms = bench::msSince(t0);
        t0 = bench::Clock::now();
        const auto zd = wire::compress(delta, level);
        const double zd_ms = bench::msSince(t0);
        const std::string k = "zstd" + std::to_string(level);
        join[k] = {
            {"snapshot_mib", bench::mib(zf.size())},
            {"snapshot_ms", zf_ms},
            {"delta_mib", bench::mib(zd.size())},
            {"delta_ms", zd_ms},
            {"delta_seconds_at_20mbit", static_cast<double>(zd.size()) * 8.0 / 20e6}};
    }
    return join;
}

Json stabilityJson(const testing::BattleFigures& f, double needle_height_m, double spacing_m) {
    Json s = {
        {"max_rise_m", f.max_rise_m},
        {"max_rise_own_m", f.max_rise_own_m},
        {"max_patch_rise_m", f.max_patch_rise_m},
        {"deepest_m", f.deepest_m},
        {"needle_height_m", needle_height_m},
        {"needles", f.needles},
        {"tallest_spike_m", f.tallest_spike_m},
        {"max_slope", f.max_slope},
        {"max_slope_before", f.max_slope_before},
        {"patches", f.patches},
        {"patch_extent_m", f.patch_extent_m},
        {"changed_vertices", f.changed_vertices}};
    for (const auto& spot : f.needle_spots)
        s["needle_spots"].push_back(
            {{"x_m", spot.x * spacing_m}, {"y_m", spot.y * spacing_m}, {"spike_m", spot.value}});
    s["steepest"] = {
        {"x_m", f.steepest.x * spacing_m},
        {"y_m", f.steepest.y * spacing_m},
        {"slope", f.steepest.value}};
    return s;
}

std::string hex16(std::uint64_t v) {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

/// The report: the map, the battle, the counts and timings, memory, join bytes, stability.
Json reportJson(
    const Settings& s,
    const World& world,
    const BattleOptions& o,
    const Fired& fired,
    const testing::BattleFigures& f,
    double scale,
    std::size_t rss_before) {
    const Terrain& t = world.terrain;
    const MemoryUsage mem = t.memoryUsage();
    Json j;
    j["bench"] = "battle_bench";
    j["date"] = bench::isoNow();
    j["cpu"] = bench::cpuModel();
    j["map"] = world.name;
    j["spacing_m"] = t.spec().spacingMetres();
    j["battle"] = {
        {"seed", o.seed},
        {"shots", s.shots},
        {"zone_x_m", o.zone_x},
        {"zone_y_m", o.zone_y},
        {"zone_radius_m", o.zone_radius},
        {"radius_m", {o.min_radius, o.max_radius}},
        {"players", o.players},
        {"follow_share", o.follow_share}};
    j["counts"] = {
        {"shots", f.shots}, {"craters", f.craters}, {"missed", f.missed}, {"refused", f.refused}};
    j["apply_ms"] = summaryJson(bench::summarize(fired.apply_ms));
    j["threads"] = s.threads;
    j["aim_ms"] = summaryJson(bench::summarize(fired.aim_ms));
    j["seconds"] = fired.seconds;
    j["world_hash"] = hex16(t.worldHash());
    j["memory"] = {
        {"terrain_mib", bench::mib(mem.total())},
        {"samples_mib", bench::mib(mem.sample_bytes)},
        {"patches_mib", bench::mib(mem.patch_bytes)},
        {"rss_mib", bench::mib(bench::residentBytes())},
        {"rss_growth_mib",
         bench::mib(bench::residentBytes() - std::min(rss_before, bench::residentBytes()))}};
    j["join_bytes"] = joinBytesJson(t);
    j["stability"] = stabilityJson(f, s.needle_height * scale, t.spec().spacingMetres());
    return j;
}

/// The report to stdout and --out, the relief and the view; 2 (with a message) if one cannot be
/// written.
int writeOutputs(const Settings& s, const Json& j, const Terrain& t, const BattleOptions& o) {
    const WorldSpec& spec = t.spec();
    std::cout << j.dump(2) << "\n";
    if (!s.out.empty()) {
        std::ofstream file(s.out);
        file << j.dump(2) << "\n";
        if (!file) {
            std::fprintf(stderr, "battle_bench: cannot write %s\n", s.out.c_str());
            return 2;
        }
    }
    if (!s.relief.empty()) {
        io::ReliefOptions r;
        r.pixels_per_cell = 4;
        const double half = o.zone_radius + 3.0 * o.max_radius;
        r.x0 = std::max(0.0, o.zone_x - half);
        r.y0 = std::max(0.0, o.zone_y - half);
        r.x1 = std::min(spec.extentX(), o.zone_x + half);
        r.y1 = std::min(spec.extentY(), o.zone_y + half);
        if (auto status = io::writeRgbPng(s.relief, io::renderShadedRelief(t, r)); !status) {
            std::fprintf(stderr, "battle_bench: %s\n", status.error().message.c_str());
            return 2;
        }
    }
    if (!s.view.empty()) {
        if (auto status = renderView(t, o, s.view); !status) {
            std::fprintf(stderr, "battle_bench: %s\n", status.error().message.c_str());
            return 2;
        }
    }
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    Settings s;
    if (const std::optional<int> stop = parseSettings(argc, argv, s))
        return *stop;
    std::optional<World> world = loadWorld(s);
    if (!world)
        return 2;
    Terrain& t = world->terrain;
    const double scale = s.radius_scale > 0.0 ? s.radius_scale : t.spec().spacingMetres();
    BattleOptions o = s.battle;
    placeBattle(o, s, t.spec(), scale);

    BattleGenerator generator(o);
    testing::BattleWatch watch(t, 2.0 * o.max_radius);
    ThreadPool pool(s.threads);
    std::ofstream ops_file;
    if (!s.ops_path.empty()) {
        ops_file.open(s.ops_path);
        if (!ops_file) {
            std::fprintf(stderr, "battle_bench: cannot write %s\n", s.ops_path.c_str());
            return 2;
        }
        ops_file << "# canonical ops (parseCanonicalOps): kind center_x center_y radius height "
                    "strength\n";
    }
    const std::size_t rss_before = bench::residentBytes();
    const Fired fired = fireShots(t, generator, s.shots, pool, watch, ops_file);
    testing::BattleFigures f = watch.figures(t, s.needle_height * scale, o.zone_x, o.zone_y);
    f.shots = fired.counts.shots;
    f.craters = fired.counts.craters;
    f.missed = fired.counts.missed;
    f.refused = fired.counts.refused;
    return writeOutputs(s, reportJson(s, *world, o, fired, f, scale, rss_before), t, o);
}
