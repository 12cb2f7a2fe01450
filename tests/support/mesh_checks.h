#pragma once

// Checks on a tessellator's mesh that do not trust the tessellator: conformity (no cracks, no
// T-junctions), agreement of the incremental index lists with the mesh, shared vertex heights.

#include <terrain/roam/tessellator.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace terrain::testing {

inline std::uint64_t packPoint(roam::LatticePoint p) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(p.x)) << 32) |
           static_cast<std::uint32_t>(p.y);
}

struct ConformityReport {
    std::int64_t leaves = 0;
    std::int64_t unmatched_interior_edges = 0; ///< edges with one triangle, not on the map border
    std::int64_t overshared_edges = 0;         ///< edges with more than two triangles
    std::int64_t area_error = 0;               ///< twice the area, leaves minus map
    std::string first_problem;
};

/// Every edge of the leaf triangles must be shared by exactly two of them, except edges on the
/// padded map's border (then exactly one), and the leaves must cover the map exactly. A crack or
/// a T-junction leaves an edge with one triangle on one side only.
inline ConformityReport checkConformity(const roam::Tessellator& tess, const WorldSpec& spec) {
    const std::int32_t max_x = (spec.paddedWidth() - 1) * roam::kLatticePerCell;
    const std::int32_t max_y = (spec.paddedHeight() - 1) * roam::kLatticePerCell;
    std::unordered_map<std::uint64_t, std::unordered_map<std::uint64_t, int>> edges;
    ConformityReport r;
    std::int64_t area2 = 0;
    tess.forEachLeaf([&](const roam::Triangle& t, std::int32_t, bool) {
        ++r.leaves;
        area2 += roam::cross(t.apex, t.left, t.right);
        const std::array<roam::LatticePoint, 3> v = {t.apex, t.left, t.right};
        for (int i = 0; i < 3; ++i) {
            std::uint64_t a = packPoint(v[i]);
            std::uint64_t b = packPoint(v[(i + 1) % 3]);
            if (a > b)
                std::swap(a, b);
            ++edges[a][b];
        }
    });
    auto on_border = [&](std::uint64_t a, std::uint64_t b) {
        const auto ax = static_cast<std::int32_t>(a >> 32),
                   ay = static_cast<std::int32_t>(a & 0xffffffffu);
        const auto bx = static_cast<std::int32_t>(b >> 32),
                   by = static_cast<std::int32_t>(b & 0xffffffffu);
        return (ax == bx && (ax == 0 || ax == max_x)) || (ay == by && (ay == 0 || ay == max_y));
    };
    for (const auto& [a, inner] : edges)
        for (const auto& [b, count] : inner) {
            if (count > 2) {
                ++r.overshared_edges;
            } else if (count == 1 && !on_border(a, b)) {
                if (r.first_problem.empty())
                    r.first_problem = "edge (" + std::to_string(a >> 32) + "," +
                                      std::to_string(a & 0xffffffffu) + ")-(" +
                                      std::to_string(b >> 32) + "," +
                                      std::to_string(b & 0xffffffffu) + ") has one triangle";
                ++r.unmatched_interior_edges;
            }
        }
    r.area_error = area2 - 2LL * max_x * max_y;
    return r;
}

inline void expectConforming(const roam::Tessellator& tess, const WorldSpec& spec) {
    const ConformityReport r = checkConformity(tess, spec);
    EXPECT_GT(r.leaves, 0);
    EXPECT_EQ(r.unmatched_interior_edges, 0) << r.first_problem;
    EXPECT_EQ(r.overshared_edges, 0);
    EXPECT_EQ(r.area_error, 0);
}

/// The tiles' index lists (maintained slot by slot) hold exactly the mesh's emitted leaves, and
/// every vertex position has one height wherever it appears (tiles, blocks).
inline void expectIndexListsMatchMesh(const roam::Tessellator& tess) {
    using Key = std::array<std::uint64_t, 4>;
    auto key_of = [](std::int32_t tile, std::array<roam::LatticePoint, 3> v) {
        std::array<std::uint64_t, 3> p = {packPoint(v[0]), packPoint(v[1]), packPoint(v[2])};
        std::sort(p.begin(), p.end());
        return Key{static_cast<std::uint64_t>(tile), p[0], p[1], p[2]};
    };
    std::map<Key, int> expected;
    tess.forEachLeaf([&](const roam::Triangle& t, std::int32_t tile, bool emitted) {
        if (emitted)
            ++expected[key_of(tile, {t.apex, t.left, t.right})];
    });
    std::map<Key, int> listed;
    std::unordered_map<std::uint64_t, std::int64_t> heights;
    std::int64_t height_mismatches = 0;
    std::int64_t live = 0;
    for (std::int32_t tile = 0; tile < tess.tileCount(); ++tile) {
        const auto idx = tess.tileMesh(tile).indices();
        for (std::size_t i = 0; i + 2 < idx.size(); i += 3) {
            if (idx[i] == 0 && idx[i + 1] == 0 && idx[i + 2] == 0)
                continue;
            std::array<roam::LatticePoint, 3> v{};
            for (std::size_t j = 0; j < 3; ++j) {
                ASSERT_LT(idx[i + j], static_cast<std::uint32_t>(tess.tileVertexCount(tile)));
                const roam::TileVertex tv = tess.tileVertex(tile, idx[i + j]);
                v[j] = tv.position;
                auto [it, inserted] = heights.emplace(packPoint(tv.position), tv.height);
                if (!inserted && it->second != tv.height)
                    ++height_mismatches;
            }
            ++listed[key_of(tile, v)];
            ++live;
        }
    }
    EXPECT_EQ(height_mismatches, 0) << "a vertex has different heights in different blocks";
    EXPECT_EQ(live, tess.triangleCount());
    EXPECT_TRUE(listed == expected)
        << "index lists: " << listed.size() << " triangles, mesh: " << expected.size();
}

} // namespace terrain::testing
