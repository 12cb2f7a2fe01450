#pragma once

// The camera paths of the speed-against-accuracy benchmark, for any map (sizes, speeds and
// altitudes scale with its extent, so a 1 km procedural map and an 80 km SRTM tile are flown
// alike). Each frame is a camera and its events (a teleport, the shots that land before it).
// Seeded and pure.
//
//   cruise    a wide circle at 0.02 x the map's width above the ground (15-150 m), the view
//             wobbling 8 degrees around the direction of travel
//   low       the same circle at a seventh of that height, slower, looking ahead
//   hover     still, turning slowly on the spot
//   whip      drifting, and every 40 frames a 180-degree whip pan in 8 frames (1350 deg/s)
//   teleport  cruise, jumping to another part of the map every 60 frames
//   battle    straight across a battle zone, 12 m over its craters, while shots land (the
//             caller fires them with the battle generator: BattleFrame::shots per frame, after
//             pre_shots before frame 0)

#include <terrain/battle.h>
#include <terrain/roam/camera.h>
#include <terrain/terrain.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace terrain::lodlab {

enum class FlightKind : std::uint8_t { kCruise, kLow, kHover, kWhip, kTeleport, kBattle };
inline constexpr std::array<FlightKind, 6> kAllFlights = {
    FlightKind::kCruise, FlightKind::kLow,      FlightKind::kHover,
    FlightKind::kWhip,   FlightKind::kTeleport, FlightKind::kBattle};

const char* toString(FlightKind kind);
std::optional<FlightKind> parseFlight(const std::string& name);

struct FlightOptions {
    FlightKind kind = FlightKind::kCruise;
    int frames = 300;
    double hz = 60.0;
    int width = 1280;
    int height = 720;
    double fovy_degrees = 60.0;
    std::uint64_t seed = 1;
    int battle_shots_per_frame = 1;
};

struct FlightFrame {
    roam::Camera camera;
    bool teleport = false; ///< the eye jumped to this frame
    int shots = 0;         ///< battle: shots to fire (and apply) before this frame
};

/// The battle zone every battle flight crosses: the map's centre.
struct BattleZone {
    double x = 0.0;
    double y = 0.0;
    double radius = 40.0;
};
BattleZone battleZone(const Terrain& terrain);
/// The battle generator aimed at battleZone(terrain): the battle flight's shots.
BattleGenerator battleGenerator(const Terrain& terrain);
/// Fires `shots` of `generator` at `terrain`, applying every crater it makes.
void fireShots(BattleGenerator& generator, Terrain& terrain, int shots);

/// The frames of a flight over `terrain` as it is now (the ground it follows is this one's).
std::vector<FlightFrame> makeFlight(const Terrain& terrain, const FlightOptions& options);

} // namespace terrain::lodlab
