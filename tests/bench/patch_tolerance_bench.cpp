// Patches, memory and shape error against the patch tolerance.
//
// Scenario "single": one crater of radius R (depth 0.4 R, rim 0.25 R-depth) on a flat 1 m grid;
// the represented surface (base triangles + patches) is sampled every 1/32 m over the crater's
// footprint and compared with the analytic crater. Reported: max error, max error away from the
// rim crease (outside the cells the crease crosses, |r - R| > 1.5 h: no C2 patch follows a
// crease inside a cell), RMS error.
// Scenario "series": the default map with the main job's 200-crater series: patches and memory.
// A tolerance of 1000 m means "no patches": the grid alone.
//
// Output: CSV (one row per scenario x tolerance x radius) to stdout or --csv FILE, and a JSON
// summary to --json FILE.

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/surface_query.h>
#include <terrain/terrain.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace terrain;

struct Row {
    std::string scenario;
    double tolerance_m = 0;
    double radius_m = 0;
    std::size_t patches = 0;
    std::size_t patch_bytes = 0;
    double max_err_m = 0;
    double max_err_off_rim_m = 0;
    double rms_err_m = 0;
    double apply_ms = 0;
};

double craterProfile(double r, double radius, double depth, double rim) {
    const double t = r / radius;
    if (t < 1.0)
        return -depth + (depth + rim) * t * t;
    if (t < 2.0)
        return rim * (2.0 - t) * (2.0 - t);
    return 0.0;
}

Row single(double tol, double radius) {
    WorldSpec spec;
    spec.width = spec.height = 129;
    spec.patch_tolerance = static_cast<std::int32_t>(std::lround(tol * spec.units_per_metre));
    std::vector<std::int32_t> flat(129 * 129, 10 * 1024);
    Terrain t = std::move(*Terrain::create(spec, flat));
    const double cx = 64.37;
    const double cy = 63.81;
    const auto op = *quantizeOp({OpKind::kCrater, cx, cy, radius, 0.4 * radius, 0.25}, spec);
    const auto start = std::chrono::steady_clock::now();
    (void)t.apply(op);
    Row row;
    row.apply_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    row.scenario = "single";
    row.tolerance_m = tol;
    row.radius_m = radius;
    row.patches = t.patchCount();
    row.patch_bytes = t.memoryUsage().patch_bytes;
    // the op as quantized, in metres
    const double qx = static_cast<double>(op.center_x) / 1024;
    const double qy = static_cast<double>(op.center_y) / 1024;
    const double qr = op.radius / 1024.0;
    const double depth = op.height / 1024.0;
    const double rim = depth * op.strength / 65536.0;
    double sum2 = 0;
    long n = 0;
    const double reach = 2.0 * qr + 1.0;
    for (double y = qy - reach; y <= qy + reach; y += 1.0 / 32)
        for (double x = qx - reach; x <= qx + reach; x += 1.0 / 32) {
            const double r = std::hypot(x - qx, y - qy);
            const double err =
                std::abs(surfaceHeight(t, x, y) - (10.0 + craterProfile(r, qr, depth, rim)));
            row.max_err_m = std::max(row.max_err_m, err);
            if (std::abs(r - qr) > 1.5) // outside the cells the rim crease crosses
                row.max_err_off_rim_m = std::max(row.max_err_off_rim_m, err);
            sum2 += err * err;
            ++n;
        }
    row.rms_err_m = std::sqrt(sum2 / static_cast<double>(n));
    return row;
}

Row series(double tol) {
    ProceduralMapOptions o;
    o.patch_tolerance_metres = tol;
    Terrain t = std::move(*makeProceduralMap(o));
    CraterSeries s;
    s.count = 200;
    const auto ops = randomCraters(t.spec(), s);
    const auto start = std::chrono::steady_clock::now();
    for (const OpRequest& r : ops)
        (void)t.apply(*quantizeOp(r, t.spec()));
    Row row;
    row.apply_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count() /
        200.0;
    row.scenario = "series200";
    row.tolerance_m = tol;
    row.radius_m = 0;
    row.patches = t.patchCount();
    row.patch_bytes = t.memoryUsage().patch_bytes;
    return row;
}

} // namespace

int main(int argc, char** argv) {
    std::string csv_path;
    std::string json_path;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (std::strcmp(argv[i], "--csv") == 0)
            csv_path = argv[i + 1];
        else if (std::strcmp(argv[i], "--json") == 0)
            json_path = argv[i + 1];
    }
    const double tolerances[] = {1.0 / 256, 1.0 / 128, 1.0 / 64, 1.0 / 32, 1.0 / 16,
                                 1.0 / 8,   1.0 / 4,   1.0 / 2,  1000.0};
    std::vector<Row> rows;
    for (double tol : tolerances)
        for (double radius : {0.5, 1.0, 2.0, 4.0, 8.0})
            rows.push_back(single(tol, radius));
    for (double tol : tolerances)
        rows.push_back(series(tol));

    std::ostringstream csv;
    csv << "scenario,tolerance_m,radius_m,patches,patch_bytes,max_err_m,max_err_off_rim_m,rms_err_"
           "m,apply_ms\n";
    for (const Row& r : rows)
        csv << r.scenario << ',' << r.tolerance_m << ',' << r.radius_m << ',' << r.patches << ','
            << r.patch_bytes << ',' << r.max_err_m << ',' << r.max_err_off_rim_m << ','
            << r.rms_err_m << ',' << r.apply_ms << '\n';
    if (csv_path.empty())
        std::fputs(csv.str().c_str(), stdout);
    else
        std::ofstream(csv_path) << csv.str();
    if (!json_path.empty()) {
        std::ofstream j(json_path);
        j << "{\n  \"bench\": \"patch_tolerance\",\n  \"bytes_per_patch\": " << kBytesPerPatch
          << ",\n  \"rows\": [\n";
        for (std::size_t i = 0; i < rows.size(); ++i) {
            const Row& r = rows[i];
            j << "    {\"scenario\": \"" << r.scenario << "\", \"tolerance_m\": " << r.tolerance_m
              << ", \"radius_m\": " << r.radius_m << ", \"patches\": " << r.patches
              << ", \"patch_bytes\": " << r.patch_bytes << ", \"max_err_m\": " << r.max_err_m
              << ", \"max_err_off_rim_m\": " << r.max_err_off_rim_m
              << ", \"rms_err_m\": " << r.rms_err_m << ", \"apply_ms\": " << r.apply_ms << "}"
              << (i + 1 < rows.size() ? "," : "") << "\n";
        }
        j << "  ]\n}\n";
    }
    return 0;
}
