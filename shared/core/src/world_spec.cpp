#include <terrain/world_spec.h>

#include <algorithm>
#include <string>

namespace terrain {

Status WorldSpec::validate() const {
    if (width < 2 || height < 2 || width > kMaxMapVertices || height > kMaxMapVertices)
        return makeError(
            ErrorCode::kOutOfRange, "map size must be 2.." + std::to_string(kMaxMapVertices) +
                                        " vertices per side, got " + std::to_string(width) + " x " +
                                        std::to_string(height));
    if (units_per_metre < 1 || units_per_metre > kMaxUnitsPerMetre)
        return makeError(
            ErrorCode::kOutOfRange, "units per metre must be 1.." +
                                        std::to_string(kMaxUnitsPerMetre) + ", got " +
                                        std::to_string(units_per_metre));
    // spacing up to 10 km and 2^26 quanta (so the smallest valid op radius, spacing / 8, stays
    // within the 2^23-quanta radius limit), extent * 48 within 2^40 (positions in 1/48 quanta)
    const std::int64_t max_spacing = std::min<std::int64_t>(
        static_cast<std::int64_t>(units_per_metre) * 10000, std::int64_t{1} << 26);
    if (spacing < 1 || spacing > max_spacing)
        return makeError(
            ErrorCode::kOutOfRange, "grid spacing must be 1 .. " + std::to_string(max_spacing) +
                                        " quanta (10 km at most), got " + std::to_string(spacing));
    const std::int64_t extent =
        static_cast<std::int64_t>(spacing) * (std::max(paddedWidth(), paddedHeight()) - 1);
    if (extent * kFineScale > (std::int64_t{1} << 40))
        return makeError(
            ErrorCode::kOutOfRange, "map extent too large for the fixed-point range: " +
                                        std::to_string(extent) + " quanta");
    if (patch_tolerance < 1 || patch_tolerance > kMaxHeightQuanta)
        return makeError(
            ErrorCode::kOutOfRange,
            "patch tolerance must be at least 1 quantum, got " + std::to_string(patch_tolerance));
    return Ok{};
}

} // namespace terrain
