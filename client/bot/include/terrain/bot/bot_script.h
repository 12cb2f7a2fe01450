#pragma once

// What a bot does, as pure functions of the frame number and its seed: where the camera is
// (an orbit around a focus point, looking at it) and which screen pixels it "clicks" to blast
// craters. No clocks, no I/O: two runs with one seed fly and aim the same way.

#include <terrain/roam/camera.h>
#include <terrain/terrain.h>

#include <cstdint>

namespace terrain::bot {

struct ScriptOptions {
    std::uint64_t seed = 1;
    int frames = 600;
    int viewport_width = 640;
    int viewport_height = 360;
    double orbit_radius_metres = 140.0;
    double altitude_metres = 70.0; ///< above the focus point
    double sweep_degrees = 120.0;  ///< orbit angle covered over the run
    int craters = 10;
    double crater_radius_min = 4.0;
    double crater_radius_max = 10.0;
    double crater_depth_min = 1.5;
    double crater_depth_max = 4.0;
};

struct CraterShot {
    double pixel_x = 0.0; ///< where the "click" lands, pixels from the top-left corner
    double pixel_y = 0.0;
    double radius = 0.0;
    double depth = 0.0;
};

class BotScript {
  public:
    BotScript(const ScriptOptions& options, const WorldSpec& spec);

    /// The focus: a seeded point in the middle half of the map that the bot orbits and shoots at.
    double focusX() const { return focus_x_; }
    double focusY() const { return focus_y_; }
    /// Camera at `frame` (0 .. frames-1); the eye stays `clearance` above `terrain`'s surface.
    roam::Camera camera(int frame, const Terrain& terrain) const;
    /// True when a crater is due at `frame` (spread evenly over the first 80 % of the frames).
    bool craterDue(int frame) const;
    /// The shot for `frame` (seeded; near the screen centre, below the horizon).
    CraterShot shot(int frame) const;

  private:
    ScriptOptions options_;
    double focus_x_ = 0.0;
    double focus_y_ = 0.0;
    double extent_x_ = 0.0;
    double extent_y_ = 0.0;
};

} // namespace terrain::bot
