// Speed against accuracy: every level-of-detail method (lodlab::Method) on the same maps, flights
// and cameras, for each tau and triangle cap. Per frame: CPU time of the method's terrainChanged()
// (battle craters) and update() (wall time on this thread; drawing is not timed), triangles drawn,
// bytes it would upload, its own error bound, and on measured frames the screen error of what it
// draws against the true surface (max and p99 over triangles) and the open edges of its whole mesh
// (cracks). Writes runs.csv (a row per run), frames.csv (a row per frame) and runs.json into
// --out-dir; tests/bench/lod_report.sh turns them into the charts. Exit status: 0, 1 when a chunked
// or ROAM mesh had an open edge, 2 on bad arguments or an unreadable DEM.

#include "support/bench_facts.h"

#include <terrain/battle.h>
#include <terrain/io/dem_import.h>
#include <terrain/io/png_image.h>
#include <terrain/lodlab/flights.h>
#include <terrain/lodlab/image_measure.h>
#include <terrain/lodlab/lod_method.h>
#include <terrain/lodlab/screen_measure.h>
#include <terrain/procedural_map.h>
#include <terrain/render/mesh_renderer.h>
#include <terrain/render/offscreen.h>
#include <terrain/terrain.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#ifndef TERRAIN_DEM_DIR
#define TERRAIN_DEM_DIR "../shared/data/dem"
#endif

