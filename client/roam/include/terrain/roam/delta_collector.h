#pragma once

// The tessellator's side of the hand-over to another thread: takes what the tiles changed in each
// step (the index pages and vertex ranges a renderer would take) and writes MeshDeltas with their
// current contents. A delta that the reader never took is superseded by the next one, which
// covers what it did too: so everything changed since the last delta known to be taken is
// pending, and every delta written carries all of it. A reader that applies any subsequence of the
// deltas, each newer than the last it applied, holds the tessellator's tiles as they were at the
// step of the last.
//
// The reader's vertex arrays hold only the vertices a triangle uses, at the slots TileMesh gives
// them (its drawn list): the tessellator's array keeps a place for every vertex it could draw
// (the 65 x 65 base grid, every point of every resident detail grain), about eight for each one
// drawn. So the reader's copy, the GPU's buffers and the deltas are sized to what is drawn.
//
// Owns: per tile the pending coverage (index pages, slots, whether the list or array is
// whole) and vertex builders (one per group of tiles written at once). Takes the tessellator's
// changes (so it is the tessellator's only reader: no renderer syncs from that tessellator).
// Pure, single-threaded: the thread that updates the tessellator calls it.

#include <terrain/roam/mesh_delta.h>
#include <terrain/roam/tessellator.h>
#include <terrain/roam/tile_vertex_builder.h>
#include <terrain/task_runner.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <utility>
#include <vector>

namespace terrain::roam {

class DeltaCollector {
  public:
    /// The reader took the last delta written: what it covered is no longer pending. Call before
    /// the next collect().
    void delivered();
    /// Takes the tessellator's changes since the last call into the pending coverage and writes
    /// everything pending into `out` (cleared first), with `terrain` (the surface `tess` reads)
    /// for the normals.
    void collect(Tessellator& tess, const Terrain& terrain, MeshDelta& out);
    /// Steps collected so far (the step of the last delta written).
    std::uint64_t step() const { return step_; }
    /// The vertices and index pages are written on `runner` from now on (not owned; null:
    /// serially). The bytes are the same at any thread count: each tile's contents go to the
    /// places the serial layout gave them.
    void setTaskRunner(TaskRunner* runner) { runner_ = runner; }

    /// Slots in the readers' arrays, and places in the tessellator's arrays (what the slots
    /// save: a reader holds the first count of vertices instead of the second).
    static std::uint64_t slotCount(const Tessellator& tess);
    static std::uint64_t tessellatorVertexCount(const Tessellator& tess);
    std::size_t memoryBytes() const;
    /// Lowest and highest ground of the world (metres, its samples): the colours' scale a
    /// delta that starts the tiles over carries.
    static std::pair<float, float> heightRange(const Terrain& terrain);

  private:
    struct Pending {
        std::vector<std::uint8_t> slot_flags; ///< per slot: in `slots` (its value is pending)
        std::vector<std::uint32_t> slots;
        std::vector<std::uint32_t> pages;
        std::vector<std::uint8_t> page_flags; ///< per page: in `pages`
        bool rewritten = false;
        bool all_vertices = false;
    };
    struct Group {
        TileVertexBuilder builder;
        std::vector<std::uint32_t> vertices; ///< a run's vertices, slot by slot
    };

    static void markSlot(Pending& p, std::uint32_t slot);
    void takeChanges(Tessellator& tess, const WorldSpec& spec);
    /// The tile's entry, pages and runs (where their contents go), appended to `out`.
    void layout(const Tessellator& tess, std::int32_t t, MeshDelta& out);
    /// The contents of the tile's pages and runs, at the places layout() gave them.
    static void fill(
        const Tessellator& tess,
        const Terrain& terrain,
        const MeshDelta::Tile& entry,
        Group& group,
        MeshDelta& out);

    std::vector<Pending> pending_;
    std::vector<std::int32_t> pending_tiles_; ///< tiles with pending changes, unordered
    std::vector<std::uint8_t> tile_listed_;
    bool new_tiles_ = true;
    WorldSpec spec_{};
    std::uint64_t step_ = 0;
    TaskRunner* runner_ = nullptr;
    std::vector<Group> groups_; ///< one per group of tiles
    std::vector<std::size_t> group_ends_;
};

} // namespace terrain::roam
