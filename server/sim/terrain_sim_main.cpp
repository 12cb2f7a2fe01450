// terrain-sim: the authority's work without the network. Loads a DEM or generates the default
// map, applies an op script (or a seeded crater series), and reports the world hash, patches,
// memory and timings; writes shaded-relief PNGs before and after. I/O and clocks live here, at
// the edge; the terrain work is all in terrain_core.

#include <terrain/io/genesis.h>
#include <terrain/io/png_image.h>
#include <terrain/io/shaded_relief.h>
#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>
#include <terrain/task_runner.h>
#include <terrain/terrain.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

long residentKiB() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind("VmRSS:", 0) == 0)
            return std::strtol(line.c_str() + 6, nullptr, 10);
    return -1;
}

double mebibytes(std::size_t bytes) {
    return static_cast<double>(bytes) / 1048576.0;
}

double percentile(std::vector<double> v, double p) {
    if (v.empty())
        return 0.0;
    std::sort(v.begin(), v.end());
    const auto i = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
    return v[std::min(i, v.size() - 1)];
}

int fail(const std::string& what, const terrain::Error& e) {
    std::fprintf(
        stderr, "terrain-sim: %s: %s (%s)\n", what.c_str(), e.message.c_str(),
        terrain::toString(e.code));
    return 2;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"terrain-sim: apply deformation ops to a terrain and report hash, patches, "
                 "memory and timings"};
    std::string dem_path;
    std::string png_path;
    std::string script_path;
    std::string out_dir = "out";
    std::string json_path;
    double spacing = 0.0;
    double vscale = 1.0;
    double tolerance = 0.0; // 0: the default of the map source
    std::uint64_t seed = 1;
    int size = 1025;
    int craters = 200;
    double min_radius = 1.5;
    double max_radius = 6.0;
    int zoom = 8;
    bool no_images = false;
    app.add_option("--dem", dem_path, "DEM sidecar (.json) or its folder; default: procedural map");
    app.add_option("--png", png_path, "16-bit grayscale PNG height map (needs --spacing)");
    app.add_option("--spacing", spacing, "grid spacing in metres (overrides the DEM's)")
        ->check(CLI::PositiveNumber);
    app.add_option("--vertical-scale", vscale, "metres per PNG unit")->check(CLI::PositiveNumber);
    app.add_option(
           "--tolerance", tolerance, "patch tolerance in metres (default 1/32 m; DEMs: spacing/64)")
        ->check(CLI::PositiveNumber);
    app.add_option("--seed", seed, "seed of the procedural map and of the crater series");
    app.add_option("--size", size, "procedural map size in vertices per side")
        ->check(CLI::Range(2, 32768));
    app.add_option(
        "--script", script_path, "op script file (see op_script.h); default: random craters");
    app.add_option("--craters", craters, "number of random craters")
        ->check(CLI::Range(0, 10000000));
    app.add_option("--min-radius", min_radius, "random crater min radius, metres")
        ->check(CLI::PositiveNumber);
    app.add_option("--max-radius", max_radius, "random crater max radius, metres")
        ->check(CLI::PositiveNumber);
    app.add_option("--out", out_dir, "folder for the PNGs");
    app.add_option("--zoom", zoom, "pixels per cell of the close-up images")
        ->check(CLI::Range(1, 64));
    app.add_option("--json", json_path, "also write the report as JSON to this file");
    app.add_flag("--no-images", no_images, "skip the PNGs");
    unsigned threads = 1;
    app.add_option(
           "--threads", threads, "threads an op's cells and tiles are spread over (the same bits)")
        ->check(CLI::Range(1, 256))
        ->capture_default_str();
    CLI11_PARSE(app, argc, argv);

    terrain::io::GenesisOptions genesis;
    genesis.dem = dem_path;
    genesis.png = png_path;
    genesis.png_vertical_scale = vscale;
    genesis.seed = seed;
    genesis.size = size;
    if (spacing > 0.0)
        genesis.spacing_metres = spacing;
    if (tolerance > 0.0)
        genesis.patch_tolerance_metres = tolerance;
    const auto load_start = Clock::now();
    auto made = terrain::io::makeGenesis(genesis);
    if (!made)
        return fail("cannot make the map", made.error());
    const std::string source = made->source;
    std::optional<terrain::Terrain> world(std::move(made->terrain));
    terrain::Terrain& t = *world;
    const double load_ms = msSince(load_start);
    const terrain::WorldSpec& spec = t.spec();

    std::vector<terrain::OpRequest> requests;
    if (!script_path.empty()) {
        std::ifstream in(script_path);
        if (!in) {
            std::fprintf(stderr, "terrain-sim: cannot open %s\n", script_path.c_str());
            return 2;
        }
        std::stringstream text;
        text << in.rdbuf();
        auto parsed = terrain::parseOpScript(text.str());
        if (!parsed)
            return fail("bad script " + script_path, parsed.error());
        requests = std::move(*parsed);
    } else {
        terrain::CraterSeries series;
        series.seed = seed;
        series.count = craters;
        series.min_radius = min_radius;
        series.max_radius = max_radius;
        requests = terrain::randomCraters(spec, series);
    }

    std::printf("map      : %s\n", source.c_str());
    std::printf(
        "size     : %d x %d vertices, spacing %.3f m, %d x %d tiles, tolerance %.4f m\n",
        spec.width, spec.height, spec.spacingMetres(), spec.tilesX(), spec.tilesY(),
        spec.patch_tolerance * spec.metresPerUnit());
    std::printf("hash     : %016" PRIx64 " before ops (load %.1f ms)\n", t.worldHash(), load_ms);

    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    terrain::io::ReliefOptions relief;
    relief.highlight_patches = false;
    const auto samples = t.paddedSamples();
    const auto [lo, hi] = std::minmax_element(samples.begin(), samples.end());
    relief.z_low = *lo * spec.metresPerUnit();
    relief.z_high = *hi * spec.metresPerUnit();
    auto writeImage = [&](const std::string& name, const terrain::io::ReliefOptions& o) {
        const auto path = std::filesystem::path(out_dir) / name;
        if (auto s = terrain::io::writeRgbPng(path, terrain::io::renderShadedRelief(t, o)); !s)
            std::fprintf(stderr, "terrain-sim: %s\n", s.error().message.c_str());
        else
            std::printf("image    : %s\n", path.c_str());
    };
    // the close-up frames the first op, so the same window shows before and after
    terrain::io::ReliefOptions closeup = relief;
    closeup.pixels_per_cell = zoom;
    closeup.highlight_patches = true;
    if (!requests.empty()) {
        const double half = std::max(8.0 * requests.front().radius, 16.0 * spec.spacingMetres());
        closeup.x0 = std::max(0.0, requests.front().x - half);
        closeup.y0 = std::max(0.0, requests.front().y - half);
        closeup.x1 = std::min(spec.extentX(), requests.front().x + half);
        closeup.y1 = std::min(spec.extentY(), requests.front().y + half);
    }
    if (!no_images) {
        writeImage("before.png", relief);
        writeImage("before_closeup.png", closeup);
    }

    std::vector<double> op_ms;
    op_ms.reserve(requests.size());
    int refused = 0;
    std::int64_t created = 0;
    std::int64_t removed = 0;
    terrain::ThreadPool pool(threads);
    const auto ops_start = Clock::now();
    for (std::size_t i = 0; i < requests.size(); ++i) {
        auto op = terrain::quantizeOp(requests[i], spec);
        if (!op) {
            ++refused;
            std::printf(
                "refused  : op %zu: %s (%s)\n", i, op.error().message.c_str(),
                terrain::toString(op.error().code));
            continue;
        }
        const auto start = Clock::now();
        auto effect = t.apply(*op, &pool);
        op_ms.push_back(msSince(start));
        if (!effect) {
            ++refused;
            std::printf("refused  : op %zu: %s\n", i, effect.error().message.c_str());
            continue;
        }
        created += effect->patches_created;
        removed += effect->patches_removed;
    }
    const double ops_total_ms = msSince(ops_start);

    const auto snapshot_start = Clock::now();
    const auto snapshot = terrain::encodeSnapshot(t, op_ms.size());
    auto decoded = terrain::decodeSnapshot(snapshot);
    const double snapshot_ms = msSince(snapshot_start);
    if (!decoded)
        return fail("snapshot round trip", decoded.error());
    const bool snapshot_ok = decoded->terrain.worldHash() == t.worldHash();

    const terrain::MemoryUsage mem = t.memoryUsage();
    std::printf(
        "ops      : %zu applied, %d refused, %.1f ms total; per op median %.3f ms, p99 %.3f ms, "
        "max %.3f ms\n",
        op_ms.size(), refused, ops_total_ms, percentile(op_ms, 0.5), percentile(op_ms, 0.99),
        percentile(op_ms, 1.0));
    std::printf(
        "patches  : %zu live (%" PRId64 " created, %" PRId64 " removed), %zu bytes each\n",
        t.patchCount(), created, removed, terrain::kBytesPerPatch);
    std::printf(
        "memory   : samples %.2f MiB + patches %.3f MiB + tiles %.3f MiB = %.2f MiB; process RSS "
        "%.1f MiB\n",
        mebibytes(mem.sample_bytes), mebibytes(mem.patch_bytes), mebibytes(mem.tile_bytes),
        mebibytes(mem.total()), static_cast<double>(residentKiB()) / 1024.0);
    std::printf(
        "snapshot : %zu bytes, encode+decode %.1f ms, round trip %s\n", snapshot.size(),
        snapshot_ms, snapshot_ok ? "same hash" : "HASH DIFFERS");
    std::printf("hash     : %016" PRIx64 " after %zu ops\n", t.worldHash(), op_ms.size());

    if (!no_images) {
        writeImage("after.png", relief);
        writeImage("after_closeup.png", closeup);
    }
    if (!json_path.empty()) {
        std::ofstream j(json_path);
        j << "{\n  \"world_hash\": \"" << std::hex << t.worldHash() << std::dec << "\",\n"
          << "  \"ops_applied\": " << op_ms.size() << ",\n  \"ops_refused\": " << refused << ",\n"
          << "  \"op_ms_median\": " << percentile(op_ms, 0.5)
          << ",\n  \"op_ms_p99\": " << percentile(op_ms, 0.99) << ",\n"
          << "  \"patches\": " << t.patchCount()
          << ",\n  \"bytes_per_patch\": " << terrain::kBytesPerPatch << ",\n"
          << "  \"memory_bytes\": " << mem.total() << ",\n  \"snapshot_bytes\": " << snapshot.size()
          << ",\n"
          << "  \"load_ms\": " << load_ms << "\n}\n";
    }
    return snapshot_ok ? 0 : 1;
}
