// The fly camera's math: moves along its axes at its speed, turns without flipping, stays above
// the ground, and the scripted orbit circles its centre facing it.

#include <terrain/viewer/fly_camera.h>
#include <terrain/viewer/rolling_median.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>

namespace terrain::viewer {
namespace {

constexpr double kPi = 3.14159265358979323846;

void expectNear(const glm::dvec3& a, const glm::dvec3& b, double tolerance = 1e-9) {
    EXPECT_NEAR(a.x, b.x, tolerance);
    EXPECT_NEAR(a.y, b.y, tolerance);
    EXPECT_NEAR(a.z, b.z, tolerance);
}

TEST(FlyCamera, LooksAtItsTarget) {
    const glm::dvec3 eye(10.0, 20.0, 50.0);
    const glm::dvec3 target(200.0, 300.0, 30.0);
    const FlyCamera c = FlyCamera::lookingAt(eye, target);
    expectNear(c.forward(), glm::normalize(target - eye));
    EXPECT_NEAR(glm::length(c.forward()), 1.0, 1e-12);
    // right is horizontal and square to the view
    EXPECT_EQ(c.right().z, 0.0);
    EXPECT_NEAR(glm::dot(c.right(), c.forward()), 0.0, 1e-12);
    // x right, y forward, z up: right-handed
    EXPECT_GT(glm::dot(glm::cross(c.right(), c.forward()), glm::dvec3(0, 0, 1)), 0.0);
}

TEST(FlyCamera, MovesAtItsSpeedAlongItsAxes) {
    FlyCamera c({0.0, 0.0, 100.0}, 0.0, 0.0); // looking along +x
    c.speed = 10.0;
    c.step({.forward = 1.0}, 0.5);
    expectNear(c.eye(), {5.0, 0.0, 100.0});
    c.step({.right = 1.0}, 1.0); // +x view: right is -y
    expectNear(c.eye(), {5.0, -10.0, 100.0});
    c.step({.up = -1.0, .fast = true}, 0.1); // shift: fast_factor times
    expectNear(c.eye(), {5.0, -10.0, 100.0 - c.fast_factor});
    // forward follows the pitch; strafing does not
    FlyCamera down({0.0, 0.0, 100.0}, 0.0, -kPi / 4);
    down.speed = 1.0;
    down.step({.forward = 1.0}, std::sqrt(2.0));
    expectNear(down.eye(), {1.0, 0.0, 99.0});
    down.step({.right = 1.0}, 1.0);
    EXPECT_NEAR(down.eye().z, 99.0, 1e-12);
}

TEST(FlyCamera, TurnsWithoutFlipping) {
    FlyCamera c({0.0, 0.0, 0.0}, 0.0, 0.0);
    c.step({.yaw = kPi / 2}, 0.0);
    expectNear(c.forward(), {0.0, 1.0, 0.0});
    c.step({.pitch = 3.0}, 0.0);
    EXPECT_DOUBLE_EQ(c.pitch(), FlyCamera::kMaxPitch);
    c.step({.pitch = -10.0}, 0.0);
    EXPECT_DOUBLE_EQ(c.pitch(), -FlyCamera::kMaxPitch);
    // many turns keep yaw bounded
    for (int i = 0; i < 1000; ++i)
        c.step({.yaw = 1.0}, 0.0);
    EXPECT_LE(std::abs(c.yaw()), kPi);
}

TEST(FlyCamera, StaysAboveTheGroundAndInsideItsBox) {
    FlyCamera c({5.0, 5.0, 10.0}, 0.0, 0.0);
    EXPECT_FALSE(c.keepAbove(7.0, 2.0)); // already above 9
    EXPECT_EQ(c.eye().z, 10.0);
    c.speed = 100.0;
    c.step({.up = -1.0}, 1.0); // dives through the ground
    EXPECT_TRUE(c.keepAbove(7.0, 2.0));
    EXPECT_EQ(c.eye().z, 9.0);
    c.keepWithin({0.0, 0.0}, {4.0, 100.0});
    expectNear(c.eye(), {4.0, 5.0, 9.0});
}

TEST(FlyCamera, CameraMatchesTheViewport) {
    const FlyCamera c = FlyCamera::lookingAt({0.0, 0.0, 40.0}, {100.0, 50.0, 0.0});
    const roam::Camera rc = c.camera(640, 400);
    EXPECT_EQ(rc.viewport_width, 640);
    EXPECT_EQ(rc.viewport_height, 400);
    expectNear(rc.eye, c.eye());
    // the centre pixel's ray is the view direction: what --auto-crater shoots along
    expectNear(roam::ViewMetric(rc).rayThrough(320.0, 200.0), c.forward(), 1e-12);
    // a pixel above the centre looks higher
    EXPECT_GT(roam::ViewMetric(rc).rayThrough(320.0, 10.0).z, c.forward().z);
}

TEST(FlyCamera, OrbitCirclesTheCentreFacingIt) {
    const glm::dvec2 centre(500.0, 500.0);
    FlyCamera c = FlyCamera::lookingAt({250.0, 250.0, 60.0}, {500.0, 500.0, 40.0});
    c.speed = 30.0;
    const double radius = glm::length(glm::dvec2(c.eye()) - centre);
    const double dt = 1.0 / 30.0;
    const double rate = 9.0 * kPi / 180.0;
    const glm::dvec3 start = c.eye();
    for (int i = 0; i < 300; ++i)
        c.step(orbitInput(c, centre, rate, dt), dt);
    // 10 s at 9 deg/s: a quarter turn, at (nearly) the same distance and height, still facing in
    const glm::dvec2 to_eye = glm::dvec2(c.eye()) - centre;
    EXPECT_NEAR(glm::length(to_eye), radius, 0.01 * radius);
    EXPECT_NEAR(c.eye().z, start.z, 1e-9);
    const glm::dvec2 from = glm::normalize(glm::dvec2(start) - centre);
    EXPECT_NEAR(std::acos(glm::dot(from, glm::normalize(to_eye))), kPi / 2, 0.01);
    const glm::dvec2 facing = glm::normalize(glm::dvec2(c.forward()));
    EXPECT_GT(glm::dot(facing, -glm::normalize(to_eye)), 0.999);
}

TEST(RollingMedian, KeepsTheLastWindow) {
    RollingMedian m(3);
    EXPECT_EQ(m.median(), 0.0);
    m.push(5.0);
    EXPECT_EQ(m.median(), 5.0);
    m.push(1.0);
    m.push(100.0);
    EXPECT_EQ(m.median(), 5.0);
    m.push(2.0); // 5 drops out: {1, 100, 2}
    m.push(3.0); // 1 drops out: {100, 2, 3}
    EXPECT_EQ(m.size(), 3u);
    EXPECT_EQ(m.median(), 3.0);
    EXPECT_EQ(medianOf({4.0, 1.0, 3.0, 2.0}), 3.0);
    EXPECT_EQ(medianOf({}), 0.0);
}

} // namespace
} // namespace terrain::viewer
