#pragma once

// A battle: craters aimed the way players aim them, at what earlier shots left. Each shot is a
// ray from a player's camera (orbiting the fight, low and far for grazing shots, high and near
// for steep ones) towards a point in the battle zone or near an earlier hit, cast against the
// surface as it is now; the crater lands where the ray first meets the ground: the crest in
// front, the far wall of a crater, its floor. The caller applies each shot before asking for the
// next, so every shot sees the ones before it: the feedback that grew needles out of additive
// craters. Seeded and pure (an integer hash for every random number; the ray cast is the
// surface query's, in doubles, so the requests are reproducible on one platform; replicas
// elsewhere replay the canonical ops instead).

#include <terrain/deform_op.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <optional>
#include <vector>

namespace terrain {

struct BattleOptions {
    std::uint64_t seed = 1;
    double zone_x = 512.0; ///< metres: the centre of the fighting
    double zone_y = 512.0;
    double zone_radius = 40.0; ///< metres: fresh aim points fall within it
    int players = 8;           ///< cameras, each on its own orbit around the aim point
    double orbit_degrees_per_shot = 2.0;
    double min_range = 15.0; ///< metres, horizontal, camera to aim point
    double max_range = 160.0;
    double min_altitude = 1.7; ///< metres above the ground under the camera (low = grazing)
    double max_altitude = 60.0;
    /// Share of shots aimed near one of the last hits (players shoot where the fight is).
    double follow_share = 0.5;
    double follow_spread = 3.0; ///< metres around that hit
    double min_radius = 1.5;    ///< crater radius, metres
    double max_radius = 6.0;
    double min_depth_ratio = 0.3; ///< depth / radius
    double max_depth_ratio = 0.8;
    double min_rim_ratio = 0.25; ///< rim height / depth (0.375 puts the cavity back as ejecta)
    double max_rim_ratio = 0.45;
};

/// One shot as it was aimed: the ray and, if it met the ground, the crater request.
struct BattleShot {
    glm::dvec3 eye{0.0};
    glm::dvec3 aim{0.0};
    std::optional<OpRequest> crater; ///< nothing when the ray left the map without a hit
};

class BattleGenerator {
  public:
    explicit BattleGenerator(const BattleOptions& options);

    /// Aims the next shot at `terrain` as it is now.
    BattleShot next(const Terrain& terrain);

    int fired() const { return fired_; }
    int missed() const { return missed_; }
    const BattleOptions& options() const { return options_; }

  private:
    double unit(std::uint64_t stream) const; // [0, 1) for this shot and stream

    BattleOptions options_;
    int fired_ = 0;
    int missed_ = 0;
    std::vector<glm::dvec3> recent_; // the last hits, a ring
    std::size_t recent_next_ = 0;
};

} // namespace terrain
