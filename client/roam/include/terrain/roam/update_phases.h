#pragma once

// The passes of Tessellator::update(), named so that an observer at the edge (a worker, a
// benchmark) can time them: the tessellator calls enter() as each begins and never reads a clock
// itself.

#include <cstdint>

namespace terrain::roam {

enum class UpdatePhase : std::uint8_t {
    kStaleBounds, ///< bounds that ops made stale, redone (BoundsUpdate)
    kRebuild,     ///< the top-down build after a jump or a new world
    kSplitMerge,  ///< the policy's splits and merges (SplitMerge)
    kFinishFrame, ///< the tiles' end of frame: holes filled, visibility, counts (TileEmitter)
    kPoolUpkeep,  ///< idle blocks swept, grains compacted (BlockPool)
    kDone,        ///< update() returns
};
inline constexpr int kUpdatePhases = 5; ///< kDone excluded

class UpdatePhaseObserver {
  public:
    virtual ~UpdatePhaseObserver() = default;
    /// `phase` begins (the previous one ends).
    virtual void enter(UpdatePhase phase) = 0;
};

/// The end of a worker's short step, as the tessellator's budgets read it: the tessellator asks,
/// the edge reads the clock.
class StepDeadline {
  public:
    /// Whether `share` of the step's time is spent (1: all of it).
    virtual bool spent(double share) const = 0;

  protected:
    ~StepDeadline() = default;
};

} // namespace terrain::roam
