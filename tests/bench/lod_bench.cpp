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
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
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

/// The command line.
struct Settings {
    std::vector<std::string> maps;
    std::vector<lodlab::FlightKind> flights;
    std::vector<lodlab::Method> methods;
    std::vector<double> taus;
    std::vector<std::int64_t> caps;
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
};

/// Parses the command line into `s`; an exit status when main should stop (help, bad input).
std::optional<int> parseSettings(int argc, char** argv, Settings& s) {
    CLI::App app{"lod_bench: speed against accuracy of every LOD method"};
    std::string maps = "default,srtm_n44w072";
    std::string flights = "cruise,low,hover,whip,teleport,battle";
    std::string methods = "split_merge,split_only,full_mesh,chunked,split_merge_morph";
    std::string taus = "0.25,0.5,1,2,4,8";
    std::string caps = "0";
    app.add_option("--maps", maps, "default, small, or DEM names under --dem-dir (comma list)");
    app.add_option("--flights", flights, "cruise, low, hover, whip, teleport, battle");
    app.add_option(
        "--methods", methods, "split_merge, split_only, full_mesh, chunked, split_merge_morph");
    app.add_option("--taus", taus, "screen error targets, pixels (comma list)");
    app.add_option("--caps", caps, "triangle caps (comma list; 0: none)");
    app.add_option("--frames", s.frames, "frames per run")->check(CLI::Range(1, 100000));
    app.add_option("--measures", s.measures, "frames measured per run (screen error, cracks)")
        ->check(CLI::Range(1, 100000));
    app.add_option("--pre-shots", s.pre_shots, "battle: shots fired before the flight")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--width", s.width)->check(CLI::Range(16, 8192));
    app.add_option("--height", s.height)->check(CLI::Range(16, 8192));
    app.add_option("--out-dir", s.out_dir);
    app.add_option("--dem-dir", s.dem_dir);
    app.add_flag(
        "!--no-images", s.images,
        "skip the image measures (OSMesa renders of each measured frame, its predecessor and the "
        "full-resolution mesh)");
    app.add_option("--image-threshold", s.threshold, "a pixel differs beyond this channel step")
        ->check(CLI::Range(0, 255));
    app.add_flag(
        "--save-frames", s.save_frames,
        "write the middle measured frame of every run at tau 1 (and the reference) as PNGs");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }

    s.maps = splitList(maps);
    for (const std::string& f : splitList(flights)) {
        auto k = lodlab::parseFlight(f);
        if (!k) {
            std::fprintf(stderr, "lod_bench: unknown flight '%s'\n", f.c_str());
            return 2;
        }
        s.flights.push_back(*k);
    }
    for (const std::string& m : splitList(methods)) {
        auto k = lodlab::parseMethod(m);
        if (!k) {
            std::fprintf(stderr, "lod_bench: unknown method '%s'\n", m.c_str());
            return 2;
        }
        s.methods.push_back(*k);
    }
    try {
        for (const std::string& t : splitList(taus))
            s.taus.push_back(std::stod(t));
        for (const std::string& c : splitList(caps))
            s.caps.push_back(std::stoll(c));
    } catch (const std::exception&) {
        std::fprintf(stderr, "lod_bench: --taus and --caps take comma lists of numbers\n");
        return 2;
    }
    for (double t : s.taus)
        if (!(t > 0.0)) {
            std::fprintf(stderr, "lod_bench: every tau must be positive\n");
            return 2;
        }
    return std::nullopt;
}

/// runs.csv and frames.csv in the output folder, with their header lines.
struct CsvFiles {
    std::ofstream frames;
    std::ofstream runs;
};

