#include <terrain/viewer/fly_camera.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace terrain::viewer {

FlyCamera::FlyCamera(const glm::dvec3& eye, double yaw, double pitch)
    : eye_(eye), yaw_(yaw), pitch_(std::clamp(pitch, -kMaxPitch, kMaxPitch)) {}

FlyCamera FlyCamera::lookingAt(const glm::dvec3& eye, const glm::dvec3& target) {
    const glm::dvec3 d = target - eye;
    const double horizontal = std::hypot(d.x, d.y);
    // straight down or up has no yaw: keep looking north
    const double yaw = horizontal > 0.0 ? std::atan2(d.y, d.x) : 3.14159265358979323846 / 2.0;
    return FlyCamera(eye, yaw, std::atan2(d.z, horizontal));
}

glm::dvec3 FlyCamera::forward() const {
    return {std::cos(pitch_) * std::cos(yaw_), std::cos(pitch_) * std::sin(yaw_), std::sin(pitch_)};
}

glm::dvec3 FlyCamera::right() const {
    // forward x up, flattened: strafing never changes height
    return {std::sin(yaw_), -std::cos(yaw_), 0.0};
}

void FlyCamera::step(const FlyInput& input, double dt_seconds) {
    constexpr double kTurn = 2.0 * 3.14159265358979323846;
    yaw_ = std::remainder(yaw_ + input.yaw, kTurn);
    pitch_ = std::clamp(pitch_ + input.pitch, -kMaxPitch, kMaxPitch);
    const double distance = speed * (input.fast ? fast_factor : 1.0) * dt_seconds;
    eye_ += distance * (input.forward * forward() + input.right * right() +
                        input.up * glm::dvec3(0.0, 0.0, 1.0));
}

bool FlyCamera::keepAbove(double ground_z, double clearance) {
    const double floor = ground_z + clearance;
    if (!(eye_.z < floor))
        return false;
    eye_.z = floor;
    return true;
}

void FlyCamera::keepWithin(const glm::dvec2& lo, const glm::dvec2& hi) {
    eye_.x = std::clamp(eye_.x, lo.x, hi.x);
    eye_.y = std::clamp(eye_.y, lo.y, hi.y);
}

roam::Camera FlyCamera::camera(int viewport_width, int viewport_height) const {
    roam::Camera c;
    c.eye = eye_;
    c.forward = forward();
    c.up = {0.0, 0.0, 1.0};
    c.fovy_radians = fovy_radians;
    c.viewport_width = viewport_width;
    c.viewport_height = viewport_height;
    c.near_plane = near_plane;
    return c;
}

FlyInput orbitInput(
    const FlyCamera& camera,
    const glm::dvec2& centre,
    double radians_per_second,
    double dt_seconds) {
    FlyInput input;
    const double radius = glm::length(glm::dvec2(camera.eye()) - centre);
    if (camera.speed > 0.0)
        input.right = radius * radians_per_second / camera.speed;
    // strafing right around a centre ahead turns the line of sight to the left
    input.yaw = radians_per_second * dt_seconds;
    return input;
}

} // namespace terrain::viewer
