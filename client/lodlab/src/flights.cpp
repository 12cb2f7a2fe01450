#include <terrain/lodlab/flights.h>
#include <terrain/surface_query.h>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

#include <algorithm>
#include <cmath>

namespace terrain::lodlab {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

/// splitmix64: the seeded numbers of the teleports
double unit(std::uint64_t seed, std::uint64_t i) {
    std::uint64_t z = seed * 0x9e3779b97f4a7c15ull + i * 0xbf58476d1ce4e5b9ull + 1;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) / static_cast<double>(1ull << 53);
}

/// The highest ground within `radius` of (x, y): the eye keeps its altitude above that, so
/// it never dips into a ridge beside its path.
double groundAround(const Terrain& t, double x, double y, double radius) {
    double h = surfaceHeight(t, x, y);
    for (int k = 0; k < 8; ++k) {
        const double a = k * kPi / 4.0;
        h = std::max(h, surfaceHeight(t, x + radius * std::cos(a), y + radius * std::sin(a)));
    }
    return h;
}

roam::Camera
cameraAt(const FlightOptions& o, glm::dvec3 eye, double yaw, double pitch, double near) {
    roam::Camera c;
    c.eye = eye;
    c.forward = {std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch)};
    c.up = {0.0, 0.0, 1.0};
    c.fovy_radians = o.fovy_degrees * kDeg;
    c.viewport_width = o.width;
    c.viewport_height = o.height;
    c.near_plane = near;
    return c;
}

} // namespace

const char* toString(FlightKind kind) {
    switch (kind) {
    case FlightKind::kCruise:
        return "cruise";
    case FlightKind::kLow:
        return "low";
    case FlightKind::kHover:
        return "hover";
    case FlightKind::kWhip:
        return "whip";
    case FlightKind::kTeleport:
        return "teleport";
    case FlightKind::kBattle:
        return "battle";
    }
    return "?";
}

std::optional<FlightKind> parseFlight(const std::string& name) {
    for (FlightKind k : kAllFlights)
        if (name == toString(k))
            return k;
    return std::nullopt;
}

BattleZone battleZone(const Terrain& terrain) {
    return {terrain.spec().extentX() / 2, terrain.spec().extentY() / 2, 40.0};
}

BattleGenerator battleGenerator(const Terrain& terrain) {
    const BattleZone zone = battleZone(terrain);
    BattleOptions o;
    o.zone_x = zone.x;
    o.zone_y = zone.y;
    o.zone_radius = zone.radius;
    return BattleGenerator(o);
}

void fireShots(BattleGenerator& generator, Terrain& terrain, int shots) {
    for (int s = 0; s < shots; ++s) {
        const BattleShot shot = generator.next(terrain);
        if (shot.crater)
            if (auto op = quantizeOp(*shot.crater, terrain.spec()))
                (void)terrain.apply(*op);
    }
}

std::vector<FlightFrame> makeFlight(const Terrain& terrain, const FlightOptions& o) {
    const double ex = terrain.spec().extentX();
    const double ey = terrain.spec().extentY();
    const double span = std::min(ex, ey);
    const double cell = terrain.spec().spacingMetres();
    const double cruise_altitude = std::clamp(0.02 * span, 15.0, 150.0);
    const double dt = 1.0 / o.hz;
    std::vector<FlightFrame> frames(static_cast<std::size_t>(std::max(o.frames, 0)));
    const glm::dvec2 centre{ex / 2, ey / 2};
    // the circle of cruise, low and teleport: a radius of 0.3 x the map, 250 m/s at most and
    // no more than 10 degrees a second of turning
    const double radius = 0.3 * span;
    const double speed = std::min(250.0, radius * 10.0 * kDeg);
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const double t = static_cast<double>(i) * dt;
        FlightFrame& f = frames[i];
        switch (o.kind) {
        case FlightKind::kCruise:
        case FlightKind::kLow:
        case FlightKind::kTeleport: {
            const bool low = o.kind == FlightKind::kLow;
            const double v = low ? speed / 4 : speed;
            double phase = v * t / radius;
            glm::dvec2 c = centre;
            double r = radius;
            if (o.kind == FlightKind::kTeleport) {
                // every 60 frames another circle about another point of the map
                const auto leg = static_cast<std::uint64_t>(i / 60);
                f.teleport = i > 0 && i % 60 == 0;
                c = {
                    ex * (0.3 + 0.4 * unit(o.seed, 2 * leg)),
                    ey * (0.3 + 0.4 * unit(o.seed, 2 * leg + 1))};
                r = 0.15 * span;
                phase += 2.4 * static_cast<double>(leg);
            }
            const glm::dvec2 p = c + r * glm::dvec2{std::cos(phase), std::sin(phase)};
            const double heading = phase + kPi / 2;
            const double altitude = low ? cruise_altitude / 7 : cruise_altitude;
            const double yaw = heading + 8.0 * kDeg * std::sin(2.0 * kPi * t / 4.0);
            const double ground = groundAround(terrain, p.x, p.y, std::max(2 * cell, altitude));
            f.camera = cameraAt(
                o, {p.x, p.y, ground + altitude}, yaw, low ? -0.08 : -0.25,
                std::max(0.1, altitude / 150));
            break;
        }
        case FlightKind::kHover: {
            const double altitude = cruise_altitude / 3;
            const double ground = groundAround(terrain, centre.x, centre.y, 2 * cell);
            f.camera = cameraAt(
                o, {centre.x, centre.y, ground + altitude}, 20.0 * kDeg * t, -0.3,
                std::max(0.1, altitude / 150));
            break;
        }
        case FlightKind::kWhip: {
            const double altitude = cruise_altitude / 4;
            const glm::dvec2 p = centre + glm::dvec2{0.01 * span * t, 0.0};
            const double ground = groundAround(terrain, p.x, p.y, 2 * cell);
            // still for 32 frames, then 180 degrees in 8
            const auto k = static_cast<int>(i);
            const int whips = k / 40;
            const int into = k % 40;
            const double yaw =
                kPi * (whips + (into >= 32 ? static_cast<double>(into - 31) / 8.0 : 0.0));
            f.camera = cameraAt(
                o, {p.x, p.y, ground + altitude}, yaw, -0.2, std::max(0.1, altitude / 150));
            break;
        }
        case FlightKind::kBattle: {
            // a straight pass 12 m over the ground, from 3 zone radii before the centre to 3
            // beyond it, across the flight, looking ahead and 15 degrees down (its craters are
            // in view all the way)
            const BattleZone z = battleZone(terrain);
            const double heading = 30.0 * kDeg;
            const double along =
                -3.0 * z.radius +
                6.0 * z.radius * static_cast<double>(i) /
                    static_cast<double>(std::max<std::size_t>(frames.size() - 1, 1));
            const glm::dvec2 p{z.x + along * std::cos(heading), z.y + along * std::sin(heading)};
            const double ground = groundAround(terrain, p.x, p.y, 5.0);
            const glm::dvec3 eye{p.x, p.y, ground + 12.0};
            f.camera = cameraAt(o, eye, heading, -15.0 * kDeg, 0.5);
            f.shots = i == 0 ? 0 : o.battle_shots_per_frame;
            break;
        }
        }
    }
    return frames;
}

} // namespace terrain::lodlab
