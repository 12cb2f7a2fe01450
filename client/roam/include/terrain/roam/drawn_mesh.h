#pragma once

// The frame thread's copy of a tessellator's tiles, kept by MeshDeltas from another thread
// (delta_collector.h): per tile the index list and the vertex array ready to draw, and whether it
// is in view. What the deltas changed is kept for a renderer as the tessellator keeps it (index
// pages written, vertex ranges, whole rewrites) until it takes them, so a renderer uploads only
// what changed, whichever deltas it missed.
//
// Owns: the copies and their change marks. Applying a delta copies its contents (no
// tessellation, no terrain reads): the frame thread's whole cost of the hand-over. Pure,
// single-threaded (the frame thread's).

#include <terrain/roam/mesh_delta.h>
#include <terrain/roam/tile_mesh.h>
#include <terrain/roam/tile_vertex_arrays.h>
#include <terrain/roam/tile_vertex_builder.h>
#include <terrain/world_spec.h>

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace terrain::roam {

class DrawnMesh {
  public:
    /// Where the copy's vertices put x and y: lattice units, as the deltas carry them and our
    /// renderer's program takes them, or metres from the map's corner (x and y times
    /// metresPerLattice(), at the copy: what an engine outside takes).
    enum class Units { kLattice, kMetres };
    explicit DrawnMesh(Units units = Units::kLattice) : units_(units) {}

    /// Metres per lattice unit of a world: its grid spacing over kLatticePerCell.
    static double metresPerLattice(const WorldSpec& spec);
    Units units() const { return units_; }

    /// Brings the tiles to the delta's step. Refused (false, nothing changed): a delta not newer
    /// than the copy, one for another tile count that does not start the tiles over, or one
    /// that does not hold together (a page past its list, a run past its array or the delta's
    /// vertices, a tile past the count).
    bool apply(const MeshDelta& delta);

    /// The tessellation step the copy holds (0: none yet).
    std::uint64_t step() const { return step_; }
    std::int32_t tileCount() const { return static_cast<std::int32_t>(tiles_.size()); }
    /// The world the tiles are of, and its lowest and highest ground (metres, from the base
    /// grid as the tiles first came).
    const WorldSpec& spec() const { return spec_; }
    std::pair<float, float> heightRange() const { return height_range_; }
    bool tileVisible(std::int32_t tile) const { return tiles_[at(tile)].visible; }
    /// Three indices per slot into the tile's vertices; every slot is drawn.
    std::span<const std::uint32_t> indices(std::int32_t tile) const {
        return tiles_[at(tile)].indices;
    }
    std::uint32_t slotCount(std::int32_t tile) const {
        return static_cast<std::uint32_t>(tiles_[at(tile)].indices.size() / 3);
    }
    std::span<const DrawVertex> vertices(std::int32_t tile) const {
        return tiles_[at(tile)].vertices;
    }
    std::uint32_t vertexVersion(std::int32_t tile) const { return tiles_[at(tile)].version; }

    // what changed since takeChanges(tile), as TileMesh and TileVertexArrays report it
    bool indicesRewritten(std::int32_t tile) const { return tiles_[at(tile)].rewritten; }
    /// Pages (TileMesh::kSlotsPerPage slots) written, ascending; pages past the list's end may
    /// be listed (cut off since) and need no upload.
    std::span<const std::uint32_t> dirtyPages(std::int32_t tile) const {
        return tiles_[at(tile)].dirty_pages;
    }
    bool indicesDirty(std::int32_t tile) const {
        return tiles_[at(tile)].rewritten || !tiles_[at(tile)].dirty_pages.empty();
    }
    bool verticesAllChanged(std::int32_t tile) const { return tiles_[at(tile)].all_vertices; }
    /// Vertex ranges written (they may overlap).
    std::span<const VertexRange> vertexChanges(std::int32_t tile) const {
        return tiles_[at(tile)].vertex_changes;
    }
    void takeVertexChanges(std::int32_t tile);
    void takeIndexChanges(std::int32_t tile);
    void takeChanges(std::int32_t tile) {
        takeVertexChanges(tile);
        takeIndexChanges(tile);
    }

    /// Bytes held, capacity included.
    std::size_t memoryBytes() const;

  private:
    static std::size_t at(std::int64_t v) { return static_cast<std::size_t>(v); }
    struct TileCopy {
        std::vector<std::uint32_t> indices;
        std::vector<DrawVertex> vertices;
        std::uint32_t version = 0;
        bool visible = false;
        // changes since taken
        bool rewritten = true;
        bool all_vertices = true;
        std::vector<std::uint32_t> dirty_pages;
        std::vector<std::uint8_t> page_flags;
        std::vector<VertexRange> vertex_changes;
    };
    /// Marks a page written (once).
    static void markPage(TileCopy& copy, std::uint32_t page);
    static bool wellFormed(const MeshDelta& delta);
    template <typename T> static void fitCapacity(std::vector<T>& v);

    Units units_ = Units::kLattice;
    std::vector<TileCopy> tiles_;
    std::uint64_t step_ = 0;
    WorldSpec spec_{};
    std::pair<float, float> height_range_{0.0f, 0.0f};
};

} // namespace terrain::roam
