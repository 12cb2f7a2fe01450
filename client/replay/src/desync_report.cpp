#include <terrain/assert.h>
#include <terrain/io/png_image.h>
#include <terrain/replay/desync_report.h>
#include <terrain/snapshot.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>

namespace terrain::replay {
namespace {

namespace fs = std::filesystem;

std::string hex(std::uint64_t v) {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016" PRIx64, v);
    return buf;
}

TileRecord tileOf(const Terrain& t, std::int32_t tile) {
    std::vector<std::uint8_t> bytes;
    t.appendTileBytes(tile, bytes);
    auto decoded = decodeTile(bytes, t.spec());
    // our own encoding of a valid state: a failure here is a bug, not input
    TERRAIN_ASSERT(decoded.ok());
    return std::move(*decoded);
}

/// cell -> patch, for comparing two tiles' patches.
std::map<std::uint16_t, const DetailPatch*> patchesByCell(const TileRecord& r) {
    std::map<std::uint16_t, const DetailPatch*> out;
    for (const PatchEntry& e : r.patches)
        out[e.cell] = &e.patch;
    return out;
}

/// Cells (in tile) whose patch differs, appears or disappears.
std::vector<std::uint16_t> differingPatchCells(const TileRecord& a, const TileRecord& b) {
    const auto pa = patchesByCell(a);
    const auto pb = patchesByCell(b);
    std::vector<std::uint16_t> cells;
    for (const auto& [cell, patch] : pa) {
        auto other = pb.find(cell);
        if (other == pb.end() || !(*other->second == *patch))
            cells.push_back(cell);
    }
    for (const auto& [cell, patch] : pb)
        if (!pa.count(cell))
            cells.push_back(cell);
    std::sort(cells.begin(), cells.end());
    return cells;
}

Status writeText(const fs::path& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out)
        return makeError(ErrorCode::kIo, "cannot write " + path.string());
    return Ok{};
}

std::string dumpTile(const TileRecord& r, const Terrain& t, const std::string& side) {
    const WorldSpec& spec = t.spec();
    const std::int32_t tx = r.tile % spec.tilesX();
    const std::int32_t ty = r.tile / spec.tilesX();
    std::string out;
    char line[160];
    std::snprintf(
        line, sizeof line,
        "# tile %d (%s): cells x %d..%d, y %d..%d; tile hash %s; %zu detail patches\n", r.tile,
        side.c_str(), tx * kTileCells, tx * kTileCells + kTileCells - 1, ty * kTileCells,
        ty * kTileCells + kTileCells - 1, hex(t.tileHash(r.tile)).c_str(), r.patches.size());
    out += line;
    std::snprintf(
        line, sizeof line, "# heights in quanta (%d per metre), %d x %d, row-major from y %d\n",
        spec.units_per_metre, kTileVertices, kTileVertices, ty * kTileCells);
    out += line;
    auto grid = [&](const char* title, const std::vector<std::int32_t>& v) {
        out += title;
        for (int y = 0; y < kTileVertices; ++y) {
            for (int x = 0; x < kTileVertices; ++x) {
                std::snprintf(
                    line, sizeof line, x == 0 ? "%d" : " %d",
                    v[static_cast<std::size_t>(y * kTileVertices + x)]);
                out += line;
            }
            out += '\n';
        }
    };
    grid("samples\n", r.samples);
    grid("originals\n", r.originals);
    out += "patches (cell x y: 25 controls in sixths of a quantum, row-major)\n";
    for (const PatchEntry& e : r.patches) {
        std::snprintf(line, sizeof line, "%d %d:", e.cell % kTileCells, e.cell / kTileCells);
        out += line;
        for (const std::int32_t c : e.patch.control) {
            std::snprintf(line, sizeof line, " %d", c);
            out += line;
        }
        out += '\n';
    }
    return out;
}

/// Grey relief (expected heights over the area), red/blue for higher/lower observed ground,
/// yellow for cells where only a patch differs.
io::RgbImage differencePicture(
    const Terrain& expected,
    const Terrain& observed,
    const std::vector<TileDifference>& tiles,
    const std::vector<std::vector<std::uint16_t>>& patch_cells) {
    const WorldSpec& spec = expected.spec();
    std::int32_t x0 = spec.width, y0 = spec.height, x1 = 0, y1 = 0;
    for (const TileDifference& d : tiles) {
        const std::int32_t tx = d.tile % spec.tilesX() * kTileCells;
        const std::int32_t ty = d.tile / spec.tilesX() * kTileCells;
        x0 = std::min(x0, tx);
        y0 = std::min(y0, ty);
        x1 = std::max(x1, std::min(tx + kTileCells, spec.width - 1));
        y1 = std::max(y1, std::min(ty + kTileCells, spec.height - 1));
    }
    const std::int32_t w = x1 - x0 + 1;
    const std::int32_t h = y1 - y0 + 1;
    const std::int32_t scale = std::max(1, 512 / std::max(w, h));
    std::int32_t lo = INT32_MAX, hi = INT32_MIN;
    std::int64_t max_diff = 1;
    for (std::int32_t y = y0; y <= y1; ++y)
        for (std::int32_t x = x0; x <= x1; ++x) {
            lo = std::min(lo, expected.sample(x, y));
            hi = std::max(hi, expected.sample(x, y));
            max_diff = std::max<std::int64_t>(
                max_diff, std::llabs(std::int64_t{observed.sample(x, y)} - expected.sample(x, y)));
        }
    io::RgbImage image;
    image.width = w * scale;
    image.height = h * scale;
    image.rgb.assign(
        static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * 3, 0);
    auto put = [&](std::int32_t vx, std::int32_t vy, std::uint8_t r, std::uint8_t g,
                   std::uint8_t b) {
        for (std::int32_t sy = 0; sy < scale; ++sy)
            for (std::int32_t sx = 0; sx < scale; ++sx) {
                // north up: the last row of the map is the picture's first
                const auto row = static_cast<std::size_t>((h - 1 - (vy - y0)) * scale + sy);
                const auto column = static_cast<std::size_t>((vx - x0) * scale + sx);
                const std::size_t at = (row * static_cast<std::size_t>(image.width) + column) * 3;
                image.rgb[at] = r;
                image.rgb[at + 1] = g;
                image.rgb[at + 2] = b;
            }
    };
    for (std::int32_t y = y0; y <= y1; ++y)
        for (std::int32_t x = x0; x <= x1; ++x) {
            const std::int64_t d = std::int64_t{observed.sample(x, y)} - expected.sample(x, y);
            const auto grey = static_cast<std::uint8_t>(
                40 + 120 * (hi > lo ? double(expected.sample(x, y) - lo) / (hi - lo) : 0.5));
            if (d == 0) {
                put(x, y, grey, grey, grey);
                continue;
            }
            const auto level = static_cast<std::uint8_t>(
                96 + 159 * std::sqrt(static_cast<double>(std::llabs(d)) / double(max_diff)));
            if (d > 0)
                put(x, y, level, 0, 0);
            else
                put(x, y, 0, 0, level);
        }
    for (std::size_t i = 0; i < tiles.size(); ++i) {
        const std::int32_t tx = tiles[i].tile % spec.tilesX() * kTileCells;
        const std::int32_t ty = tiles[i].tile / spec.tilesX() * kTileCells;
        for (const std::uint16_t cell : patch_cells[i]) {
            const std::int32_t cx = tx + cell % kTileCells;
            const std::int32_t cy = ty + cell / kTileCells;
            if (observed.sample(cx, cy) == expected.sample(cx, cy))
                put(cx, cy, 230, 210, 0);
        }
    }
    return image;
}

} // namespace

