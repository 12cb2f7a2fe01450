#include <terrain/bot/bot_script.h>
#include <terrain/surface_query.h>

#include <algorithm>
#include <cmath>

namespace terrain::bot {

namespace {
constexpr double kPi = 3.14159265358979323846;

// splitmix64: a stateless hash of (seed, stream, index) to [0, 1)
double unitHash(std::uint64_t seed, std::uint64_t stream, std::uint64_t index) {
    std::uint64_t z = seed * 0x9e3779b97f4a7c15ull + stream * 0xbf58476d1ce4e5b9ull + index;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
}
} // namespace

BotScript::BotScript(const ScriptOptions& options, const WorldSpec& spec)
    : options_(options), extent_x_(spec.extentX()), extent_y_(spec.extentY()) {
    focus_x_ = extent_x_ * (0.25 + 0.5 * unitHash(options.seed, 1, 0));
    focus_y_ = extent_y_ * (0.25 + 0.5 * unitHash(options.seed, 1, 1));
}

roam::Camera BotScript::camera(int frame, const Terrain& terrain) const {
    const double t = options_.frames > 1 ? static_cast<double>(frame) / (options_.frames - 1) : 0.0;
    const double start = 2.0 * kPi * unitHash(options_.seed, 2, 0);
    const double angle = start + t * options_.sweep_degrees * kPi / 180.0;
    const double fx = focus_x_;
    const double fy = focus_y_;
    const double fz = surfaceHeight(terrain, fx, fy);
    roam::Camera c;
    c.eye = glm::dvec3(
        std::clamp(fx + options_.orbit_radius_metres * std::cos(angle), 0.0, extent_x_),
        std::clamp(fy + options_.orbit_radius_metres * std::sin(angle), 0.0, extent_y_), 0.0);
    const double clearance = 5.0;
    c.eye.z = std::max(
        fz + options_.altitude_metres, surfaceHeight(terrain, c.eye.x, c.eye.y) + clearance);
    c.forward = glm::dvec3(fx, fy, fz) - c.eye;
    c.viewport_width = options_.viewport_width;
    c.viewport_height = options_.viewport_height;
    c.near_plane = 0.5;
    return c;
}

bool BotScript::craterDue(int frame) const {
    if (options_.craters <= 0)
        return false;
    const int span = std::max(1, options_.frames * 4 / 5);
    // frames f with floor(f * n / span) stepping: n shots evenly over the span, the first at 1
    if (frame < 1 || frame > span)
        return false;
    const auto n = static_cast<long long>(options_.craters);
    return (static_cast<long long>(frame) * n) / span !=
           (static_cast<long long>(frame - 1) * n) / span;
}

CraterShot BotScript::shot(int frame) const {
    const auto f = static_cast<std::uint64_t>(frame);
    CraterShot s;
    // the middle of the screen, a little below the centre where the focus is: ground, not sky
    s.pixel_x = options_.viewport_width * (0.35 + 0.3 * unitHash(options_.seed, 3, f));
    s.pixel_y = options_.viewport_height * (0.45 + 0.25 * unitHash(options_.seed, 4, f));
    const double r = unitHash(options_.seed, 5, f);
    s.radius =
        options_.crater_radius_min + r * (options_.crater_radius_max - options_.crater_radius_min);
    s.depth =
        options_.crater_depth_min +
        unitHash(options_.seed, 6, f) * (options_.crater_depth_max - options_.crater_depth_min);
    return s;
}

} // namespace terrain::bot
