#include <terrain/battle.h>
#include <terrain/surface_query.h>

#include <algorithm>
#include <cmath>

namespace terrain {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kRecentHits = 32;

// splitmix64 of (seed, stream, index) to [0, 1): the same numbers on every platform
double unitHash(std::uint64_t seed, std::uint64_t stream, std::uint64_t index) {
    std::uint64_t z = seed * 0x9e3779b97f4a7c15ull + stream * 0xbf58476d1ce4e5b9ull + index;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
}

double lerp(double a, double b, double t) {
    return a + (b - a) * t;
}

} // namespace

BattleGenerator::BattleGenerator(const BattleOptions& options) : options_(options) {
    recent_.reserve(kRecentHits);
}

double BattleGenerator::unit(std::uint64_t stream) const {
    return unitHash(options_.seed, stream, static_cast<std::uint64_t>(fired_));
}

BattleShot BattleGenerator::next(const Terrain& terrain) {
    const BattleOptions& o = options_;
    const WorldSpec& spec = terrain.spec();
    const double ex = spec.extentX();
    const double ey = spec.extentY();
    BattleShot shot;

    // where the player looks: a fresh point of the zone, or near a recent hit
    double ax = 0.0;
    double ay = 0.0;
    if (!recent_.empty() && unit(1) < o.follow_share) {
        const auto pick = static_cast<std::size_t>(unit(2) * static_cast<double>(recent_.size()));
        const glm::dvec3& h = recent_[std::min(pick, recent_.size() - 1)];
        const double r = o.follow_spread * std::sqrt(unit(3));
        const double a = 2.0 * kPi * unit(4);
        ax = h.x + r * std::cos(a);
        ay = h.y + r * std::sin(a);
    } else {
        const double r = o.zone_radius * std::sqrt(unit(3));
        const double a = 2.0 * kPi * unit(4);
        ax = o.zone_x + r * std::cos(a);
        ay = o.zone_y + r * std::sin(a);
    }
    ax = std::clamp(ax, 0.0, ex);
    ay = std::clamp(ay, 0.0, ey);

    // from where: the player's orbit around the aim point; altitudes favour the low, grazing
    // shots that hit crests first
    const int players = std::max(1, o.players);
    const int player = fired_ % players;
    const double orbit = 2.0 * kPi * unitHash(o.seed, 5, static_cast<std::uint64_t>(player)) +
                         o.orbit_degrees_per_shot * kPi / 180.0 * (fired_ / players);
    const double range = lerp(o.min_range, o.max_range, unit(6));
    const double low = unit(7);
    const double altitude = lerp(o.min_altitude, o.max_altitude, low * low);
    const double eye_x = std::clamp(ax + range * std::cos(orbit), 0.0, ex);
    const double eye_y = std::clamp(ay + range * std::sin(orbit), 0.0, ey);
    shot.eye = glm::dvec3(eye_x, eye_y, surfaceHeight(terrain, eye_x, eye_y) + altitude);
    shot.aim = glm::dvec3(ax, ay, surfaceHeight(terrain, ax, ay));

    // the crater's size, drawn for every shot so that a miss does not shift later ones
    const double radius = lerp(o.min_radius, o.max_radius, unit(8));
    const double depth = radius * lerp(o.min_depth_ratio, o.max_depth_ratio, unit(9));
    const double rim = lerp(o.min_rim_ratio, o.max_rim_ratio, unit(10));
    ++fired_;

    const glm::dvec3 direction = shot.aim - shot.eye;
    const std::optional<RayHit> hit = castRay(terrain, shot.eye, direction, 1.5);
    if (!hit) {
        ++missed_;
        return shot;
    }
    OpRequest r;
    r.kind = OpKind::kCrater;
    r.x = std::clamp(hit->point.x, 0.0, ex);
    r.y = std::clamp(hit->point.y, 0.0, ey);
    r.radius = radius;
    r.height = depth;
    r.strength = rim;
    shot.crater = r;
    if (recent_.size() < kRecentHits)
        recent_.push_back(hit->point);
    else
        recent_[recent_next_] = hit->point;
    recent_next_ = (recent_next_ + 1) % kRecentHits;
    return shot;
}

} // namespace terrain
