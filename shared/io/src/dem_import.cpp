#include <terrain/io/dem_import.h>
#include <terrain/io/png_image.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <new>
#include <vector>

namespace terrain::io {
namespace {

using nlohmann::json;

Error badField(const std::string& field, const std::string& rule) {
    return makeError(ErrorCode::kBadFormat, "DEM sidecar: '" + field + "' " + rule);
}

// A positive finite number at json[a][b][c...], if present.
std::optional<double> positiveNumberAt(const json& j, std::initializer_list<const char*> path) {
    const json* node = &j;
    for (const char* key : path) {
        if (!node->is_object() || !node->contains(key))
            return std::nullopt;
        node = &(*node)[key];
    }
    if (!node->is_number())
        return std::nullopt;
    const double v = node->get<double>();
    if (!std::isfinite(v) || v <= 0.0)
        return std::nullopt;
    return v;
}

// Linear resampling along one axis: terrain index t reads source position t * ratio (clamped
// to the last sample, which a longer axis repeats for at most half a cell).
struct Tap {
    std::int32_t i0 = 0;
    std::int32_t i1 = 0;
    double f = 0.0;
};

std::vector<Tap> axisTaps(std::int32_t source_count, std::int32_t count, double ratio) {
    std::vector<Tap> taps(static_cast<std::size_t>(count));
    const double last = source_count - 1;
    for (std::int32_t t = 0; t < count; ++t) {
        const double u = std::min(t * ratio, last);
        Tap& tap = taps[static_cast<std::size_t>(t)];
        tap.i0 = static_cast<std::int32_t>(std::floor(u));
        tap.i1 = std::min(tap.i0 + 1, source_count - 1);
        tap.f = u - tap.i0;
    }
    return taps;
}

// Samples along an axis of `count` for `source_count` source samples `source_spacing` apart,
// at `spacing`: the count that keeps the extent within half a cell.
std::int64_t resampledCount(std::int32_t source_count, double source_spacing, double spacing) {
    return std::llround((source_count - 1) * source_spacing / spacing) + 1;
}

// Builds the terrain from heights in metres, row 0 north (already validated finite), with square
// cells of the finer of the two spacings, y pointing north.
Result<ImportedDem> buildTerrain(
    DemInfo info, const std::vector<double>& north_first, const DemImportOptions& options) {
    const double sx = info.source_spacing_x;
    const double sy = info.source_spacing_y;
    if (!std::isfinite(sx) || sx <= 0.0 || !std::isfinite(sy) || sy <= 0.0)
        return makeError(ErrorCode::kOutOfRange, "grid spacing must be positive and finite");
    const std::int32_t sw = info.source_width;
    const std::int32_t sh = info.source_height;
    const double spacing = std::min(sx, sy);
    const std::int64_t w = resampledCount(sw, sx, spacing);
    const std::int64_t h = resampledCount(sh, sy, spacing);
    if (w > kMaxMapVertices || h > kMaxMapVertices ||
        static_cast<std::uint64_t>(w * h) > options.max_samples)
        return makeError(
            ErrorCode::kOutOfRange, "square cells of " + std::to_string(spacing) + " m need " +
                                        std::to_string(w) + " x " + std::to_string(h) +
                                        " samples, beyond the import budget (at most " +
                                        std::to_string(kMaxMapVertices) + " per side, " +
                                        std::to_string(options.max_samples) + " in all)");
    info.width = static_cast<std::int32_t>(w);
    info.height = static_cast<std::int32_t>(h);
    info.spacing_metres = spacing;
    const double ratio_x = w == sw ? 1.0 : spacing / sx; // source cells per terrain cell
    const double ratio_y = h == sh ? 1.0 : spacing / sy;
    if (h != sh)
        info.resampling = "rows: " + std::to_string(sh) + " at " + std::to_string(sy) + " m -> " +
                          std::to_string(h) + " at " + std::to_string(spacing) +
                          " m, linear along y";
    if (w != sw)
        info.resampling = "columns: " + std::to_string(sw) + " at " + std::to_string(sx) +
                          " m -> " + std::to_string(w) + " at " + std::to_string(spacing) +
                          " m, linear along x";

    const double tolerance =
        options.patch_tolerance_metres.value_or(std::max(1.0 / 32.0, info.spacing_metres / 64.0));
    if (!std::isfinite(tolerance) || tolerance <= 0.0)
        return makeError(ErrorCode::kOutOfRange, "patch tolerance must be positive and finite");
    WorldSpec spec;
    spec.width = info.width;
    spec.height = info.height;
    spec.units_per_metre = options.units_per_metre;
    const double u = options.units_per_metre;
    const double spacing_q = std::round(info.spacing_metres * u);
    const double tol_q = std::round(tolerance * u);
    if (spacing_q < 1.0 || spacing_q > 1e9 || tol_q < 1.0 || tol_q > 1e9)
        return makeError(
            ErrorCode::kOutOfRange, "spacing or tolerance is not representable in quanta");
    spec.spacing = static_cast<std::int32_t>(spacing_q);
    spec.patch_tolerance = static_cast<std::int32_t>(tol_q);
    if (auto status = spec.validate(); !status)
        return status.error();

    // source sample (column x, row y counted from the south)
    const auto source = [&](std::int32_t x, std::int32_t y) {
        return north_first
            [static_cast<std::size_t>(sh - 1 - y) * static_cast<std::size_t>(sw) +
             static_cast<std::size_t>(x)];
    };
    const std::vector<Tap> tx = axisTaps(sw, info.width, ratio_x);
    const std::vector<Tap> ty = axisTaps(sh, info.height, ratio_y);
    std::vector<std::int32_t> samples(static_cast<std::size_t>(w * h));
    info.min_metres = std::numeric_limits<double>::infinity();
    info.max_metres = -std::numeric_limits<double>::infinity();
    for (std::int32_t y = 0; y < info.height; ++y) {
        const Tap& a = ty[static_cast<std::size_t>(y)];
        for (std::int32_t x = 0; x < info.width; ++x) {
            const Tap& b = tx[static_cast<std::size_t>(x)];
            const double lo = (1.0 - b.f) * source(b.i0, a.i0) + b.f * source(b.i1, a.i0);
            const double hi = (1.0 - b.f) * source(b.i0, a.i1) + b.f * source(b.i1, a.i1);
            const double m = (1.0 - a.f) * lo + a.f * hi;
            const double q = std::round(m * u);
            if (!(std::abs(q) <= kMaxHeightQuanta))
                return makeError(
                    ErrorCode::kOutOfRange, "sample at column " + std::to_string(x) + ", row " +
                                                std::to_string(y) + " (" + std::to_string(m) +
                                                " m) is beyond the fixed-point height range");
            samples
                [static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                 static_cast<std::size_t>(x)] = static_cast<std::int32_t>(q);
            info.min_metres = std::min(info.min_metres, m);
            info.max_metres = std::max(info.max_metres, m);
        }
    }
    // the imported surface at every source sample: along the resampled axis it is linear
    // between the terrain's samples (a grid line of the base triangles), across it exact
    const auto terrainAt = [&](std::int32_t x, std::int32_t y) {
        return samples
                   [static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                    static_cast<std::size_t>(x)] /
               u;
    };
    double error_sum = 0.0;
    for (std::int32_t y = 0; y < sh; ++y) {
        const double py = std::min(y / ratio_y, static_cast<double>(h - 1));
        const auto y0 = static_cast<std::int32_t>(std::floor(py));
        const std::int32_t y1 = std::min<std::int32_t>(y0 + 1, info.height - 1);
        const double fy = py - y0;
        for (std::int32_t x = 0; x < sw; ++x) {
            const double px = std::min(x / ratio_x, static_cast<double>(w - 1));
            const auto x0 = static_cast<std::int32_t>(std::floor(px));
            const std::int32_t x1 = std::min<std::int32_t>(x0 + 1, info.width - 1);
            const double fx = px - x0;
            const double at =
                (1.0 - fy) * ((1.0 - fx) * terrainAt(x0, y0) + fx * terrainAt(x1, y0)) +
                fy * ((1.0 - fx) * terrainAt(x0, y1) + fx * terrainAt(x1, y1));
            const double error = std::abs(at - source(x, y));
            info.resample_max_error_metres = std::max(info.resample_max_error_metres, error);
            error_sum += error;
        }
    }
    info.resample_mean_error_metres = error_sum / static_cast<double>(north_first.size());
    auto terrain = Terrain::create(spec, samples);
    if (!terrain)
        return terrain.error();
    return ImportedDem{std::move(*terrain), std::move(info)};
}

Result<std::vector<std::uint8_t>> readFile(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return makeError(ErrorCode::kIo, "cannot open " + path.string());
    std::vector<std::uint8_t> bytes(
        (std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad())
        return makeError(ErrorCode::kIo, "read error on " + path.string());
    return bytes;
}

} // namespace

Result<ImportedDem> importDemFromMemory(
    std::string_view json_text,
    std::span<const std::uint8_t> raw,
    const DemImportOptions& options) {
    const json j = json::parse(json_text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded())
        return makeError(ErrorCode::kBadFormat, "DEM sidecar is not valid JSON");
    if (!j.is_object())
        return makeError(ErrorCode::kBadFormat, "DEM sidecar must be a JSON object");

    DemInfo info;
    if (j.contains("name") && j["name"].is_string())
        info.name = j["name"].get<std::string>();
    for (const char* key : {"width", "height"}) {
        if (!j.contains(key) || !j[key].is_number_integer())
            return badField(key, "must be an integer");
        const auto v = j[key].get<std::int64_t>();
        if (v < 2 || v > kMaxMapVertices)
            return makeError(
                ErrorCode::kOutOfRange, std::string("DEM ") + key + " must be 2.." +
                                            std::to_string(kMaxMapVertices) + ", got " +
                                            std::to_string(v));
        (std::strcmp(key, "width") == 0 ? info.source_width : info.source_height) =
            static_cast<std::int32_t>(v);
    }
    if (!j.contains("sample_type") || !j["sample_type"].is_string())
        return badField("sample_type", "must be a string");
    info.sample_type = j["sample_type"].get<std::string>();
    std::size_t sample_bytes = 0;
    if (info.sample_type == "int16")
        sample_bytes = 2;
    else if (info.sample_type == "float32")
        sample_bytes = 4;
    else
        return makeError(
            ErrorCode::kUnsupported,
            "DEM sample_type '" + info.sample_type + "' is not supported (int16, float32)");
    if (j.contains("byte_order") &&
        !(j["byte_order"].is_string() && j["byte_order"].get<std::string>() == "little-endian"))
        return badField("byte_order", "must be \"little-endian\"");

    std::optional<double> nodata;
    if (j.contains("nodata") && !j["nodata"].is_null()) {
        if (!j["nodata"].is_number())
            return badField("nodata", "must be a number or null");
        nodata = j["nodata"].get<double>();
    }
    if (options.vertical_scale) {
        info.vertical_scale = *options.vertical_scale;
    } else if (j.contains("vertical_scale") && !j["vertical_scale"].is_null()) {
        if (!j["vertical_scale"].is_number())
            return badField("vertical_scale", "must be a number or null");
        info.vertical_scale = j["vertical_scale"].get<double>();
    }
    if (!std::isfinite(info.vertical_scale) || info.vertical_scale <= 0.0)
        return makeError(ErrorCode::kOutOfRange, "vertical scale must be positive and finite");

    if (options.spacing_metres) {
        info.source_spacing_x = info.source_spacing_y = *options.spacing_metres;
        info.spacing_source = "option";
    } else if (auto s = positiveNumberAt(j, {"horizontal", "spacing_m", "x"})) {
        info.source_spacing_x = *s;
        info.source_spacing_y = positiveNumberAt(j, {"horizontal", "spacing_m", "y"}).value_or(*s);
        info.spacing_source = "horizontal.spacing_m";
    } else if (auto a = positiveNumberAt(j, {"horizontal", "approx_spacing_m", "x"})) {
        info.source_spacing_x = *a;
        info.source_spacing_y =
            positiveNumberAt(j, {"horizontal", "approx_spacing_m", "y"}).value_or(*a);
        info.spacing_source = "horizontal.approx_spacing_m";
    } else {
        return makeError(
            ErrorCode::kBadFormat,
            "DEM sidecar gives no spacing in metres (horizontal.spacing_m or approx_spacing_m); "
            "pass one explicitly");
    }

    const std::size_t count =
        static_cast<std::size_t>(info.source_width) * static_cast<std::size_t>(info.source_height);
    if (count > options.max_samples)
        return makeError(
            ErrorCode::kOutOfRange, "DEM has " + std::to_string(count) +
                                        " samples, more than the import budget of " +
                                        std::to_string(options.max_samples));
    if (raw.size() != count * sample_bytes)
        return makeError(
            ErrorCode::kSizeMismatch,
            "DEM raw file has " + std::to_string(raw.size()) + " bytes; " +
                std::to_string(info.source_width) + " x " + std::to_string(info.source_height) +
                " " + info.sample_type + " needs " + std::to_string(count * sample_bytes));

    std::vector<double> metres(count);
    std::vector<std::size_t> holes;
    double lowest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < count; ++i) {
        double v = 0.0;
        if (sample_bytes == 2) {
            const auto s = static_cast<std::int16_t>(raw[2 * i] | (raw[2 * i + 1] << 8));
            v = s;
        } else {
            const std::uint32_t bits = static_cast<std::uint32_t>(raw[4 * i]) |
                                       (static_cast<std::uint32_t>(raw[4 * i + 1]) << 8) |
                                       (static_cast<std::uint32_t>(raw[4 * i + 2]) << 16) |
                                       (static_cast<std::uint32_t>(raw[4 * i + 3]) << 24);
            float f = 0.0f;
            std::memcpy(&f, &bits, sizeof f);
            if (!std::isfinite(f))
                return makeError(
                    ErrorCode::kNotFinite, "DEM sample " + std::to_string(i) + " is not finite");
            v = f;
        }
        if (nodata && v == *nodata) {
            holes.push_back(i);
            continue;
        }
        metres[i] = v * info.vertical_scale;
        lowest = std::min(lowest, metres[i]);
    }
    if (holes.size() == count)
        return makeError(ErrorCode::kOutOfRange, "DEM has no valid sample (all nodata)");
    for (std::size_t i : holes)
        metres[i] = lowest;
    info.nodata_filled = static_cast<std::int64_t>(holes.size());
    return buildTerrain(std::move(info), metres, options);
}

Result<ImportedDem>
importDem(const std::filesystem::path& path, const DemImportOptions& options) try {
    std::filesystem::path json_path = path;
    if (std::filesystem::is_directory(path))
        json_path = path / (path.filename().string() + ".json");
    auto text = readFile(json_path);
    if (!text)
        return text.error();
    const json j = json::parse(text->begin(), text->end(), nullptr, false);
    std::string raw_name = json_path.stem().string() + ".raw";
    if (!j.is_discarded() && j.is_object() && j.contains("file")) {
        if (!j["file"].is_string())
            return badField("file", "must be a string");
        raw_name = j["file"].get<std::string>();
        if (raw_name.empty() || raw_name.find('/') != std::string::npos ||
            raw_name.find('\\') != std::string::npos || raw_name == "." || raw_name == "..")
            return badField("file", "must be a plain file name beside the sidecar");
    }
    auto raw = readFile(json_path.parent_path() / raw_name);
    if (!raw)
        return raw.error();
    const std::string_view view(reinterpret_cast<const char*>(text->data()), text->size());
    return importDemFromMemory(view, *raw, options);
} catch (const std::bad_alloc&) {
    return makeError(ErrorCode::kOutOfRange, "not enough memory to import " + path.string());
}

Result<ImportedDem> importPng(
    const std::filesystem::path& path,
    double spacing_metres,
    double vertical_scale,
    double offset_metres,
    const DemImportOptions& options) {
    if (!std::isfinite(vertical_scale) || vertical_scale <= 0.0 || !std::isfinite(offset_metres))
        return makeError(
            ErrorCode::kOutOfRange, "PNG vertical scale must be positive, offset finite");
    auto image = readGrayPng(path, options.max_samples);
    if (!image)
        return image.error();
    DemInfo info;
    info.name = path.stem().string();
    info.source_width = image->width;
    info.source_height = image->height;
    info.sample_type = image->bit_depth == 16 ? "png-gray16" : "png-gray8";
    info.source_spacing_x = info.source_spacing_y = spacing_metres;
    info.spacing_source = "option";
    info.vertical_scale = vertical_scale;
    if (info.source_width < 2 || info.source_height < 2 || info.source_width > kMaxMapVertices ||
        info.source_height > kMaxMapVertices)
        return makeError(
            ErrorCode::kOutOfRange,
            "PNG size must be 2.." + std::to_string(kMaxMapVertices) + " per side");
    std::vector<double> metres(image->pixels.size());
    for (std::size_t i = 0; i < metres.size(); ++i)
        metres[i] = offset_metres + image->pixels[i] * vertical_scale;
    return buildTerrain(std::move(info), metres, options);
}

} // namespace terrain::io
