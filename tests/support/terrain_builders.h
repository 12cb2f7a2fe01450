#pragma once

// Builders shared by the test suites: small worlds with known content.

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/terrain.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace terrain::testing {

/// Flat world at `height_m`, spacing in metres.
inline Terrain
makeFlat(std::int32_t w, std::int32_t h, double spacing_m = 1.0, double height_m = 10.0) {
    WorldSpec spec;
    spec.width = w;
    spec.height = h;
    spec.spacing = static_cast<std::int32_t>(spacing_m * spec.units_per_metre);
    std::vector<std::int32_t> s(
        static_cast<std::size_t>(w) * static_cast<std::size_t>(h),
        static_cast<std::int32_t>(height_m * spec.units_per_metre));
    auto t = Terrain::create(spec, s);
    EXPECT_TRUE(t.ok());
    return std::move(*t);
}

/// Rolling procedural world; sizes deliberately not k * 64 + 1 so padding is exercised.
inline Terrain
makeHills(std::uint64_t seed, std::int32_t w = 150, std::int32_t h = 140, double spacing_m = 1.0) {
    ProceduralMapOptions o;
    o.seed = seed;
    o.width = w;
    o.height = h;
    o.spacing_metres = spacing_m;
    o.amplitude_metres = 12.0;
    o.wavelength_metres = 64.0;
    o.octaves = 4;
    auto t = makeProceduralMap(o);
    EXPECT_TRUE(t.ok());
    return std::move(*t);
}

/// Applies every request; all must be valid.
/// A square procedural map (the session and protocol tests' world).
inline Terrain smallMap(int size = 257, std::uint64_t seed = 5) {
    ProceduralMapOptions o;
    o.seed = seed;
    o.width = size;
    o.height = size;
    return std::move(*makeProceduralMap(o));
}

/// A small request of a random kind anywhere on the map, as a client in the session tests sends.
inline OpRequest randomRequest(std::mt19937_64& rng, const WorldSpec& spec) {
    const double extent = static_cast<double>(spec.spacing) / spec.units_per_metre * spec.cellsX();
    std::uniform_real_distribution<double> pos(2.0, extent - 2.0);
    std::uniform_real_distribution<double> radius(1.0, 6.0);
    std::uniform_real_distribution<double> depth(0.2, 2.0);
    std::uniform_int_distribution<int> kind(1, 4);
    OpRequest r;
    r.kind = static_cast<OpKind>(kind(rng));
    r.x = pos(rng);
    r.y = pos(rng);
    r.radius = radius(rng);
    r.height = r.kind == OpKind::kFlatten ? 40.0 : r.kind == OpKind::kSmooth ? 0.0 : depth(rng);
    r.strength = r.kind == OpKind::kRaise ? 1.0 : 0.5;
    return r;
}

/// Quantizes and applies one op; the cells it changed (empty if it failed: the test fails).
inline CellRect applyRequest(Terrain& t, const OpRequest& r) {
    auto op = quantizeOp(r, t.spec());
    EXPECT_TRUE(op.ok()) << op.error().message;
    if (!op.ok())
        return CellRect{0, 0, -1, -1};
    auto effect = t.apply(*op);
    EXPECT_TRUE(effect.ok()) << effect.error().message;
    return effect.ok() ? effect->cells : CellRect{0, 0, -1, -1};
}

/// Applies the ops in order; with `changed`, appends the cells each changed.
inline void
applyAll(Terrain& t, const std::vector<OpRequest>& ops, std::vector<CellRect>* changed = nullptr) {
    for (const OpRequest& r : ops) {
        const CellRect cells = applyRequest(t, r);
        if (changed != nullptr)
            changed->push_back(cells);
    }
}

/// Hashes recomputed from scratch through a snapshot round trip.
inline std::uint64_t freshHash(const Terrain& t);

} // namespace terrain::testing

#include <terrain/snapshot.h>

inline std::uint64_t terrain::testing::freshHash(const Terrain& t) {
    auto decoded = decodeSnapshot(encodeSnapshot(t, 0));
    EXPECT_TRUE(decoded.ok()) << (decoded.ok() ? "" : decoded.error().message);
    return decoded.ok() ? decoded->terrain.worldHash() : 0;
}
