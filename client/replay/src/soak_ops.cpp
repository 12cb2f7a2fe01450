#include <terrain/fixed_point.h>
#include <terrain/replay/soak_ops.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::replay {
namespace {

BattleOptions battleFor(std::uint64_t seed, const WorldSpec& spec) {
    BattleOptions b;
    b.seed = seed;
    b.zone_x = spec.extentX() / 2;
    b.zone_y = spec.extentY() / 2;
    b.zone_radius = std::max(5.0, std::min(spec.extentX(), spec.extentY()) * 0.15);
    b.min_range = std::min(b.min_range, b.zone_radius);
    b.max_range = std::min(b.max_range, std::min(spec.extentX(), spec.extentY()) * 0.45);
    return b;
}

} // namespace

SoakOps::SoakOps(std::uint64_t seed, const WorldSpec& spec, SoakMix mix)
    : spec_(spec), mix_(mix), rng_(seed), battle_(battleFor(seed, spec)) {}

double SoakOps::uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng_);
}

FeedRequest SoakOps::next(const Terrain& current) {
    const double pick = uniform(0.0, 1.0);
    if (pick < mix_.battle) {
        BattleShot shot = battle_.next(current);
        if (shot.crater) {
            ++counts_.battle;
            return *shot.crater;
        }
        // the ray left the map: a random op instead
    } else if (pick >= mix_.battle + mix_.random) {
        if (pick < mix_.battle + mix_.random + mix_.extreme) {
            ++counts_.extreme;
            return extremeOp();
        }
        ++counts_.invalid;
        return invalidOp();
    }
    ++counts_.random;
    return randomOp();
}

OpRequest SoakOps::randomOp() {
    const RadiusRange rr = radiusRange(spec_);
    const double m = spec_.metresPerUnit();
    // most radii small (as play makes them), some up to 16 cells
    const double max_r = std::min(rr.max * m, 16 * spec_.spacingMetres());
    const double min_r = rr.min * m;
    OpRequest r;
    r.kind = static_cast<OpKind>(1 + std::uniform_int_distribution<int>(0, 3)(rng_));
    r.x = uniform(0.0, spec_.extentX());
    r.y = uniform(0.0, spec_.extentY());
    r.radius = min_r * std::pow(max_r / min_r, std::pow(uniform(0.0, 1.0), 2.0));
    switch (r.kind) {
    case OpKind::kCrater:
        r.height = uniform(0.05, 1.0) * r.radius;
        r.strength = uniform(0.0, 1.0);
        break;
    case OpKind::kRaise:
        r.height = uniform(-1.0, 1.0) * r.radius;
        if (std::abs(r.height) < m)
            r.height = m;
        r.strength = 1.0;
        break;
    case OpKind::kFlatten:
        r.height = uniform(-50.0, 300.0);
        r.strength = uniform(0.01, 1.0);
        break;
    case OpKind::kSmooth:
        r.height = 0.0;
        r.strength = uniform(0.01, 1.0);
        break;
    }
    return r;
}

DeformOp SoakOps::extremeOp() {
    const RadiusRange rr = radiusRange(spec_);
    const std::int64_t max_x = std::int64_t{spec_.cellsX()} * spec_.spacing;
    const std::int64_t max_y = std::int64_t{spec_.cellsY()} * spec_.spacing;
    const auto max_height = static_cast<std::int32_t>(kMaxOpHeightMetres * spec_.units_per_metre);
    auto coin = [&] { return std::uniform_int_distribution<int>(0, 1)(rng_) == 1; };
    auto any = [&](std::int64_t hi) {
        return std::uniform_int_distribution<std::int64_t>(0, hi)(rng_);
    };
    DeformOp op;
    op.kind = static_cast<OpKind>(1 + std::uniform_int_distribution<int>(0, 3)(rng_));
    // centre: a corner, a point on an edge, or anywhere
    switch (std::uniform_int_distribution<int>(0, 2)(rng_)) {
    case 0:
        op.center_x = coin() ? max_x : 0;
        op.center_y = coin() ? max_y : 0;
        break;
    case 1:
        op.center_x = coin() ? (coin() ? max_x : 0) : any(max_x);
        op.center_y = op.center_x == 0 || op.center_x == max_x ? any(max_y) : (coin() ? max_y : 0);
        break;
    default:
        op.center_x = any(max_x);
        op.center_y = any(max_y);
    }
    if (uniform(0.0, 1.0) < mix_.largest / std::max(mix_.extreme, 1e-9)) {
        op.radius = rr.max;
        ++counts_.largest;
    } else {
        op.radius = coin() ? rr.min : std::min<std::int32_t>(rr.max, 4 * spec_.spacing);
    }
    switch (op.kind) {
    case OpKind::kCrater: // the deepest the radius allows, or the shallowest; rim 0 or 1
        op.height = coin() ? std::min(max_height, op.radius) : 1;
        op.strength = coin() ? kUnitStrength : 0;
        break;
    case OpKind::kRaise: // as high or as deep as the radius, or one quantum
        op.height = coin() ? std::min(max_height, op.radius) : 1;
        op.height = coin() ? op.height : -op.height;
        op.strength = kUnitStrength;
        break;
    case OpKind::kFlatten: // to the lowest or highest height a sample can hold
        op.height = coin() ? kMaxHeightQuanta : -kMaxHeightQuanta;
        op.strength = coin() ? kUnitStrength : 1;
        break;
    case OpKind::kSmooth:
        op.height = 0;
        op.strength = coin() ? kUnitStrength : 1;
        break;
    }
    return op;
}

OpRequest SoakOps::invalidOp() {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    OpRequest r = randomOp();
    switch (std::uniform_int_distribution<int>(0, 7)(rng_)) {
    case 0:
        r.x = nan;
        break;
    case 1:
        r.radius = inf;
        break;
    case 2:
        r.height = -inf;
        break;
    case 3:
        r.radius = std::uniform_int_distribution<int>(0, 1)(rng_) ? 0.0 : -3.0;
        break;
    case 4:
        r.x = spec_.extentX() + uniform(0.01, 1e6);
        break;
    case 5:
        r.y = -uniform(0.01, 1e6);
        break;
    case 6:
        r.strength = std::uniform_int_distribution<int>(0, 1)(rng_) ? 1.5 : -0.25;
        break;
    default:
        r.kind = OpKind::kSmooth;
        r.height = 2.0;
        r.strength = 0.5;
    }
    return r;
}

} // namespace terrain::replay
