#pragma once

// The layout of every tile's vertex array, and what changed in it since a renderer last looked:
// the renderer's face of the tessellator, beside the index lists (tile_mesh.h).
//
// A tile's array is the (kTileCells + 1)^2 base grid first, row by row, then one segment per
// resident grain of a detail block of the tile (kGrainVertices[g] vertices), in the order they
// came. A segment keeps its place while its grain lives, so index lists never move; a grain that
// goes leaves a hole, reused by the next grain of its size.
//
// Owns: per tile its segments, holes, vertex count, version and changed ranges. Does not know
// the heights (the block pool and the terrain hold them) nor which block a chunk is; it names
// a segment's chunk only so that a reader can find the heights. Pure, single-threaded.

#include <terrain/roam/block_grains.h>
#include <terrain/roam/lattice.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::roam {

inline constexpr std::int32_t kTileBaseVertices = (kTileCells + 1) * (kTileCells + 1);

/// A tile vertex: lattice position (1/16 cell) and height in fine units (1/16 quantum).
struct TileVertex {
    LatticePoint position;
    std::int64_t height = 0;
    /// Lattice origin of the cell whose block holds it; (-1, -1) on the base grid. A vertex on a
    /// cell border is in both cells' blocks, with the same height.
    LatticePoint block_origin{-1, -1};
};

/// A run [begin, end) of a tile's vertex array.
struct VertexRange {
    std::uint32_t begin = 0;
    std::uint32_t end = 0;
};

/// A run of a tile's vertex array that holds one grain of one block, or a hole.
struct VertexSegment {
    std::int32_t offset = 0; ///< past the base grid
    std::int32_t chunk = -1; ///< the grain's chunk in the block pool; -1: a hole
    std::int32_t grain = 0;
};

class TileVertexArrays {
  public:
    /// Past this many ranges a tile's changes are "everything" (no renderer is taking them).
    static constexpr std::size_t kMaxRanges = 4096;

    /// `tiles` tiles, each with the base grid only, version 0, everything changed.
    void reset(std::size_t tiles);
    /// The tile's array is the base grid again (its segments and holes are forgotten).
    void clearTile(std::int32_t tile);

    /// A segment for grain g's `chunk`: a hole of that size, or a new one at the end. Bumps the
    /// version and marks the segment's vertices; returns the segment.
    std::int32_t attach(std::int32_t tile, int g, std::int32_t chunk);
    /// The segment becomes a hole (no index refers to it any more): bumps the version, marks
    /// nothing.
    void detach(std::int32_t tile, int g, std::int32_t segment);
    /// The segment's grain moved to another chunk (the pool compacted it): the same vertices.
    void rechunk(std::int32_t tile, std::int32_t segment, std::int32_t chunk) {
        segments_[gi(tile)][gi(segment)].chunk = chunk;
    }

    /// Vertices in the tile's array, holes included.
    std::int32_t vertexCount(std::int32_t tile) const {
        return kTileBaseVertices + extra_[gi(tile)];
    }
    /// Segments by offset.
    std::span<const VertexSegment> segments(std::int32_t tile) const { return segments_[gi(tile)]; }
    /// Index of the segment's first vertex in the tile's array.
    std::uint32_t firstVertex(std::int32_t tile, std::int32_t segment) const {
        return static_cast<std::uint32_t>(
            kTileBaseVertices + segments_[gi(tile)][gi(segment)].offset);
    }

    /// Bumped whenever the tile's vertex array (heights or segments) changes.
    std::uint32_t version(std::int32_t tile) const { return version_[gi(tile)]; }
    void bumpVersion(std::int32_t tile) { ++version_[gi(tile)]; }

    /// Marks [begin, end) changed (joined to the last range when it continues it).
    void mark(std::int32_t tile, std::uint32_t begin, std::uint32_t end);
    /// Everything changed (a reset): a renderer loads the tile whole.
    void markAll(std::int32_t tile);
    bool allChanged(std::int32_t tile) const { return all_[gi(tile)] != 0; }
    /// The ranges marked since take(), in the order marked (they may overlap).
    std::span<const VertexRange> changes(std::int32_t tile) const { return changes_[gi(tile)]; }
    /// A renderer took the changes.
    void take(std::int32_t tile);

    std::size_t memoryBytes() const;

  private:
    static std::size_t gi(std::int64_t v) { return static_cast<std::size_t>(v); }

    std::vector<std::vector<VertexSegment>> segments_;
    /// Per tile and grain: segments that are holes, free for a grain of that size.
    std::vector<std::array<std::vector<std::int32_t>, kGrains>> holes_;
    std::vector<std::int32_t> extra_; ///< per tile: vertices past the base grid
    std::vector<std::uint32_t> version_;
    std::vector<std::vector<VertexRange>> changes_; ///< per tile, since taken
    std::vector<std::uint8_t> all_;                 ///< per tile: everything changed
};

} // namespace terrain::roam