std::vector<TileDifference> differingTiles(const Terrain& expected, const Terrain& observed) {
    std::vector<TileDifference> out;
    const double metres_per_quantum = 1.0 / expected.spec().units_per_metre;
    for (std::int32_t t = 0; t < expected.spec().tileCount(); ++t) {
        if (expected.tileHash(t) == observed.tileHash(t))
            continue;
        const TileRecord a = tileOf(expected, t);
        const TileRecord b = tileOf(observed, t);
        TileDifference d;
        d.tile = t;
        d.expected_hash = expected.tileHash(t);
        d.observed_hash = observed.tileHash(t);
        std::int64_t largest = 0;
        for (std::size_t i = 0; i < a.samples.size(); ++i) {
            const std::int64_t diff = std::int64_t{b.samples[i]} - a.samples[i];
            d.samples_differing += diff != 0 ? 1 : 0;
            largest = std::max<std::int64_t>(largest, std::llabs(diff));
        }
        d.patches_differing = differingPatchCells(a, b).size();
        d.max_difference_metres = static_cast<double>(largest) * metres_per_quantum;
        out.push_back(d);
    }
    return out;
}

Status writeDesyncReport(
    const fs::path& dir,
    const DesyncFacts& facts,
    const Terrain& expected,
    const Terrain& observed) {
    const WorldSpec& a = expected.spec();
    const WorldSpec& b = observed.spec();
    if (a.width != b.width || a.height != b.height || a.units_per_metre != b.units_per_metre)
        return makeError(ErrorCode::kSizeMismatch, "the two states are not of one world");
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec)
        return makeError(ErrorCode::kIo, "cannot create " + dir.string() + ": " + ec.message());

    const std::vector<TileDifference> tiles = differingTiles(expected, observed);
    std::vector<std::vector<std::uint16_t>> patch_cells;
    nlohmann::json tiles_json = nlohmann::json::array();
    for (const TileDifference& d : tiles) {
        const TileRecord e = tileOf(expected, d.tile);
        const TileRecord o = tileOf(observed, d.tile);
        patch_cells.push_back(differingPatchCells(e, o));
        const std::string stem = "tile-" + std::to_string(d.tile);
        if (Status s = writeText(dir / (stem + "-expected.txt"), dumpTile(e, expected, "expected"));
            !s)
            return s;
        if (Status s = writeText(dir / (stem + "-observed.txt"), dumpTile(o, observed, "observed"));
            !s)
            return s;
        tiles_json.push_back(
            {{"tile", d.tile},
             {"cells_x", {d.tile % a.tilesX() * kTileCells, d.tile % a.tilesX() * kTileCells + 63}},
             {"cells_y", {d.tile / a.tilesX() * kTileCells, d.tile / a.tilesX() * kTileCells + 63}},
             {"expected_tile_hash", hex(d.expected_hash)},
             {"observed_tile_hash", hex(d.observed_hash)},
             {"samples_differing", d.samples_differing},
             {"patches_differing", d.patches_differing},
             {"max_difference_metres", d.max_difference_metres},
             {"expected_dump", stem + "-expected.txt"},
             {"observed_dump", stem + "-observed.txt"}});
    }
    if (!tiles.empty())
        if (Status s = io::writeRgbPng(
                dir / "difference.png", differencePicture(expected, observed, tiles, patch_cells));
            !s)
            return s;

    const double u = a.units_per_metre;
    nlohmann::json report = {
        {"seq", facts.seq},
        {"journal", facts.where},
        {"who", facts.who},
        {"expected_world_hash", hex(facts.expected_hash)},
        {"observed_world_hash", hex(facts.observed_hash)},
        {"op",
         {{"kind", toString(facts.op.kind)},
          {"x_m", static_cast<double>(facts.op.center_x) / u},
          {"y_m", static_cast<double>(facts.op.center_y) / u},
          {"radius_m", facts.op.radius / u},
          {"height_m", facts.op.height / u},
          {"strength", facts.op.strength / 65536.0},
          {"text", describe(facts.op, a)}}},
        {"tiles", tiles_json},
        {"picture", tiles.empty() ? "" : "difference.png"}};
    if (Status s = writeText(dir / "report.json", report.dump(2) + "\n"); !s)
        return s;

    std::string text = "desync at seq " + std::to_string(facts.seq) + " of " + facts.where +
                       "\n  who:  " + facts.who + "\n  op:   " + describe(facts.op, a) +
                       "\n  hash: expected " + hex(facts.expected_hash) + ", observed " +
                       hex(facts.observed_hash) + "\n  " + std::to_string(tiles.size()) +
                       " tile(s) differ:\n";
    for (const TileDifference& d : tiles) {
        char line[200];
        std::snprintf(
            line, sizeof line,
            "    tile %d: %zu samples and %zu patches differ, at most %.4f m (diff -u "
            "tile-%d-expected.txt tile-%d-observed.txt)\n",
            d.tile, d.samples_differing, d.patches_differing, d.max_difference_metres, d.tile,
            d.tile);
        text += line;
    }
    text += "  difference.png: grey relief where equal; red: observed higher, blue: lower "
            "(brighter: nearer the largest difference); yellow: only a detail patch differs\n";
    return writeText(dir / "report.txt", text);
}

} // namespace terrain::replay