namespace {

using namespace terrain;
using Json = nlohmann::ordered_json;
namespace fs = std::filesystem;

std::vector<std::string> splitList(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream in(s);
    std::string item;
    while (std::getline(in, item, ','))
        if (!item.empty())
            out.push_back(item);
    return out;
}

struct MapSource {
    std::string name;
    std::unique_ptr<Terrain> terrain;
    std::string note;
};

/// "default" (the procedural map), "small" (a 129-vertex one, for smoke tests) or a DEM's name.
std::optional<MapSource>
loadMap(const std::string& name, const fs::path& dem_dir, std::string& error) {
    MapSource m;
    m.name = name;
    if (name == "default" || name == "small") {
        ProceduralMapOptions o;
        if (name == "small")
            o.width = o.height = 129;
        auto t = makeProceduralMap(o);
        if (!t) {
            error = t.error().message;
            return std::nullopt;
        }
        m.terrain = std::make_unique<Terrain>(std::move(*t));
        m.note =
            "procedural, " + std::to_string(o.width) + " x " + std::to_string(o.height) + " at 1 m";
        return m;
    }
    io::DemImportOptions o;
    if (name == "gcanyon_hoppe_1200")
        o.spacing_metres = 40.0; // the source states none; its notes suggest 30-45 m
    auto dem = io::importDem(dem_dir / name, o);
    if (!dem) {
        error = name + ": " + dem.error().message;
        return std::nullopt;
    }
    m.terrain = std::make_unique<Terrain>(std::move(dem->terrain));
    m.note = "DEM " + std::to_string(dem->info.width) + " x " + std::to_string(dem->info.height) +
             " at " + std::to_string(dem->info.spacing_metres) + " m";
    return m;
}

struct RunKey {
    std::string map;
    std::string flight;
    lodlab::Method method;
    double tau;
    std::int64_t cap;
};

struct RunResult {
    RunKey key;
    bench::Summary cpu_ms;
    bench::Summary triangles;
    bench::Summary upload_bytes;
    double bound_max = 0.0;
    double error_max = 0.0;       ///< over measured frames
    double error_p99 = 0.0;       ///< largest per-frame p99
    double error_mean = 0.0;      ///< mean of the frames' means
    double image_diff_mean = 0.0; ///< share of pixels off the full-resolution render
    double image_diff_max = 0.0;
    double psnr_mean = 0.0;
    double psnr_min = 0.0;
    double popping_mean = 0.0; ///< share of pixels that popped
    double popping_max = 0.0;
    /// share of pixels that change from last frame's mesh to this frame's, both seen from this
    /// frame's camera (lodlab::meshChangeShare)
    double lod_change_mean = 0.0;
    double lod_change_max = 0.0;
    int imaged_frames = 0;
    int measured_frames = 0;
    int frames_over_tau = 0; ///< measured frames whose max exceeds tau
    int frames_capped = 0;   ///< frames over the cap or the work budget
    int rebuilds = 0;
    std::int64_t open_edges = 0; ///< largest count on a checked frame
    std::size_t memory_bytes = 0;
    double build_ms = 0.0;
};

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"lod_bench: speed against accuracy of every LOD method"};
    std::string maps = "default,srtm_n44w072";
    std::string flights = "cruise,low,hover,whip,teleport,battle";
    std::string methods = "split_merge,split_only,full_mesh,chunked,split_merge_morph";
    std::string taus = "0.25,0.5,1,2,4,8";
    std::string caps = "0";
    int frames = 240;
    int measures = 8;
    int pre_shots = 1000;
    int width = 1280;
    int height = 720;
    std::string out_dir = "out/lod";
    std::string dem_dir = TERRAIN_DEM_DIR;
    bool images = true;
    int threshold = 16;
    bool save_frames = false;
    app.add_option("--maps", maps, "default, small, or DEM names under --dem-dir (comma list)");
    app.add_option("--flights", flights, "cruise, low, hover, whip, teleport, battle");
    app.add_option(
        "--methods", methods, "split_merge, split_only, full_mesh, chunked, split_merge_morph");
    app.add_option("--taus", taus, "screen error targets, pixels (comma list)");
    app.add_option("--caps", caps, "triangle caps (comma list; 0: none)");
    app.add_option("--frames", frames, "frames per run")->check(CLI::Range(1, 100000));
    app.add_option("--measures", measures, "frames measured per run (screen error, cracks)")
        ->check(CLI::Range(1, 100000));
    app.add_option("--pre-shots", pre_shots, "battle: shots fired before the flight")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--width", width)->check(CLI::Range(16, 8192));
    app.add_option("--height", height)->check(CLI::Range(16, 8192));
    app.add_option("--out-dir", out_dir);
    app.add_option("--dem-dir", dem_dir);
    app.add_flag(
        "!--no-images", images,
        "skip the image measures (OSMesa renders of each measured frame, its predecessor and the "
        "full-resolution mesh)");
    app.add_option("--image-threshold", threshold, "a pixel differs beyond this channel step")
        ->check(CLI::Range(0, 255));
    app.add_flag(
        "--save-frames", save_frames,
        "write the middle measured frame of every run at tau 1 (and the reference) as PNGs");
    CLI11_PARSE(app, argc, argv);

    std::vector<lodlab::FlightKind> flight_list;
    for (const std::string& f : splitList(flights)) {
        auto k = lodlab::parseFlight(f);
        if (!k) {
            std::fprintf(stderr, "lod_bench: unknown flight '%s'\n", f.c_str());
            return 2;
        }
        flight_list.push_back(*k);
    }
    std::vector<lodlab::Method> method_list;
    for (const std::string& m : splitList(methods)) {
        auto k = lodlab::parseMethod(m);
        if (!k) {
            std::fprintf(stderr, "lod_bench: unknown method '%s'\n", m.c_str());
            return 2;
        }
        method_list.push_back(*k);
    }
    std::vector<double> tau_list;
    std::vector<std::int64_t> cap_list;
    try {
        for (const std::string& t : splitList(taus))
            tau_list.push_back(std::stod(t));
        for (const std::string& c : splitList(caps))
            cap_list.push_back(std::stoll(c));
    } catch (const std::exception&) {
        std::fprintf(stderr, "lod_bench: --taus and --caps take comma lists of numbers\n");
        return 2;
    }
    for (double t : tau_list)
        if (!(t > 0.0)) {
            std::fprintf(stderr, "lod_bench: every tau must be positive\n");
            return 2;
        }
    std::error_code ec;
    fs::create_directories(out_dir, ec);
    std::ofstream frames_csv(fs::path(out_dir) / "frames.csv");
    std::ofstream runs_csv(fs::path(out_dir) / "runs.csv");
    if (!frames_csv || !runs_csv) {
        std::fprintf(stderr, "lod_bench: cannot write into %s\n", out_dir.c_str());
        return 2;
    }
    frames_csv
        << "map,flight,method,tau,cap,frame,cpu_ms,triangles,upload_bytes,bound_px,"
           "error_max_px,error_p99_px,open_edges,event,image_diff,psnr_db,popping,lod_change\n";
    runs_csv
        << "map,flight,method,tau,cap,cpu_p50_ms,cpu_p99_ms,cpu_max_ms,triangles_p50,"
           "triangles_max,upload_mean_bytes,upload_p99_bytes,bound_max_px,error_max_px,"
           "error_p99_px,error_mean_px,measured_frames,frames_over_tau,frames_capped,"
           "rebuilds,open_edges,memory_bytes,build_ms,image_diff_mean,image_diff_max,"
           "psnr_mean_db,psnr_min_db,popping_mean,popping_max,lod_change_mean,lod_change_max\n";

    Json report = Json::object();
    report["benchmark"] = "lod_bench";
    report["date"] = bench::isoNow();
    report["cpu"] = bench::cpuModel();
    report["frames"] = frames;
    report["viewport"] = {width, height};
    Json runs = Json::array();
    bool cracked = false;
    std::unique_ptr<render::GlContext> gl;
    if (images) {
        auto context =
            render::createOffscreenContext(render::OffscreenBackend::kOsmesa, width, height);
        if (!context) {
            std::fprintf(
                stderr, "lod_bench: no image measures: %s\n", context.error().message.c_str());
            images = false;
        } else {
            gl = std::move(*context);
            report["renderer"] = gl->describe();
        }
    }
    report["image_threshold"] = threshold;
    if (save_frames)
        fs::create_directories(fs::path(out_dir) / "frames", ec);

    for (const std::string& map_name : splitList(maps)) {
        std::string error;
        auto map = loadMap(map_name, dem_dir, error);
        if (!map) {
            std::fprintf(stderr, "lod_bench: %s\n", error.c_str());
            return 2;
        }
        std::printf("map %s: %s\n", map->name.c_str(), map->note.c_str());
        std::unique_ptr<render::MeshRenderer> painter;
        std::array<std::uint8_t, 3> sky_rgb{};
        if (images) {
            auto made = render::MeshRenderer::create(*gl, *map->terrain);
            if (!made) {
                std::fprintf(stderr, "lod_bench: %s\n", made.error().message.c_str());
                return 2;
            }
            painter = std::move(*made);
            // the sky's colour as read back: nothing drawn
            const io::RgbImage empty = painter->render({}, *map->terrain, roam::Camera{});
            sky_rgb = {empty.rgb[0], empty.rgb[1], empty.rgb[2]};
        }
        for (lodlab::FlightKind kind : flight_list) {
            // the battle's world: pre_shots craters at the zone, then more during the flight
            // (the same seed for every method, so each sees the same world)
            const bool battle = kind == lodlab::FlightKind::kBattle;
            Terrain start = *map->terrain;
            BattleGenerator pre = lodlab::battleGenerator(start);
            if (battle)
                lodlab::fireShots(pre, start, pre_shots);
            lodlab::FlightOptions fo;
            fo.kind = kind;
            fo.frames = frames;
            fo.width = width;
            fo.height = height;
            const std::vector<lodlab::FlightFrame> flight = lodlab::makeFlight(start, fo);
            std::vector<int> measured_at;
            for (int m = 0; m < measures; ++m)
                measured_at.push_back(static_cast<int>(
                    (static_cast<std::int64_t>(m) * frames + frames / 2) / measures));
            // the full-resolution renders of the measured frames and their predecessors, made
            // during the flight's first run (every run sees the same world)
            std::map<int, io::RgbImage> reference;
            for (lodlab::Method method : method_list)
                for (double tau : tau_list)
                    for (std::int64_t cap : cap_list) {
                        if (method == lodlab::Method::kFullMesh &&
                            (tau != tau_list.front() || cap != cap_list.front()))
                            continue; // it takes neither: one run
                        Terrain world = start;
                        BattleGenerator gen = pre; // continues where the pre-battle stopped
                        lodlab::MethodOptions mo;
                        mo.tau_pixels = tau;
                        mo.max_triangles = cap > 0 ? cap : std::int64_t{1} << 40;
                        RunResult r;
                        r.key = {map->name, lodlab::toString(kind), method, tau, cap};
                        const auto build = bench::Clock::now();
                        auto lod = lodlab::makeMethod(method, world, mo);
                        r.build_ms = bench::msSince(build);
                        std::unique_ptr<lodlab::LodMethod> truth;
                        if (images && reference.empty())
                            truth = lodlab::makeMethod(lodlab::Method::kFullMesh, world, mo);
                        io::RgbImage previous;
                        std::vector<glm::dvec3> previous_mesh; // last frame's, when measuring
                        double psnr_sum = 0.0;
                        r.psnr_min = lodlab::kPsnrIdentical;
                        std::vector<double> cpu;
                        std::vector<double> tris;
                        std::vector<double> upload;
                        std::vector<glm::dvec3> drawn;
                        std::vector<lodlab::LatticeTriangle> mesh;
                        double mean_sum = 0.0;
                        for (int i = 0; i < frames; ++i) {
                            const lodlab::FlightFrame& ff = flight[static_cast<std::size_t>(i)];
                            std::vector<CellRect> changed;
                            for (int s = 0; s < ff.shots; ++s) {
                                const BattleShot shot = gen.next(world);
                                if (!shot.crater)
                                    continue;
                                auto op = quantizeOp(*shot.crater, world.spec());
                                if (!op)
                                    continue;
                                auto effect = world.apply(*op);
                                if (effect && !effect->cells.empty())
                                    changed.push_back(effect->cells);
                            }
                            // the frame's CPU: taking the changes in, then the update
                            const auto t0 = bench::Clock::now();
                            if (!changed.empty())
                                lod->terrainChanged(changed, false);
                            const lodlab::MethodFrame f = lod->update(ff.camera);
                            const double ms = bench::msSince(t0);
                            const bool measure =
                                std::find(measured_at.begin(), measured_at.end(), i) !=
                                measured_at.end();
                            const bool before_measure =
                                std::find(measured_at.begin(), measured_at.end(), i + 1) !=
                                measured_at.end();
                            if (truth) {
                                if (!changed.empty())
                                    truth->terrainChanged(changed, false);
                                if (measure || before_measure) {
                                    truth->update(ff.camera);
                                    truth->visibleTriangles(drawn);
                                    reference[i] = painter->render(drawn, world, ff.camera);
                                }
                            }
                            lodlab::ImageError image;
                            double popped = -1.0;
                            double lod_change = -1.0;
                            if (images && (measure || before_measure)) {
                                lod->visibleTriangles(drawn);
                                io::RgbImage shot = painter->render(drawn, world, ff.camera);
                                if (measure && !previous_mesh.empty()) {
                                    const io::RgbImage was =
                                        painter->render(previous_mesh, world, ff.camera);
                                    lod_change =
                                        lodlab::meshChangeShare(was, shot, sky_rgb, threshold);
                                    r.lod_change_mean += lod_change;
                                    r.lod_change_max = std::max(r.lod_change_max, lod_change);
                                }
                                previous_mesh.clear();
                                if (before_measure)
                                    previous_mesh = drawn;
                                if (measure) {
                                    image = lodlab::compareImages(shot, reference[i], threshold);
                                    if (!previous.rgb.empty() && reference.count(i - 1) != 0)
                                        popped = lodlab::poppingShare(
                                            previous, shot, reference[i - 1], reference[i],
                                            threshold);
                                    ++r.imaged_frames;
                                    r.image_diff_mean += image.differing_share;
                                    r.image_diff_max =
                                        std::max(r.image_diff_max, image.differing_share);
                                    psnr_sum += image.psnr_db;
                                    r.psnr_min = std::min(r.psnr_min, image.psnr_db);
                                    if (popped >= 0.0) {
                                        r.popping_mean += popped;
                                        r.popping_max = std::max(r.popping_max, popped);
                                    }
                                    if (save_frames && tau == 1.0 && cap == cap_list.front() &&
                                        i == measured_at[measured_at.size() / 2]) {
                                        const std::string stem =
                                            map->name + "_" + lodlab::toString(kind) + "_";
                                        (void)io::writeRgbPng(
                                            fs::path(out_dir) / "frames" /
                                                (stem + lodlab::toString(method) + ".png"),
                                            shot);
                                        (void)io::writeRgbPng(
                                            fs::path(out_dir) / "frames" / (stem + "reference.png"),
                                            reference[i]);
                                    }
                                }
                                previous = std::move(shot);
                            } else {
                                previous.rgb.clear();
                                previous_mesh.clear();
                            }
                            cpu.push_back(ms);
                            tris.push_back(static_cast<double>(f.triangles));
                            upload.push_back(static_cast<double>(f.upload_bytes));
                            r.bound_max = std::max(r.bound_max, f.error_bound_pixels);
                            r.frames_capped += f.over_budget ? 1 : 0;
                            r.rebuilds += f.rebuilt ? 1 : 0;
                            lodlab::MeshError e;
                            std::int64_t open = -1;
                            if (measure) {
                                lod->visibleTriangles(drawn);
                                lodlab::ScreenErrorOptions so;
                                so.tau_pixels = tau;
                                e = lodlab::measureMeshError(drawn, world, ff.camera, so);
                                ++r.measured_frames;
                                r.error_max = std::max(r.error_max, e.max_pixels);
                                r.error_p99 = std::max(r.error_p99, e.p99_pixels);
                                mean_sum += e.mean_pixels;
                                r.frames_over_tau += e.max_pixels > tau ? 1 : 0;
                                lod->allTriangles(mesh);
                                open = lodlab::countOpenEdges(
                                    mesh, std::int64_t{world.spec().cellsX()} * 16,
                                    std::int64_t{world.spec().cellsY()} * 16);
                                r.open_edges = std::max(r.open_edges, open);
                            }
                            const char* event = ff.teleport        ? "teleport"
                                                : !changed.empty() ? "crater"
                                                                   : "";
                            char line[512];
                            std::snprintf(
                                line, sizeof line,
                                "%s,%s,%s,%g,%lld,%d,%.4f,%lld,%lld,%.4f,%s,%s,%s,%s,%s,%s,%s,%s\n",
                                map->name.c_str(), lodlab::toString(kind), lodlab::toString(method),
                                tau, static_cast<long long>(cap), i, ms,
                                static_cast<long long>(f.triangles),
                                static_cast<long long>(f.upload_bytes), f.error_bound_pixels,
                                measure ? std::to_string(e.max_pixels).c_str() : "",
                                measure ? std::to_string(e.p99_pixels).c_str() : "",
                                measure ? std::to_string(open).c_str() : "", event,
                                measure && images ? std::to_string(image.differing_share).c_str()
                                                  : "",
                                measure && images ? std::to_string(image.psnr_db).c_str() : "",
                                popped >= 0.0 ? std::to_string(popped).c_str() : "",
                                lod_change >= 0.0 ? std::to_string(lod_change).c_str() : "");
                            frames_csv << line;
                        }
                        r.error_mean = r.measured_frames > 0 ? mean_sum / r.measured_frames : 0;
                        if (r.imaged_frames > 0) {
                            r.image_diff_mean /= r.imaged_frames;
                            r.psnr_mean = psnr_sum / r.imaged_frames;
                            // the first measured frame may have no predecessor rendered
                            const int popped_frames =
                                r.imaged_frames - (measured_at.front() == 0 ? 1 : 0);
                            if (popped_frames > 0) {
                                r.popping_mean /= popped_frames;
                                r.lod_change_mean /= popped_frames;
                            }
                        }
                        r.memory_bytes = lod->memoryBytes();
                        r.cpu_ms = bench::summarize(cpu);
                        r.triangles = bench::summarize(tris);
                        r.upload_bytes = bench::summarize(upload);
                        if (method != lodlab::Method::kFullMesh && r.open_edges > 0)
                            cracked = true;
                        char line[1024];
                        std::snprintf(
                            line, sizeof line,
                            "%s,%s,%s,%g,%lld,%.4f,%.4f,%.4f,%.0f,%.0f,%.0f,%.0f,%.4f,%.4f,%.4f,"
                            "%.4f,%d,%d,%d,%d,%lld,%zu,%.1f,%.5f,%.5f,%.2f,%.2f,%.5f,%.5f,%.6f,%."
                            "6f\n",
                            r.key.map.c_str(), r.key.flight.c_str(), lodlab::toString(method), tau,
                            static_cast<long long>(cap), r.cpu_ms.p50, r.cpu_ms.p99, r.cpu_ms.max,
                            r.triangles.p50, r.triangles.max, r.upload_bytes.mean,
                            r.upload_bytes.p99, r.bound_max, r.error_max, r.error_p99, r.error_mean,
                            r.measured_frames, r.frames_over_tau, r.frames_capped, r.rebuilds,
                            static_cast<long long>(r.open_edges), r.memory_bytes, r.build_ms,
                            r.image_diff_mean, r.image_diff_max, r.psnr_mean, r.psnr_min,
                            r.popping_mean, r.popping_max, r.lod_change_mean, r.lod_change_max);
                        runs_csv << line;
                        std::printf("  %s", line);
                        std::fflush(stdout);
                        Json j = Json::object();
                        j["map"] = r.key.map;
                        j["flight"] = r.key.flight;
                        j["method"] = lodlab::toString(method);
                        j["tau_px"] = tau;
                        j["cap"] = cap;
                        j["cpu_ms"] = {
                            {"p50", r.cpu_ms.p50}, {"p99", r.cpu_ms.p99}, {"max", r.cpu_ms.max}};
                        j["triangles"] = {{"p50", r.triangles.p50}, {"max", r.triangles.max}};
                        j["upload_bytes"] = {
                            {"mean", r.upload_bytes.mean}, {"p99", r.upload_bytes.p99}};
                        j["bound_max_px"] = r.bound_max;
                        j["screen_error_px"] = {
                            {"max", r.error_max}, {"p99", r.error_p99}, {"mean", r.error_mean}};
                        j["measured_frames"] = r.measured_frames;
                        j["frames_over_tau"] = r.frames_over_tau;
                        j["frames_capped"] = r.frames_capped;
                        j["rebuilds"] = r.rebuilds;
                        j["open_edges"] = r.open_edges;
                        j["memory_bytes"] = r.memory_bytes;
                        j["build_ms"] = r.build_ms;
                        if (r.imaged_frames > 0) {
                            j["image_differing_share"] = {
                                {"mean", r.image_diff_mean}, {"max", r.image_diff_max}};
                            j["psnr_db"] = {{"mean", r.psnr_mean}, {"min", r.psnr_min}};
                            j["popping_share"] = {{"mean", r.popping_mean}, {"max", r.popping_max}};
                            j["lod_change_share"] = {
                                {"mean", r.lod_change_mean}, {"max", r.lod_change_max}};
                        }
                        runs.push_back(j);
                    }
        }
    }
    report["runs"] = runs;
    std::ofstream(fs::path(out_dir) / "runs.json") << report.dump(2) << "\n";
    if (cracked) {
        std::fprintf(stderr, "lod_bench: a chunked or ROAM mesh had open edges (see runs.csv)\n");
        return 1;
    }
    return 0;
}