std::optional<CsvFiles> openCsvFiles(const std::string& out_dir) {
    std::error_code ec;
    fs::create_directories(out_dir, ec);
    CsvFiles f{
        std::ofstream(fs::path(out_dir) / "frames.csv"),
        std::ofstream(fs::path(out_dir) / "runs.csv")};
    if (!f.frames || !f.runs) {
        std::fprintf(stderr, "lod_bench: cannot write into %s\n", out_dir.c_str());
        return std::nullopt;
    }
    f.frames
        << "map,flight,method,tau,cap,frame,cpu_ms,triangles,upload_bytes,bound_px,"
           "error_max_px,error_p99_px,open_edges,event,image_diff,psnr_db,popping,lod_change\n";
    f.runs << "map,flight,method,tau,cap,cpu_p50_ms,cpu_p99_ms,cpu_max_ms,triangles_p50,"
              "triangles_max,upload_mean_bytes,upload_p99_bytes,bound_max_px,error_max_px,"
              "error_p99_px,error_mean_px,measured_frames,frames_over_tau,frames_capped,"
              "rebuilds,open_edges,memory_bytes,build_ms,image_diff_mean,image_diff_max,"
              "psnr_mean_db,psnr_min_db,popping_mean,popping_max,lod_change_mean,lod_change_max\n";
    return f;
}

/// The image measures' renderer (OSMesa), for one map at a time; absent with --no-images or
/// where no context can be made.
struct Images {
    std::unique_ptr<render::GlContext> gl;
    std::unique_ptr<render::MeshRenderer> painter;
    std::array<std::uint8_t, 3> sky_rgb{};
    int threshold = 16;
};

std::optional<Images> openImages(const Settings& s, Json& report) {
    if (!s.images)
        return std::nullopt;
    auto context =
        render::createOffscreenContext(render::OffscreenBackend::kOsmesa, s.width, s.height);
    if (!context) {
        std::fprintf(stderr, "lod_bench: no image measures: %s\n", context.error().message.c_str());
        return std::nullopt;
    }
    Images images;
    images.gl = std::move(*context);
    images.threshold = s.threshold;
    report["renderer"] = images.gl->describe();
    return images;
}

/// Points the image measures at `terrain`'s map; false (with a message) if it cannot.
bool imagesForMap(Images& images, const Terrain& terrain) {
    auto made = render::MeshRenderer::create(*images.gl, terrain);
    if (!made) {
        std::fprintf(stderr, "lod_bench: %s\n", made.error().message.c_str());
        return false;
    }
    images.painter = std::move(*made);
    // the sky's colour as read back: nothing drawn
    const io::RgbImage empty = images.painter->render({}, terrain, roam::Camera{});
    images.sky_rgb = {empty.rgb[0], empty.rgb[1], empty.rgb[2]};
    return true;
}

/// A flight over a map: the world it starts from (the battle's pre_shots craters fired), the
/// battle's generator where the pre-battle stopped, the cameras, and the frames measured. Every
/// run of the flight starts from the same world, so each method sees the same one.
struct FlightSetup {
    lodlab::FlightKind kind{};
    Terrain start;
    BattleGenerator pre;
    std::vector<lodlab::FlightFrame> frames;
    std::vector<int> measured_at;
    /// The full-resolution renders of the measured frames and their predecessors, made during
    /// the flight's first run.
    std::map<int, io::RgbImage> reference;

    bool measured(int frame) const {
        return std::find(measured_at.begin(), measured_at.end(), frame) != measured_at.end();
    }
};

FlightSetup prepareFlight(const Settings& s, const Terrain& map, lodlab::FlightKind kind) {
    Terrain start = map;
    BattleGenerator pre = lodlab::battleGenerator(start);
    if (kind == lodlab::FlightKind::kBattle)
        lodlab::fireShots(pre, start, s.pre_shots);
    lodlab::FlightOptions fo;
    fo.kind = kind;
    fo.frames = s.frames;
    fo.width = s.width;
    fo.height = s.height;
    std::vector<lodlab::FlightFrame> frames = lodlab::makeFlight(start, fo);
    std::vector<int> measured_at;
    for (int m = 0; m < s.measures; ++m)
        measured_at.push_back(static_cast<int>(
            (static_cast<std::int64_t>(m) * s.frames + s.frames / 2) / s.measures));
    return {kind, std::move(start), std::move(pre), std::move(frames), std::move(measured_at), {}};
}

