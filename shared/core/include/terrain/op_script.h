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
#include <string>
#include <string_view>
#include <vector>

namespace terrain {

/// Errors: kBadFormat naming the line and the rule (unknown kind, wrong field count, a field
/// that is not a number). Ranges are checked later, per op, by quantizeOp().
Result<std::vector<OpRequest>> parseOpScript(std::string_view text);

/// Canonical op scripts: the exact integers of DeformOp, one op per line, for replays that must
/// reach the same bits anywhere (the golden battle, cross-CPU checks). '#' comments allowed:
///   <crater|raise|flatten|smooth> <center_x> <center_y> <radius> <height> <strength>
/// (quanta, and 16.16 for strength). Errors: kBadFormat naming the line and the rule. Ranges are
/// checked when the ops are applied (validateOp()).
Result<std::vector<DeformOp>> parseCanonicalOps(std::string_view text);

/// One line of that form, without the newline.
std::string formatCanonicalOp(const DeformOp& op);

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
