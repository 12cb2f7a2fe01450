#pragma once

// Checks of a DrawnMesh (the frame thread's copy of a tessellator's tiles) against a tessellator.

#include <terrain/roam/drawn_mesh.h>
#include <terrain/roam/tessellator.h>
#include <terrain/roam/tile_vertex_builder.h>
#include <terrain/terrain.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

namespace terrain::testing {

inline bool sameBits(const roam::DrawVertex& a, const roam::DrawVertex& b) {
    return std::memcmp(&a, &b, sizeof(roam::DrawVertex)) == 0;
}

/// The first difference between the copy and the tessellator's tiles (visibility, vertex
/// versions, and the triangle list: slot by slot, the three vertices the copy's indices name in
/// its own array against those the tessellator's name in its array, as drawn from `terrain`),
/// or "". The copy's array holds only the vertices a triangle uses, at slots of its own: its
/// vertices no index names are not compared (nothing draws them). Without `normals`, positions
/// and heights only (a third of the cost).
inline std::string difference(
    const roam::DrawnMesh& copy,
    const roam::Tessellator& tess,
    const Terrain& terrain,
    bool normals = true) {
    if (copy.tileCount() != tess.tileCount())
        return "tile count";
    roam::TileVertexBuilder builder;
    builder.newFrame();
    std::vector<roam::DrawVertex> expected;
    for (std::int32_t t = 0; t < tess.tileCount(); ++t) {
        const std::string at = "tile " + std::to_string(t) + ": ";
        if (copy.tileVisible(t) != tess.tileVisible(t))
            return at + "visibility";
        const auto want = tess.tileMesh(t).indices();
        const auto got = copy.indices(t);
        if (want.size() != got.size())
            return at + "index count";
        if (copy.vertexVersion(t) != tess.tileVertexVersion(t))
            return at + "vertex version";
        expected.resize(static_cast<std::size_t>(tess.tileVertexCount(t)));
        if (normals)
            builder.build(tess, terrain, t, 0, expected);
        else
            builder.positions(tess, t, 0, expected);
        const auto vertices = copy.vertices(t);
        for (std::size_t i = 0; i < want.size(); ++i) {
            if (want[i] >= expected.size())
                return at + "a tessellator index past its vertices";
            if (got[i] >= vertices.size())
                return at + "index " + std::to_string(i) + " past the copy's " +
                       std::to_string(vertices.size()) + " vertices";
            const roam::DrawVertex& a = vertices[got[i]];
            const roam::DrawVertex& b = expected[want[i]];
            if (normals ? !sameBits(a, b) : a.x != b.x || a.y != b.y || a.z != b.z)
                return at + "index " + std::to_string(i) + " (slot " + std::to_string(got[i]) +
                       ", vertex " + std::to_string(want[i]) + " of " +
                       std::to_string(expected.size()) + "): (" + std::to_string(a.x) + ", " +
                       std::to_string(a.y) + ", " + std::to_string(a.z) + ") want (" +
                       std::to_string(b.x) + ", " + std::to_string(b.y) + ", " +
                       std::to_string(b.z) + ")";
        }
    }
    return "";
}

} // namespace terrain::testing
