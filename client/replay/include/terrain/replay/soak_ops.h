#pragma once

// Fuzzed ops for a soak: a seeded mix of
//   battle   craters aimed the way players aim them, at the ground as it is now (battle.h)
//   random   every kind with parameters drawn across their valid ranges, anywhere on the map
//   extreme  parameters at the rules' edges, as canonical ops: the smallest and (rarely, they
//            cost a thousand small craters each) the largest radius, the map's corners and
//            edges, the deepest crater and the highest raise the radius allows, raise down as
//            well as up, flatten to the lowest and highest heights, strengths of 1/65536 and 1
//   invalid  what a bad client sends: NaN, infinities, zero and negative radii, centres off the
//            map, strengths outside [0, 1], a smooth with a height; the server must refuse each
//            with its reason and change nothing
// Pure: no sockets, no clocks.

#include <terrain/battle.h>
#include <terrain/replay/live_run.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <random>

namespace terrain::replay {

struct SoakMix {
    double battle = 0.60;
    double random = 0.25;
    double extreme = 0.10;  ///< the rest is invalid
    double largest = 0.002; ///< share of extreme ops at the largest radius
};

struct SoakCounts {
    std::uint64_t battle = 0, random = 0, extreme = 0, largest = 0, invalid = 0;
    std::uint64_t total() const { return battle + random + extreme + invalid; }
};

class SoakOps {
  public:
    SoakOps(std::uint64_t seed, const WorldSpec& spec, SoakMix mix = {});
    /// The next request, aimed (battle shots) at `current`, the ground as a client holds it.
    FeedRequest next(const Terrain& current);
    const SoakCounts& counts() const { return counts_; }

  private:
    double uniform(double lo, double hi);
    OpRequest randomOp();
    DeformOp extremeOp();
    OpRequest invalidOp();

    WorldSpec spec_;
    SoakMix mix_;
    std::mt19937_64 rng_;
    BattleGenerator battle_;
    SoakCounts counts_;
};

} // namespace terrain::replay
