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

/// The first difference between the copy and the tessellator's tiles (visibility, index lists,
/// vertex versions, and every vertex an index refers to, as drawn from `terrain`), or "".
/// Vertices no index refers to (a hole a grain left) are not compared: nothing draws them, and
/// nothing marks them changed. Without `normals`, positions and heights only (a third of the
/// cost).
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
    std::vector<std::uint8_t> referenced;
    for (std::int32_t t = 0; t < tess.tileCount(); ++t) {
        const std::string at = "tile " + std::to_string(t) + ": ";
        if (copy.tileVisible(t) != tess.tileVisible(t))
            return at + "visibility";
        const auto want = tess.tileMesh(t).indices();
        const auto got = copy.indices(t);
        if (want.size() != got.size() || !std::equal(want.begin(), want.end(), got.begin()))
            return at + "index list";
        if (copy.vertexVersion(t) != tess.tileVertexVersion(t))
            return at + "vertex version";
        expected.resize(static_cast<std::size_t>(tess.tileVertexCount(t)));
        if (normals)
            builder.build(tess, terrain, t, 0, expected);
        else
            builder.positions(tess, t, 0, expected);
        const auto vertices = copy.vertices(t);
        if (vertices.size() != expected.size())
            return at + "vertex count";
        referenced.assign(expected.size(), 0);
        for (const std::uint32_t index : want)
            if (index >= expected.size())
                return at + "an index past the vertices";
            else
                referenced[index] = 1;
        for (std::size_t i = 0; i < expected.size(); ++i)
            if (referenced[i] != 0 &&
                (normals ? !sameBits(vertices[i], expected[i])
                         : vertices[i].x != expected[i].x || vertices[i].y != expected[i].y ||
                               vertices[i].z != expected[i].z))
                return at + "vertex " + std::to_string(i) + " of " +
                       std::to_string(expected.size()) + " (" + std::to_string(vertices[i].x) +
                       ", " + std::to_string(vertices[i].y) + ", " + std::to_string(vertices[i].z) +
                       ": want " + std::to_string(expected[i].x) + ", " +
                       std::to_string(expected[i].y) + ", " + std::to_string(expected[i].z) + ")";
    }
    return "";
}

} // namespace terrain::testing