/// Fires the frame's shots into `world`; the cells each changed.
std::vector<CellRect> fireFrameShots(BattleGenerator& gen, Terrain& world, int shots) {
    std::vector<CellRect> changed;
    for (int s = 0; s < shots; ++s) {
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
    return changed;
}

/// One run: a method at a tau and cap, flown over a flight, measured as it goes.
class Run {
  public:
    Run(const Settings& s,
        FlightSetup& flight,
        Images* images,
        lodlab::Method method,
        double tau,
        std::int64_t cap,
        const std::string& map_name)
        : s_(s), flight_(flight), images_(images), world_(flight.start), gen_(flight.pre),
          tau_(tau), cap_(cap), map_name_(map_name) {
        lodlab::MethodOptions mo;
        mo.tau_pixels = tau;
        mo.max_triangles = cap > 0 ? cap : std::int64_t{1} << 40;
        r_.key = {map_name, lodlab::toString(flight.kind), method, tau, cap};
        const auto build = bench::Clock::now();
        lod_ = lodlab::makeMethod(method, world_, mo);
        r_.build_ms = bench::msSince(build);
        if (images_ != nullptr && flight_.reference.empty())
            truth_ = lodlab::makeMethod(lodlab::Method::kFullMesh, world_, mo);
        r_.psnr_min = lodlab::kPsnrIdentical;
    }

    /// Flies every frame, writing a frames.csv line each; the run's summary.
    RunResult fly(std::ostream& frames_csv) {
        for (int i = 0; i < s_.frames; ++i)
            frame(i, frames_csv);
        return finish();
    }

  private:
    /// What a frame measured beyond its timing (absent fields: not measured).
    struct FrameMeasures {
        lodlab::ImageError image;
        double popped = -1.0;
        double lod_change = -1.0;
        lodlab::MeshError error;
        std::int64_t open = -1;
    };

    void frame(int i, std::ostream& frames_csv) {
        const lodlab::FlightFrame& ff = flight_.frames[static_cast<std::size_t>(i)];
        const std::vector<CellRect> changed = fireFrameShots(gen_, world_, ff.shots);
        // the frame's CPU: taking the changes in, then the update
        const auto t0 = bench::Clock::now();
        if (!changed.empty())
            lod_->terrainChanged(changed, false);
        const lodlab::MethodFrame f = lod_->update(ff.camera);
        const double ms = bench::msSince(t0);
        const bool measure = flight_.measured(i);
        const bool before_measure = flight_.measured(i + 1);
        if (truth_) {
            if (!changed.empty())
                truth_->terrainChanged(changed, false);
            if (measure || before_measure) {
                truth_->update(ff.camera);
                truth_->visibleTriangles(drawn_);
                flight_.reference[i] = images_->painter->render(drawn_, world_, ff.camera);
            }
        }
        FrameMeasures fm;
        if (images_ != nullptr && (measure || before_measure))
            measureImages(i, ff, measure, before_measure, fm);
        else {
            previous_.rgb.clear();
            previous_mesh_.clear();
        }
        cpu_.push_back(ms);
        tris_.push_back(static_cast<double>(f.triangles));
        upload_.push_back(static_cast<double>(f.upload_bytes));
        r_.bound_max = std::max(r_.bound_max, f.error_bound_pixels);
        r_.frames_capped += f.over_budget ? 1 : 0;
        r_.rebuilds += f.rebuilt ? 1 : 0;
        if (measure)
            measureMesh(ff, fm);
        writeFrame(i, ff, changed, ms, f, measure, fm, frames_csv);
    }

    /// The image measures of a measured frame (or the one before it): against the
    /// full-resolution render, popping, and how much the mesh changed since last frame.
    void measureImages(
        int i,
        const lodlab::FlightFrame& ff,
        bool measure,
        bool before_measure,
        FrameMeasures& fm) {
        const int threshold = images_->threshold;
        lod_->visibleTriangles(drawn_);
        io::RgbImage shot = images_->painter->render(drawn_, world_, ff.camera);
        if (measure && !previous_mesh_.empty()) {
            const io::RgbImage was = images_->painter->render(previous_mesh_, world_, ff.camera);
            fm.lod_change = lodlab::meshChangeShare(was, shot, images_->sky_rgb, threshold);
            r_.lod_change_mean += fm.lod_change;
            r_.lod_change_max = std::max(r_.lod_change_max, fm.lod_change);
        }
        previous_mesh_.clear();
        if (before_measure)
            previous_mesh_ = drawn_;
        if (measure) {
            fm.image = lodlab::compareImages(shot, flight_.reference[i], threshold);
            if (!previous_.rgb.empty() && flight_.reference.count(i - 1) != 0)
                fm.popped = lodlab::poppingShare(
                    previous_, shot, flight_.reference[i - 1], flight_.reference[i], threshold);
            ++r_.imaged_frames;
            r_.image_diff_mean += fm.image.differing_share;
            r_.image_diff_max = std::max(r_.image_diff_max, fm.image.differing_share);
            psnr_sum_ += fm.image.psnr_db;
            r_.psnr_min = std::min(r_.psnr_min, fm.image.psnr_db);
            if (fm.popped >= 0.0) {
                r_.popping_mean += fm.popped;
                r_.popping_max = std::max(r_.popping_max, fm.popped);
            }
            if (s_.save_frames && tau_ == 1.0 && cap_ == s_.caps.front() &&
                i == flight_.measured_at[flight_.measured_at.size() / 2])
                saveFrame(shot, flight_.reference[i]);
        }
        previous_ = std::move(shot);
    }

    void saveFrame(const io::RgbImage& shot, const io::RgbImage& reference) const {
        const std::string stem = map_name_ + "_" + lodlab::toString(flight_.kind) + "_";
        const fs::path dir = fs::path(s_.out_dir) / "frames";
        (void)io::writeRgbPng(dir / (stem + lodlab::toString(r_.key.method) + ".png"), shot);
        (void)io::writeRgbPng(dir / (stem + "reference.png"), reference);
    }

    /// The screen error of what the method draws and the open edges of its whole mesh.
    void measureMesh(const lodlab::FlightFrame& ff, FrameMeasures& fm) {
        lod_->visibleTriangles(drawn_);
        lodlab::ScreenErrorOptions so;
        so.tau_pixels = tau_;
        fm.error = lodlab::measureMeshError(drawn_, world_, ff.camera, so);
        ++r_.measured_frames;
        r_.error_max = std::max(r_.error_max, fm.error.max_pixels);
        r_.error_p99 = std::max(r_.error_p99, fm.error.p99_pixels);
        mean_sum_ += fm.error.mean_pixels;
        r_.frames_over_tau += fm.error.max_pixels > tau_ ? 1 : 0;
        lod_->allTriangles(mesh_);
        fm.open = lodlab::countOpenEdges(
            mesh_, std::int64_t{world_.spec().cellsX()} * 16,
            std::int64_t{world_.spec().cellsY()} * 16);
        r_.open_edges = std::max(r_.open_edges, fm.open);
    }

    void writeFrame(
        int i,
        const lodlab::FlightFrame& ff,
        const std::vector<CellRect>& changed,
        double ms,
        const lodlab::MethodFrame& f,
        bool measure,
        const FrameMeasures& fm,
        std::ostream& frames_csv) const {
        const bool images = images_ != nullptr;
        const char* event = ff.teleport ? "teleport" : !changed.empty() ? "crater" : "";
        char line[512];
        std::snprintf(
            line, sizeof line, "%s,%s,%s,%g,%lld,%d,%.4f,%lld,%lld,%.4f,%s,%s,%s,%s,%s,%s,%s,%s\n",
            map_name_.c_str(), lodlab::toString(flight_.kind), lodlab::toString(r_.key.method),
            tau_, static_cast<long long>(cap_), i, ms, static_cast<long long>(f.triangles),
            static_cast<long long>(f.upload_bytes), f.error_bound_pixels,
            measure ? std::to_string(fm.error.max_pixels).c_str() : "",
            measure ? std::to_string(fm.error.p99_pixels).c_str() : "",
            measure ? std::to_string(fm.open).c_str() : "", event,
            measure && images ? std::to_string(fm.image.differing_share).c_str() : "",
            measure && images ? std::to_string(fm.image.psnr_db).c_str() : "",
            fm.popped >= 0.0 ? std::to_string(fm.popped).c_str() : "",
            fm.lod_change >= 0.0 ? std::to_string(fm.lod_change).c_str() : "");
        frames_csv << line;
    }

    RunResult finish() {
        r_.error_mean = r_.measured_frames > 0 ? mean_sum_ / r_.measured_frames : 0;
        if (r_.imaged_frames > 0) {
            r_.image_diff_mean /= r_.imaged_frames;
            r_.psnr_mean = psnr_sum_ / r_.imaged_frames;
            // the first measured frame may have no predecessor rendered
            const int popped_frames = r_.imaged_frames - (flight_.measured_at.front() == 0 ? 1 : 0);
            if (popped_frames > 0) {
                r_.popping_mean /= popped_frames;
                r_.lod_change_mean /= popped_frames;
            }
        }
        r_.memory_bytes = lod_->memoryBytes();
        r_.cpu_ms = bench::summarize(cpu_);
        r_.triangles = bench::summarize(tris_);
        r_.upload_bytes = bench::summarize(upload_);
        return r_;
    }

    const Settings& s_;
    FlightSetup& flight_;
    Images* images_;
    Terrain world_;
    BattleGenerator gen_; ///< continues where the pre-battle stopped
    double tau_;
    std::int64_t cap_;
    std::string map_name_;
    std::unique_ptr<lodlab::LodMethod> lod_;
    std::unique_ptr<lodlab::LodMethod> truth_; ///< the full mesh, while references are made
    RunResult r_;
    io::RgbImage previous_;
    std::vector<glm::dvec3> previous_mesh_; ///< last frame's, when measuring
    double psnr_sum_ = 0.0;
    double mean_sum_ = 0.0;
    std::vector<double> cpu_;
    std::vector<double> tris_;
    std::vector<double> upload_;
    std::vector<glm::dvec3> drawn_;
    std::vector<lodlab::LatticeTriangle> mesh_;
};

/// A run's runs.csv line (also printed) and its entry in runs.json.
void writeRun(const RunResult& r, std::ostream& runs_csv, Json& runs) {
    char line[1024];
    std::snprintf(
        line, sizeof line,
        "%s,%s,%s,%g,%lld,%.4f,%.4f,%.4f,%.0f,%.0f,%.0f,%.0f,%.4f,%.4f,%.4f,"
        "%.4f,%d,%d,%d,%d,%lld,%zu,%.1f,%.5f,%.5f,%.2f,%.2f,%.5f,%.5f,%.6f,%."
        "6f\n",
        r.key.map.c_str(), r.key.flight.c_str(), lodlab::toString(r.key.method), r.key.tau,
        static_cast<long long>(r.key.cap), r.cpu_ms.p50, r.cpu_ms.p99, r.cpu_ms.max,
        r.triangles.p50, r.triangles.max, r.upload_bytes.mean, r.upload_bytes.p99, r.bound_max,
        r.error_max, r.error_p99, r.error_mean, r.measured_frames, r.frames_over_tau,
        r.frames_capped, r.rebuilds, static_cast<long long>(r.open_edges), r.memory_bytes,
        r.build_ms, r.image_diff_mean, r.image_diff_max, r.psnr_mean, r.psnr_min, r.popping_mean,
        r.popping_max, r.lod_change_mean, r.lod_change_max);
    runs_csv << line;
    std::printf("  %s", line);
    std::fflush(stdout);
    Json j = Json::object();
    j["map"] = r.key.map;
    j["flight"] = r.key.flight;
    j["method"] = lodlab::toString(r.key.method);
    j["tau_px"] = r.key.tau;
    j["cap"] = r.key.cap;
    j["cpu_ms"] = {{"p50", r.cpu_ms.p50}, {"p99", r.cpu_ms.p99}, {"max", r.cpu_ms.max}};
    j["triangles"] = {{"p50", r.triangles.p50}, {"max", r.triangles.max}};
    j["upload_bytes"] = {{"mean", r.upload_bytes.mean}, {"p99", r.upload_bytes.p99}};
    j["bound_max_px"] = r.bound_max;
    j["screen_error_px"] = {{"max", r.error_max}, {"p99", r.error_p99}, {"mean", r.error_mean}};
    j["measured_frames"] = r.measured_frames;
    j["frames_over_tau"] = r.frames_over_tau;
    j["frames_capped"] = r.frames_capped;
    j["rebuilds"] = r.rebuilds;
    j["open_edges"] = r.open_edges;
    j["memory_bytes"] = r.memory_bytes;
    j["build_ms"] = r.build_ms;
    if (r.imaged_frames > 0) {
        j["image_differing_share"] = {{"mean", r.image_diff_mean}, {"max", r.image_diff_max}};
        j["psnr_db"] = {{"mean", r.psnr_mean}, {"min", r.psnr_min}};
        j["popping_share"] = {{"mean", r.popping_mean}, {"max", r.popping_max}};
        j["lod_change_share"] = {{"mean", r.lod_change_mean}, {"max", r.lod_change_max}};
    }
    runs.push_back(j);
}

/// Every run of one map: each flight, method, tau and cap (the full mesh once per flight: it
/// takes neither). Whether a chunked or ROAM mesh had an open edge; nullopt if the map or its
/// image measures could not be made.
std::optional<bool>
runMap(const Settings& s, const std::string& map_name, Images* images, CsvFiles& csv, Json& runs) {
    std::string error;
    auto map = loadMap(map_name, s.dem_dir, error);
    if (!map) {
        std::fprintf(stderr, "lod_bench: %s\n", error.c_str());
        return std::nullopt;
    }
    std::printf("map %s: %s\n", map->name.c_str(), map->note.c_str());
    if (images != nullptr && !imagesForMap(*images, *map->terrain))
        return std::nullopt;
    bool cracked = false;
    for (lodlab::FlightKind kind : s.flights) {
        FlightSetup flight = prepareFlight(s, *map->terrain, kind);
        for (lodlab::Method method : s.methods)
            for (double tau : s.taus)
                for (std::int64_t cap : s.caps) {
                    if (method == lodlab::Method::kFullMesh &&
                        (tau != s.taus.front() || cap != s.caps.front()))
                        continue;
                    const RunResult r =
                        Run(s, flight, images, method, tau, cap, map->name).fly(csv.frames);
                    if (method != lodlab::Method::kFullMesh && r.open_edges > 0)
                        cracked = true;
                    writeRun(r, csv.runs, runs);
                }
    }
    if (images != nullptr)
        images->painter.reset(); // the map's renderer goes with it
    return cracked;
}

} // namespace

