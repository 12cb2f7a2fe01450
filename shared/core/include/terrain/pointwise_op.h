#pragma once

// The pointwise deformations (crater, raise, flatten) as one function of position and old
// height, z' = F(x, y, z), exact integer arithmetic in 1/48 quanta (kFineScale).
//
// A crater carves towards a profile and throws no more than it carved. Before it changes
// anything it surveys the surface (surveyGround): the plane P through the circle at twice its
// radius (which it never changes), the anchor (where the shot struck, relative to P), and the
// volume balance. Its profile S = P + anchor (1 - t^2/4)^2 + s(t), s a bowl `depth` deep with a
// rim at R falling to 0 at 2R, is reached by moving the old surface by at most
// limit = (depth + rim) (1 - t^2/4)^2 either way:
//     z > S:  z' = max(S, z - limit)                 (carve)
//     z < S:  z' = z + share * min(S - z, limit)     (ejecta and fallback)
// and never below the floor (original ground - 2 depths) nor above the ceiling (original ground
// + rim), measured from the ground the world began with (Terrain::original). So no point ever
// rises more than twice the largest rim above its original ground nor sinks more than two
// depths below it, hits on one spot settle, a crest behind a hit is cut, never raised, and the
// limit's taper adds no cliff at the footprint's edge. ARCHITECTURE.md ("The crater model")
// gives the reasons and the bounds.
//
// Pure: reads the terrain it is given, changes nothing.

#include <terrain/deform_op.h>

#include <cstdint>

namespace terrain {

class Terrain;

/// What a crater learned of the ground before it changed it. Every replica computes the same
/// integers from the same state.
struct BlastGround {
    std::int64_t level48 = 0; ///< the ground plane at the crater's centre (1/48 quanta)
    std::int64_t slope_x = 0; ///< its gradient, 16.16 (height per horizontal distance)
    std::int64_t slope_y = 0;
    /// How far above or below the plane the profile hangs at the centre: the offset of the
    /// original ground where the shot struck, plus what ops have moved it since, counted softly
    /// (d K D / (K D + |d|), K = kAnchorDepths). Tapers to 0 at 2R.
    std::int64_t anchor48 = 0;
    std::int64_t ring_min48 = 0; ///< lowest and highest ground sample on the circle at 2R
    std::int64_t ring_max48 = 0;
    /// 16.16, at most 1: the volume the blast carves over the room there is to fill (both
    /// within the limit); every fill is scaled by it, so the ejecta never outweigh the cavity.
    std::int32_t ejecta_share = kUnitStrength;
    /// 16.16, 0 .. kMaxRimGrowth: how much higher than nominal the rim stands because the blast
    /// carved more than the nominal profile had room for (a hit on high ground).
    std::int32_t rim_growth = 0;
};

/// What a crater has dug below the original ground where it strikes lowers its anchor softly,
/// d K D / (K D + |d|): repeated hits on one spot dig a depth, then 2/3, 1/4, 1/15, ... of it,
/// and settle two depths under the original ground.
inline constexpr std::int64_t kAnchorDepths = 2;
/// No crater digs more than this many of its depths below the original ground.
inline constexpr std::int64_t kFloorDepths = 2;

/// The rim may grow to twice its nominal height to hold what a blast carved.
inline constexpr std::int32_t kMaxRimGrowth = kUnitStrength;

/// Samples on the circle at 2R; for the ejecta share, on kSurveyRings circles inside it.
inline constexpr int kRingSamples = 16;
inline constexpr int kSurveyRings = 8;

/// Exact height (1/48 quanta) of the surface at the point of the 1/16-cell lattice nearest to
/// (x, y) quanta, clamped to the map: a patch's own 17 x 17 grid, or the base triangles.
std::int64_t latticeHeight48(const Terrain& t, std::int64_t x, std::int64_t y);
/// The same for the original ground (the base triangles over Terrain::original()).
std::int64_t latticeOriginal48(const Terrain& t, std::int64_t x, std::int64_t y);

/// Surveys the ground under a crater (`op` must be a valid crater on `t`): the plane through
/// kRingSamples samples on the circle of radius 2R, its tilt limited so that it stays within
/// the samples' range over the whole footprint; and the ejecta share, from kSurveyRings x
/// kRingSamples samples over the footprint.
BlastGround surveyGround(const Terrain& t, const DeformOp& op);

/// A crater's terms at one point (1/48 quanta).
struct CraterTerms {
    bool inside = false;     ///< within the footprint (r < 2R); outside nothing changes
    std::int64_t ratio = 0;  ///< t = r / R, 16.16
    std::int64_t relief = 0; ///< s(t): bowl (-depth at the centre) and rim, above the plane
    std::int64_t target = 0; ///< S = plane + anchor (1 - t^2/4)^2 + s(t)
    std::int64_t limit = 0;  ///< the most the blast moves the ground here, up or down
};

class PointwiseOp {
  public:
    /// `op` must be valid on `before`, the surface it lands on; craters survey it.
    PointwiseOp(const DeformOp& op, const Terrain& before);
    /// With a survey already made (tests, and callers that reuse one).
    PointwiseOp(const DeformOp& op, const BlastGround& ground);

