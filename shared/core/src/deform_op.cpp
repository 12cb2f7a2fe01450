#include <terrain/deform_op.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace terrain {
namespace {

constexpr std::int64_t kOne = kUnitStrength; // 1.0 in 16.16

Error outOfRange(const char* what, double value, double lo, double hi, const char* unit) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%s must be in [%g, %g] %s, got %g", what, lo, hi, unit, value);
    return makeError(ErrorCode::kOutOfRange, buf);
}

} // namespace

const char* toString(OpKind kind) {
    switch (kind) {
    case OpKind::kCrater:
        return "crater";
    case OpKind::kRaise:
        return "raise";
    case OpKind::kFlatten:
        return "flatten";
    case OpKind::kSmooth:
        return "smooth";
    }
    return "unknown";
}

RadiusRange radiusRange(const WorldSpec& spec) {
    // below an eighth of a cell the patch grid cannot show the op; the upper limits keep one op's
    // cost bounded and every squared distance below 2^62 in 1/48 quanta
    const std::int64_t lo = std::max<std::int64_t>(1, ceilDiv(spec.spacing, 8));
    std::int64_t hi = std::int64_t{spec.spacing} * kMaxRadiusCells;
    hi = std::min<std::int64_t>(
        hi, static_cast<std::int64_t>(kMaxRadiusMetres * spec.units_per_metre));
    hi = std::min<std::int64_t>(hi, std::int64_t{1} << 23);
    return {static_cast<std::int32_t>(lo), static_cast<std::int32_t>(std::max(hi, lo))};
}

std::int64_t footprintRadius(const DeformOp& op) {
    return op.kind == OpKind::kCrater ? 2 * std::int64_t{op.radius} : std::int64_t{op.radius};
}

Status validateOp(const DeformOp& op, const WorldSpec& spec) {
    const double m = spec.metresPerUnit();
    if (op.kind != OpKind::kCrater && op.kind != OpKind::kRaise && op.kind != OpKind::kFlatten &&
        op.kind != OpKind::kSmooth)
        return makeError(
            ErrorCode::kUnsupported,
            "unknown op kind " + std::to_string(static_cast<int>(op.kind)));
    const std::int64_t max_x = std::int64_t{spec.cellsX()} * spec.spacing;
    const std::int64_t max_y = std::int64_t{spec.cellsY()} * spec.spacing;
    if (op.center_x < 0 || op.center_x > max_x || op.center_y < 0 || op.center_y > max_y) {
        char buf[256];
        std::snprintf(
            buf, sizeof buf, "centre (%g, %g) m is outside the map [0, %g] x [0, %g] m",
            static_cast<double>(op.center_x) * m, static_cast<double>(op.center_y) * m,
            static_cast<double>(max_x) * m, static_cast<double>(max_y) * m);
        return makeError(ErrorCode::kOutsideMap, buf);
    }
    const RadiusRange rr = radiusRange(spec);
    if (op.radius < rr.min || op.radius > rr.max)
        return outOfRange("radius", op.radius * m, rr.min * m, rr.max * m, "m");
    const auto max_height = static_cast<std::int32_t>(kMaxOpHeightMetres * spec.units_per_metre);
    switch (op.kind) {
    case OpKind::kCrater:
        if (op.height < 1 || op.height > max_height || op.height > op.radius)
            return outOfRange(
                "crater depth (at most the radius)", op.height * m, m,
                std::min(max_height, op.radius) * m, "m");
        if (op.strength < 0 || op.strength > kUnitStrength)
            return outOfRange("crater rim ratio", op.strength / double(kOne), 0, 1, "");
        break;
    case OpKind::kRaise:
        if (op.height == 0 || op.height < -max_height || op.height > max_height)
            return outOfRange(
                "raise height (non-zero)", op.height * m, -max_height * m, max_height * m, "m");
        if (op.strength != kUnitStrength)
            return makeError(ErrorCode::kOutOfRange, "raise strength must be 1");
        break;
    case OpKind::kFlatten:
        if (op.height < -kMaxHeightQuanta || op.height > kMaxHeightQuanta)
            return outOfRange(
                "flatten target height", op.height * m, -kMaxHeightQuanta * m, kMaxHeightQuanta * m,
                "m");
        [[fallthrough]];
    case OpKind::kSmooth:
        if (op.strength < 1 || op.strength > kUnitStrength)
            return outOfRange("strength", op.strength / double(kOne), 1.0 / kOne, 1, "");
        if (op.kind == OpKind::kSmooth && op.height != 0)
            return makeError(ErrorCode::kOutOfRange, "smooth takes no height; it must be 0");
        break;
    }
    return Ok{};
}

Result<DeformOp> quantizeOp(const OpRequest& r, const WorldSpec& spec) {
    const struct {
        const char* name;
        double value;
    } fields[] = {
        {"x", r.x},
        {"y", r.y},
        {"radius", r.radius},
        {"height", r.height},
        {"strength", r.strength}};
    for (const auto& f : fields)
        if (!std::isfinite(f.value))
            return makeError(
                ErrorCode::kNotFinite, std::string(f.name) + " must be a finite number");
    const double u = spec.units_per_metre;
    // range-check before converting so that huge values cannot overflow the integer casts
    constexpr double kLimit = 1e15;
    for (const auto& f : fields)
        if (std::abs(f.value * u) > kLimit)
            return makeError(
                ErrorCode::kOutOfRange, std::string(f.name) + " is far beyond any valid range");
    if (std::abs(r.radius * u) > 2e9 || std::abs(r.height * u) > 2e9)
        return makeError(ErrorCode::kOutOfRange, "radius or height exceeds the int32 range");
    if (r.radius <= 0.0)
        return makeError(ErrorCode::kOutOfRange, "radius must be positive");
    if (r.strength < 0.0 || r.strength > 1.0)
        return outOfRange("strength", r.strength, 0, 1, "");

    DeformOp op;
    op.kind = r.kind;
    op.center_x = std::llround(r.x * u);
    op.center_y = std::llround(r.y * u);
    op.radius = static_cast<std::int32_t>(std::llround(r.radius * u));
    op.height = static_cast<std::int32_t>(std::llround(r.height * u));
    op.strength = static_cast<std::int32_t>(std::llround(r.strength * kOne));
    if (auto status = validateOp(op, spec); !status)
        return status.error();
    return op;
}

std::string describe(const DeformOp& op, const WorldSpec& spec) {
    const double m = spec.metresPerUnit();
    char buf[200];
    std::snprintf(
        buf, sizeof buf, "%s x=%.3f y=%.3f r=%.3f h=%.3f s=%.4f", toString(op.kind),
        static_cast<double>(op.center_x) * m, static_cast<double>(op.center_y) * m, op.radius * m,
        op.height * m, op.strength / double(kOne));
    return buf;
}

} // namespace terrain
