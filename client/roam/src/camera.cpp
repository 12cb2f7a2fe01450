#include <terrain/roam/camera.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <limits>

namespace terrain::roam {

ViewMetric::ViewMetric(const Camera& camera) : camera_(camera) {
    forward_ = glm::normalize(camera.forward);
    right_ = glm::normalize(glm::cross(forward_, camera.up));
    up_ = glm::cross(right_, forward_);
    const double tan_y = std::tan(camera.fovy_radians / 2.0);
    const double aspect =
        static_cast<double>(camera.viewport_width) / static_cast<double>(camera.viewport_height);
    const double tan_x = tan_y * aspect;
    focal_pixels_ = camera.viewport_height / (2.0 * tan_y);
    error_scale_ = focal_pixels_ * (1.0 + tan_x * tan_x + tan_y * tan_y);

    // inward normals of the side planes through the eye, and the near plane
    const glm::dvec3 e = camera.eye;
    auto through_eye = [&](const glm::dvec3& n) {
        const glm::dvec3 u = glm::normalize(n);
        return Plane{u, -glm::dot(u, e)};
    };
    planes_[0] = through_eye(forward_ * tan_x + right_); // left
    planes_[1] = through_eye(forward_ * tan_x - right_); // right
    planes_[2] = through_eye(forward_ * tan_y + up_);    // bottom
    planes_[3] = through_eye(forward_ * tan_y - up_);    // top
    planes_[4] = Plane{forward_, -glm::dot(forward_, e) - camera.near_plane};
}

bool ViewMetric::intersectsFrustum(const Box& box) const {
    for (const Plane& p : planes_) {
        // the box corner furthest along the normal
        const glm::dvec3 c{
            p.normal.x >= 0.0 ? box.hi.x : box.lo.x, p.normal.y >= 0.0 ? box.hi.y : box.lo.y,
            p.normal.z >= 0.0 ? box.hi.z : box.lo.z};
        if (glm::dot(p.normal, c) + p.offset < 0.0)
            return false;
    }
    return true;
}

double ViewMetric::exitSlack(const Box& box) const {
    double slack = std::numeric_limits<double>::infinity();
    for (const Plane& p : planes_) {
        const glm::dvec3 c{
            p.normal.x >= 0.0 ? box.hi.x : box.lo.x, p.normal.y >= 0.0 ? box.hi.y : box.lo.y,
            p.normal.z >= 0.0 ? box.hi.z : box.lo.z};
        slack = std::min(slack, std::max(0.0, glm::dot(p.normal, c) + p.offset));
    }
    return slack;
}

double ViewMetric::distanceTo(const Box& box) const {
    const glm::dvec3 e = camera_.eye;
    const glm::dvec3 d{
        std::max({box.lo.x - e.x, 0.0, e.x - box.hi.x}),
        std::max({box.lo.y - e.y, 0.0, e.y - box.hi.y}),
        std::max({box.lo.z - e.z, 0.0, e.z - box.hi.z})};
    return glm::length(d);
}

double ViewMetric::screenError(const Box& box, double error_metres) const {
    if (!intersectsFrustum(box))
        return 0.0;
    return screenErrorAnyDirection(box, error_metres);
}

ScreenPoint ViewMetric::project(const glm::dvec3& p) const {
    const glm::dvec3 v = p - camera_.eye;
    const double z = glm::dot(v, forward_);
    if (z <= 0.0)
        return {0.0, 0.0, z};
    const double x = glm::dot(v, right_);
    const double y = glm::dot(v, up_);
    return {
        camera_.viewport_width * 0.5 + focal_pixels_ * x / z,
        camera_.viewport_height * 0.5 - focal_pixels_ * y / z, z};
}

glm::dvec3 ViewMetric::rayThrough(double x, double y) const {
    const double rx = (x - camera_.viewport_width * 0.5) / focal_pixels_;
    const double ry = (camera_.viewport_height * 0.5 - y) / focal_pixels_;
    return glm::normalize(forward_ + right_ * rx + up_ * ry);
}

} // namespace terrain::roam
