#pragma once

// The golden battle's shots: two craters 15-40 m ahead of a low camera flying along (0.9, 0.45),
// up to 10 m to either side, from a seeded generator. Shared by the golden meshes and the mesh
// deltas' tests, which fly the same battle.

#include <terrain/deform_op.h>
#include <terrain/roam/tessellator.h>
#include <terrain/terrain.h>

#include <random>
#include <span>

namespace terrain::testing {

/// Fires the two craters ahead of (x, y) on `t` and tells `tess` (a shot off the map is
/// skipped, its draws still made).
inline void
shootAhead(Terrain& t, roam::Tessellator& tess, std::mt19937_64& rng, double x, double y) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int shot = 0; shot < 2; ++shot) {
        const double ahead = 15.0 + 25.0 * unit(rng);
        const double side = (unit(rng) - 0.5) * 20.0;
        OpRequest r;
        r.x = x + ahead * 0.9 - side * 0.45;
        r.y = y + ahead * 0.45 + side * 0.9;
        r.radius = 1.0 + 4.0 * unit(rng);
        r.height = 0.4 * r.radius;
        r.strength = 0.3 + 0.5 * unit(rng);
        auto op = quantizeOp(r, t.spec());
        if (!op)
            continue; // off the map
        auto effect = t.apply(*op);
        if (effect)
            tess.terrainChanged(std::span<const CellRect>(&effect->cells, 1), false);
    }
}

} // namespace terrain::testing
