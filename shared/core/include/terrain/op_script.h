#pragma once

// Op scripts: a text form of deformation requests for tools, tests and replays, and a seeded
// random crater series. Pure: parsing works on text already in memory.
//
// Script format, one op per line, metres; blank lines and '#' comments are ignored:
//   crater  <x> <y> <radius> <depth> [rim_ratio=0.25]
//   raise   <x> <y> <radius> <height>
//   flatten <x> <y> <radius> <target_height> [strength=1]
//   smooth  <x> <y> <radius> [strength=1]

#include <terrain/deform_op.h>
#include <terrain/result.h>
#include <terrain/world_spec.h>

#include <cstdint>
#include <string_view>
#include <vector>

namespace terrain {

/// Errors: kBadFormat naming the line and the rule (unknown kind, wrong field count, a field
/// that is not a number). Ranges are checked later, per op, by quantizeOp().
Result<std::vector<OpRequest>> parseOpScript(std::string_view text);

struct CraterSeries {
    std::uint64_t seed = 1;
    int count = 100;
    double min_radius = 1.5;  ///< metres
    double max_radius = 6.0;  ///< metres
    double depth_ratio = 0.4; ///< depth = ratio * radius
    double rim_ratio = 0.25;
    double margin = 0.0; ///< keep centres this far (metres) from the map edge
};

/// A deterministic series of crater requests spread over the map (integer RNG, so the same seed
/// gives the same requests everywhere).
std::vector<OpRequest> randomCraters(const WorldSpec& spec, const CraterSeries& series);

} // namespace terrain
