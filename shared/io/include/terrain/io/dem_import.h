#pragma once

// Import of height maps from files: the raw + JSON DEM format of the reference datasets
// (int16 or float32, little-endian, row-major, row 0 north) and 16-bit grayscale PNG.
// Every byte and field is untrusted: errors name the rule broken, nothing asserts.

#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace terrain::io {

struct DemImportOptions {
    /// Grid spacing in metres. When unset: the sidecar's horizontal.spacing_m.x, else
    /// horizontal.approx_spacing_m.x; a DEM with neither needs this option.
    /// note: cells are square; for grids with different x and y spacing (SRTM) x is used.
    std::optional<double> spacing_metres;
    /// Metres per stored unit. When unset: the sidecar's vertical_scale, or 1 if it is null.
    std::optional<double> vertical_scale;
    /// When unset: spacing / 64, but at least 1/32 m. A fixed few centimetres would put a patch
    /// on nearly every cell an op touches on a 30-90 m DEM grid, where even a broad smooth mound
    /// leaves decimetres between grid triangles and the true surface.
    std::optional<double> patch_tolerance_metres;
    std::int32_t units_per_metre = kDefaultUnitsPerMetre;
    /// Largest grid an import accepts (width * height): bounds memory before anything is read.
    std::uint64_t max_samples = std::uint64_t{8192} * 8192;
};

struct DemInfo {
    std::string name;
    std::int32_t width = 0;
    std::int32_t height = 0;
    std::string sample_type;
    double spacing_metres = 0.0;
    std::string spacing_source; ///< where the spacing came from
    double vertical_scale = 1.0;
    double min_metres = 0.0;
    double max_metres = 0.0;
    std::int64_t nodata_filled = 0; ///< nodata samples replaced by the lowest valid sample
};

struct ImportedDem {
    Terrain terrain;
    DemInfo info;
};

/// Parses a sidecar and its raw bytes already in memory (used by importDem and by tests).
/// Errors: kBadFormat (JSON syntax, missing or mistyped field, byte order), kUnsupported
/// (sample type), kSizeMismatch (raw size != width * height * sample size), kNotFinite (a
/// float sample), kOutOfRange (a height beyond the fixed-point range, bad option).
Result<ImportedDem> importDemFromMemory(
    std::string_view json_text, std::span<const std::uint8_t> raw, const DemImportOptions& options);

/// Reads `<dir>/<name>.json` (or the .json path given) and the raw file it names, which must sit
/// beside it (the name may not contain a path). Errors: kIo plus those of importDemFromMemory.
Result<ImportedDem> importDem(const std::filesystem::path& path, const DemImportOptions& options);

/// Imports a 16-bit (or 8-bit) grayscale PNG: height = offset + value * vertical_scale metres.
Result<ImportedDem> importPng(
    const std::filesystem::path& path,
    double spacing_metres,
    double vertical_scale,
    double offset_metres,
    const DemImportOptions& options);

} // namespace terrain::io
