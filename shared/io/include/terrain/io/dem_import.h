#pragma once

// Import of height maps from files: the raw + JSON DEM format of the reference datasets
// (int16 or float32, little-endian, row-major, row 0 north) and 16-bit grayscale PNG.
// Every byte and field is untrusted: errors name the rule broken, nothing asserts.
//
// True shape: the world frame is x east, y north, z up (right-handed), so the source's row 0
// (north) becomes the terrain's last row. The core has square cells (one spacing: diamonds,
// craters and the protocol assume it), so a grid whose x and y spacings differ (SRTM's 3" cells
// are 66 x 93 m at 44 N) is resampled along its coarser axis to the finer spacing: no source
// sample is dropped, the extent is kept within half a cell, and the filter is linear along that
// axis (monotone: it never overshoots a ridge or a pit). Each resampled value lies on the
// source's piecewise-linear profile; DemInfo::resample_max_error_metres measures how far the
// imported surface is from the source samples (a peak between two new rows is cut).

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
    /// Grid spacing in metres, both axes (no resampling). When unset: the sidecar's
    /// horizontal.spacing_m, else horizontal.approx_spacing_m (x, and y if given: a y that
    /// differs resamples); a DEM with neither needs this option.
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
    std::int32_t width = 0; ///< of the terrain (after resampling)
    std::int32_t height = 0;
    std::int32_t source_width = 0; ///< of the file
    std::int32_t source_height = 0;
    std::string sample_type;
    double spacing_metres = 0.0;   ///< the terrain's (square) cells
    double source_spacing_x = 0.0; ///< the file's, metres
    double source_spacing_y = 0.0;
    std::string spacing_source; ///< where the spacing came from
    /// "" when the grid was taken as is; else what was resampled and how.
    std::string resampling;
    /// Largest |imported surface - source sample| over every source sample (metres, quantisation
    /// included); 0 when not resampled (then only quantisation, at most half a quantum).
    double resample_max_error_metres = 0.0;
    double resample_mean_error_metres = 0.0; ///< the same, averaged over the source samples
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