    const DeformOp& op() const { return op_; }
    const BlastGround& ground() const { return ground_; }
    /// A crater's rim height as it stands (grown by the survey), 1/48 quanta.
    std::int64_t rim48() const { return rim48_; }

    /// New height (1/48 quanta) at (x48, y48) (1/48 quanta) where the old height is z48 and
    /// the original ground original48 (craters are bounded by it; the other kinds ignore it).
    /// Smooth is not pointwise: it returns z48 (see deformation.cpp).
    std::int64_t
    height(std::int64_t x48, std::int64_t y48, std::int64_t z48, std::int64_t original48) const;

    /// A crater's floor and ceiling at a point whose original ground is original48: it never
    /// digs below the one nor throws above the other (ground already beyond stays).
    std::int64_t floor48(std::int64_t original48) const {
        return original48 - kFloorDepths * depth48_;
    }
    std::int64_t ceiling48(std::int64_t original48) const { return original48 + rim48_; }

    /// Crater only.
    CraterTerms craterTerms(std::int64_t x48, std::int64_t y48) const;
    /// The ground plane at a point (crater only; 1/48 quanta).
    std::int64_t plane48(std::int64_t x48, std::int64_t y48) const;
    /// s(t) for a radius ratio t (16.16): -depth at 0, rim height at 1, 0 from 2 on.
    std::int64_t relief48(std::int64_t ratio) const;
    /// The limit for a radius ratio: (depth + rim) (1 - t^2 / 4)^2, 0 from 2R on.
    std::int64_t limit48(std::int64_t ratio) const;
    /// The anchor's share at a radius ratio: anchor (1 - t^2 / 4)^2.
    std::int64_t anchor48(std::int64_t ratio) const;
    /// (1 - t^2 / 4)^2 in 16.16, 0 from t = 2 on: the taper of the limit and the anchor.
    static std::int64_t taper(std::int64_t ratio);

    /// radiusRatio(op(), r2), without its 64-bit division (the footprint loops' hottest step,
    /// and twice in each square the patch decision proves).
    std::int64_t ratio(std::int64_t r2) const;

  private:
    DeformOp op_;
    BlastGround ground_;
    std::int64_t depth48_ = 0;
    std::int64_t rim48_ = 0;
    std::int64_t radius48_ = 0;
    double ratio_per_root_ = 0.0; ///< 2^16 / radius48_: the estimate ratio() corrects
};

/// Radius ratio t = r / R in 16.16 from a squared distance in (1/48 quanta)^2.
std::int64_t radiusRatio(const DeformOp& op, std::int64_t r2);

/// Squared distance in (1/48 quanta)^2 from the op's centre; axis offsets are clamped beyond
/// twice the radius (outside every footprint), which keeps it below 2^61 on any map.
std::int64_t squaredDistance48(const DeformOp& op, std::int64_t x48, std::int64_t y48);

/// Fade weight (16.16) of a point for smooth and flatten: (1 - r^2/R^2)^2 inside R, 0 outside.
std::int64_t fadeWeight(const DeformOp& op, std::int64_t x48, std::int64_t y48);

} // namespace terrain
