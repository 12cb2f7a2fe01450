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

// Builds the terrain from heights in metres (already validated finite).
Result<ImportedDem>
buildTerrain(DemInfo info, const std::vector<double>& metres, const DemImportOptions& options) {
    if (!std::isfinite(info.spacing_metres) || info.spacing_metres <= 0.0)
        return makeError(ErrorCode::kOutOfRange, "grid spacing must be positive and finite");
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

    std::vector<std::int32_t> samples(metres.size());
    info.min_metres = std::numeric_limits<double>::infinity();
    info.max_metres = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < metres.size(); ++i) {
        const double q = std::round(metres[i] * u);
        if (!(std::abs(q) <= kMaxHeightQuanta))
            return makeError(
                ErrorCode::kOutOfRange, "sample " + std::to_string(i) + " (" +
                                            std::to_string(metres[i]) +
                                            " m) is beyond the fixed-point height range");
        samples[i] = static_cast<std::int32_t>(q);
        info.min_metres = std::min(info.min_metres, metres[i]);
        info.max_metres = std::max(info.max_metres, metres[i]);
    }
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
        (std::strcmp(key, "width") == 0 ? info.width : info.height) = static_cast<std::int32_t>(v);
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
        info.spacing_metres = *options.spacing_metres;
        info.spacing_source = "option";
    } else if (auto s = positiveNumberAt(j, {"horizontal", "spacing_m", "x"})) {
        info.spacing_metres = *s;
        info.spacing_source = "horizontal.spacing_m.x";
    } else if (auto a = positiveNumberAt(j, {"horizontal", "approx_spacing_m", "x"})) {
        info.spacing_metres = *a;
        info.spacing_source = "horizontal.approx_spacing_m.x";
    } else {
        return makeError(
            ErrorCode::kBadFormat,
            "DEM sidecar gives no spacing in metres (horizontal.spacing_m or approx_spacing_m); "
            "pass one explicitly");
    }

    const std::size_t count =
        static_cast<std::size_t>(info.width) * static_cast<std::size_t>(info.height);
    if (count > options.max_samples)
        return makeError(
            ErrorCode::kOutOfRange, "DEM has " + std::to_string(count) +
                                        " samples, more than the import budget of " +
                                        std::to_string(options.max_samples));
    if (raw.size() != count * sample_bytes)
        return makeError(
            ErrorCode::kSizeMismatch, "DEM raw file has " + std::to_string(raw.size()) +
                                          " bytes; " + std::to_string(info.width) + " x " +
                                          std::to_string(info.height) + " " + info.sample_type +
                                          " needs " + std::to_string(count * sample_bytes));

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
    info.width = image->width;
    info.height = image->height;
    info.sample_type = image->bit_depth == 16 ? "png-gray16" : "png-gray8";
    info.spacing_metres = spacing_metres;
    info.spacing_source = "option";
    info.vertical_scale = vertical_scale;
    if (info.width < 2 || info.height < 2 || info.width > kMaxMapVertices ||
        info.height > kMaxMapVertices)
        return makeError(
            ErrorCode::kOutOfRange,
            "PNG size must be 2.." + std::to_string(kMaxMapVertices) + " per side");
    std::vector<double> metres(image->pixels.size());
    for (std::size_t i = 0; i < metres.size(); ++i)
        metres[i] = offset_metres + image->pixels[i] * vertical_scale;
    return buildTerrain(std::move(info), metres, options);
}

} // namespace terrain::io
