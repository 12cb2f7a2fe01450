#pragma once

// The viewer's fly camera: a position plus yaw and pitch, moved by one input struct per frame.
// Pure math (no GLFW, no clocks: the caller passes dt), so tests drive it directly and the
// scripted flight (--fly) goes through the same code as the keyboard.
// World frame as surface_query.h: metres, x east, y north, z up.

#include <terrain/roam/camera.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace terrain::viewer {

/// One frame's worth of intent. Axes are multiples of the camera's speed (keys give -1, 0, 1).
struct FlyInput {
    double forward = 0.0; ///< along the view direction (W/S), pitch included
    double right = 0.0;   ///< horizontal, across the view (D/A)
    double up = 0.0;      ///< world up (E/Q)
    bool fast = false;    ///< shift: fast_factor times the speed
    double yaw = 0.0;     ///< radians to turn left this frame (mouse, arrows)
    double pitch = 0.0;   ///< radians to look up this frame
};

class FlyCamera {
  public:
    /// Looking along yaw (radians from +x towards +y) and pitch (radians above horizontal).
    FlyCamera(const glm::dvec3& eye, double yaw, double pitch);
    /// Looking from `eye` at `target` (pitch clamped like any other).
    static FlyCamera lookingAt(const glm::dvec3& eye, const glm::dvec3& target);

    /// Turns first, then moves by speed * dt along the turned axes.
    void step(const FlyInput& input, double dt_seconds);
    /// Lifts the eye to at least `ground_z + clearance` (the surface under it); true if it moved.
    bool keepAbove(double ground_z, double clearance);
    /// Clamps the eye's x and y into the rectangle.
    void keepWithin(const glm::dvec2& lo, const glm::dvec2& hi);

    const glm::dvec3& eye() const { return eye_; }
    double yaw() const { return yaw_; }
    double pitch() const { return pitch_; }
    /// Unit view direction.
    glm::dvec3 forward() const;
    /// Unit horizontal vector to the right of the view.
    glm::dvec3 right() const;

    /// The tessellator's and renderer's camera for a framebuffer of this size.
    roam::Camera camera(int viewport_width, int viewport_height) const;

    double speed = 40.0; ///< metres per second
    double fast_factor = 5.0;
    double fovy_radians = 60.0 * 3.14159265358979323846 / 180.0;
    double near_plane = 0.5;

    /// Pitch stays this far from straight up or down, so the view never flips.
    static constexpr double kMaxPitch = 89.0 * 3.14159265358979323846 / 180.0;

  private:
    glm::dvec3 eye_;
    double yaw_;
    double pitch_;
};

/// Input that circles `centre` (horizontally) at `radians_per_second`, facing it: strafe right
/// at the speed that covers the arc, turn left by the arc's angle. The scripted flight.
FlyInput orbitInput(
    const FlyCamera& camera,
    const glm::dvec2& centre,
    double radians_per_second,
    double dt_seconds);

} // namespace terrain::viewer