int main(int argc, char** argv) {
    Settings s;
    if (const std::optional<int> stop = parseSettings(argc, argv, s))
        return *stop;
    std::optional<CsvFiles> csv = openCsvFiles(s.out_dir);
    if (!csv)
        return 2;

    Json report = Json::object();
    report["benchmark"] = "lod_bench";
    report["date"] = bench::isoNow();
    report["cpu"] = bench::cpuModel();
    report["frames"] = s.frames;
    report["viewport"] = {s.width, s.height};
    std::optional<Images> images = openImages(s, report);
    report["image_threshold"] = s.threshold;
    if (s.save_frames) {
        std::error_code ec;
        fs::create_directories(fs::path(s.out_dir) / "frames", ec);
    }

    Json runs = Json::array();
    bool cracked = false;
    for (const std::string& map_name : s.maps) {
        const std::optional<bool> map_cracked =
            runMap(s, map_name, images ? &*images : nullptr, *csv, runs);
        if (!map_cracked)
            return 2;
        cracked = cracked || *map_cracked;
    }
    report["runs"] = runs;
    std::ofstream(fs::path(s.out_dir) / "runs.json") << report.dump(2) << "\n";
    if (cracked) {
        std::fprintf(stderr, "lod_bench: a chunked or ROAM mesh had open edges (see runs.csv)\n");
        return 1;
    }
    return 0;
}
