#pragma once

// A perspective camera in the terrain's world frame (metres, z up; see surface_query.h) and the
// screen-space error bound derived from it.
//
// The bound: a vertical error of e metres at a point inside the view frustum, at distance d from
// the eye and depth z along the view axis, moves its projection by at most K * e * d / z^2
// pixels, where K = viewport_height / (2 tan(fovy / 2)). Inside the frustum d / z is at most
// c = sqrt(1 + tan^2(fovx / 2) + tan^2(fovy / 2)) (the corner ray), so z >= d / c and the shift is
// at most K * c^2 * e / d. That bound depends on the eye position only, not on where the camera
// looks, so spinning the camera never changes which triangles are fine enough: only frustum
// culling changes. Pure: no GL, no clocks.

#include <glm/vec3.hpp>

#include <array>
#include <cmath>

namespace terrain::roam {

struct Camera {
    glm::dvec3 eye{0.0};
    glm::dvec3 forward{1.0, 0.0, 0.0}; ///< need not be unit length
    glm::dvec3 up{0.0, 0.0, 1.0};
    double fovy_radians = 60.0 * 3.14159265358979323846 / 180.0;
    int viewport_width = 1280;
    int viewport_height = 720;
    double near_plane = 0.5; ///< metres
};

/// An axis-aligned box in metres.
struct Box {
    glm::dvec3 lo{0.0};
    glm::dvec3 hi{0.0};
};

/// Where a point lands on screen (pixels, origin at the top-left corner) and its view depth.
struct ScreenPoint {
    double x = 0.0;
    double y = 0.0;
    double depth = 0.0;
};

/// The camera's frustum and error scale, computed once per frame.
class ViewMetric {
  public:
    explicit ViewMetric(const Camera& camera);

    const Camera& camera() const { return camera_; }
    /// K * c^2: pixels of projected error per metre of vertical error at one metre's distance.
    double errorScale() const { return error_scale_; }

    /// Upper bound in pixels on the projected shift of any point of `box` displaced vertically by
    /// `error_metres`, over the part of the box inside the frustum; 0 if none of it is inside.
    double screenError(const Box& box, double error_metres) const;
    /// The same bound ignoring the frustum (what the box would need if the camera turned to it).
    double screenErrorAnyDirection(const Box& box, double error_metres) const {
        return screenErrorAtDistance(distanceTo(box), error_metres);
    }
    /// The same for a box already known to be `distance` metres from the eye.
    double screenErrorAtDistance(double distance, double error_metres) const {
        // visible points are at least the near plane away
        return error_scale_ * error_metres /
               (distance > camera_.near_plane ? distance : camera_.near_plane);
    }
    bool intersectsFrustum(const Box& box) const;
    /// How far the eye must move (metres, view direction fixed) before `box`, which intersects
    /// the frustum, can lie wholly outside it: the planes move with the eye.
    double exitSlack(const Box& box) const;
    double distanceTo(const Box& box) const;

    /// Projection; depth <= near plane means the point is not visible.
    ScreenPoint project(const glm::dvec3& p) const;
    /// The inverse: the unit direction from the eye through pixel position (x, y) (a click).
    glm::dvec3 rayThrough(double x, double y) const;
    bool isVisible(const ScreenPoint& s) const {
        return s.depth >= camera_.near_plane && s.x >= 0.0 && s.y >= 0.0 &&
               s.x <= camera_.viewport_width && s.y <= camera_.viewport_height;
    }

  private:
    struct Plane {
        glm::dvec3 normal{0.0}; ///< pointing into the frustum
        double offset = 0.0;
    };

    Camera camera_;
    glm::dvec3 forward_{0.0};
    glm::dvec3 right_{0.0};
    glm::dvec3 up_{0.0};
    double focal_pixels_ = 0.0; ///< K
    double error_scale_ = 0.0;  ///< K * c^2
    std::array<Plane, 5> planes_{};
};

} // namespace terrain::roam
