#pragma once

// Deformation ops: the canonical integer form that is validated, applied, journaled and sent on
// the wire, and the float request a game or a tool fills in. Pure: no globals, no I/O.

#include <terrain/result.h>
#include <terrain/world_spec.h>

#include <cstdint>
#include <string>

namespace terrain {

enum class OpKind : std::uint8_t {
    kCrater = 1,  ///< blast: bowl `height` deep below the ground around it, rim `strength * height`
    kRaise = 2,   ///< smooth mound of signed height `height` (negative digs)
    kFlatten = 3, ///< blends towards absolute height `height` by `strength`, fading to the edge
    kSmooth = 4,  ///< relaxes towards the neighbour average by `strength`, fading to the edge
};

const char* toString(OpKind kind);

/// Strength and ratios in [0, 1] as 16.16 fixed point.
inline constexpr std::int32_t kUnitStrength = 1 << 16;

/// Canonical op: every field an integer in quanta (positions, radius, heights) or 16.16 fixed
/// point (strength). Two replicas that apply the same DeformOp reach the same bits.
struct DeformOp {
    OpKind kind = OpKind::kCrater;
    std::int64_t center_x = 0;             ///< quanta from vertex column 0
    std::int64_t center_y = 0;             ///< quanta from vertex row 0
    std::int32_t radius = 0;               ///< quanta; craters affect up to 2 * radius (ejecta)
    std::int32_t height = 0;               ///< quanta: depth, mound height or target height
    std::int32_t strength = kUnitStrength; ///< 16.16: rim ratio, or blend factor

    friend bool operator==(const DeformOp&, const DeformOp&) = default;
};

/// The same op in metres and plain ratios, as a caller writes it. Untrusted.
struct OpRequest {
    OpKind kind = OpKind::kCrater;
    double x = 0.0;        ///< metres
    double y = 0.0;        ///< metres
    double radius = 0.0;   ///< metres
    double height = 0.0;   ///< metres
    double strength = 1.0; ///< [0, 1]
};

/// Largest op footprint, so that one op's cost stays bounded on every map. A crater is at most
/// as deep as it is wide in radius (steeper bowls are shafts, not craters).
inline constexpr std::int32_t kMaxRadiusCells = 128;
inline constexpr double kMaxRadiusMetres = 2000.0;
inline constexpr double kMaxOpHeightMetres = 1000.0;

/// Range of valid radii on this world, in quanta.
struct RadiusRange {
    std::int32_t min = 0;
    std::int32_t max = 0;
};
RadiusRange radiusRange(const WorldSpec& spec);

/// Outer radius of the op's footprint in quanta (2 * radius for craters, radius otherwise).
std::int64_t footprintRadius(const DeformOp& op);

/// Checks a canonical op against the world: known kind, centre inside the map, radius, height and
/// strength in range. The error names the rule broken. Never asserts: ops come from the network.
Status validateOp(const DeformOp& op, const WorldSpec& spec);

/// Converts and validates a request: every number finite, then quantized to the nearest
/// quantum (strength to 1/65536), then validateOp().
Result<DeformOp> quantizeOp(const OpRequest& request, const WorldSpec& spec);

/// One line, for logs and the CLI: "crater x=12.5 y=40 r=3 h=1.5 s=0.25" (metres).
std::string describe(const DeformOp& op, const WorldSpec& spec);

} // namespace terrain
