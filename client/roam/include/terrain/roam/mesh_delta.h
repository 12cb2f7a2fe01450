#pragma once

// What a tessellator's tiles changed, as a reader on another thread takes it: per tile, the index
// pages and vertex runs written since the reader last took a delta, with their contents (vertices
// ready to draw, normals included), and every tile's visibility. A tile's vertex array here is
// the reader's: only the vertices a triangle uses, at slots the collector gives them (the index
// pages are in slots), not the tessellator's array with a place for every vertex it could draw.
// Written on the tessellator's thread (DeltaCollector), applied on the frame thread (DrawnMesh).
// Plain data: its vectors keep their capacity when cleared, so a delta reused step after step
// allocates nothing in a steady state.

#include <terrain/roam/tile_mesh.h>
#include <terrain/roam/tile_vertex_builder.h>
#include <terrain/world_spec.h>

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace terrain::roam {

struct MeshDelta {
    /// Indices per page: kSlotsPerPage triangles; a page cut by the list's end is padded with 0.
    static constexpr std::uint32_t kPageIndices = TileMesh::kSlotsPerPage * 3;

    /// A tile with changes; its pages and runs are [first_page, first_page + page_count) of
    /// `pages` and [first_run, first_run + run_count) of `runs`.
    struct Tile {
        std::int32_t tile = 0;
        std::uint32_t slot_count = 0;     ///< the index list's slots after the delta
        std::uint32_t vertex_count = 0;   ///< the vertex array's size after the delta
        std::uint32_t vertex_version = 0; ///< Tessellator::tileVertexVersion after the delta
        bool indices_rewritten = false;   ///< every page of the list is here (it was rebuilt)
        bool vertices_reset = false;      ///< every vertex is here (the array may have shrunk)
        std::uint32_t first_page = 0;
        std::uint32_t page_count = 0;
        std::uint32_t first_run = 0;
        std::uint32_t run_count = 0;
    };
    /// Vertices [begin, end) of a tile's array; their values are vertices[at, at + end - begin).
    struct Run {
        std::uint32_t begin = 0;
        std::uint32_t end = 0;
        std::uint64_t at = 0;
    };

    /// Tessellation steps since the collector began: the mesh state this delta brings a reader to.
    std::uint64_t step = 0;
    /// A new set of tiles (a new world, or the first delta): the reader starts every tile over.
    bool new_tiles = false;
    std::int32_t tile_count = 0;
    WorldSpec spec{}; ///< the world the tiles are of
    /// With new_tiles: the world's lowest and highest ground (metres), the colours' scale.
    std::pair<float, float> height_range{0.0f, 0.0f};
    std::vector<std::uint8_t> visible; ///< per tile, 0 or 1
    /// Per tile, Tessellator::tileVertexVersion: it also moves with nothing to copy (a grain
    /// gone, a block evicted).
    std::vector<std::uint32_t> versions;
    std::vector<Tile> tiles;                 ///< tiles with changes, ascending
    std::vector<std::uint32_t> pages;        ///< page numbers, per tile ascending
    std::vector<std::uint32_t> page_indices; ///< kPageIndices per entry of `pages`
    std::vector<Run> runs;                   ///< per tile ascending, disjoint
    std::vector<DrawVertex> vertices;

    /// Empties it, keeping the capacity.
    void clear();
    /// Bytes of contents: what handing it over copies (vertices and index pages).
    std::uint64_t payloadBytes() const {
        return vertices.size() * sizeof(DrawVertex) + page_indices.size() * sizeof(std::uint32_t);
    }
    /// Bytes held, capacity included.
    std::size_t memoryBytes() const;
};

} // namespace terrain::roam
