#pragma once

// One tile's output: a triangle list of indices into the tile's vertex array, kept in stable
// slots so that a split or merge rewrites three or six indices, not the whole list.
//
// A split replaces one triangle by two: the first child takes the parent's slot, the second the
// most recently freed slot or a new one at the end. A slot freed during a frame holds a
// degenerate triangle (0, 0, 0) until reused; at the end of the frame fillHoles() moves the last
// triangles into the remaining holes, one slot write each, so the list the renderer sees is
// dense. Every write is counted, and the pages of kSlotsPerPage slots written since the renderer
// last took the tile are listed, so an index buffer is uploaded only where it changed
// (glBufferSubData per run of dirty pages).
// Allocation happens only when the list or its key table outgrows its capacity; a steady state
// allocates nothing. Memory is a few bytes above the 24 the indices need per triangle (the
// list, and the same list in slots: drawnIndices()): lists grow by a quarter, not double, and
// the key table (one 8-byte entry per triangle, any size, not a power of two) is kept between
// half and three quarters full. Pure: no GL.

#include <terrain/roam/vertex_slots.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::roam {

struct TileCounters {
    std::uint64_t splits = 0;
    std::uint64_t merges = 0;
    std::uint64_t forced_splits = 0;
    std::uint64_t index_bytes_written = 0;
    std::uint64_t rebuilds = 0; ///< full rewrites (tessellation rebuilt, compaction, new blocks)
};

class TileMesh {
  public:
    using Indices = std::array<std::uint32_t, 3>;
    static constexpr std::uint32_t kIndexBytesPerTriangle = 3 * sizeof(std::uint32_t);
    static constexpr std::uint32_t kSlotsPerPage = 32;

    /// Drops every triangle (a full rewrite follows).
    void clear();
    /// Keys name triangles within the tile (tileTriangleKey); 0xffffffff is not a key.
    void add(std::uint32_t key, const Indices& indices);
    /// Frees the triangle's slot; false if the tile does not hold it.
    bool remove(std::uint32_t key);
    bool contains(std::uint32_t key) const { return find(key) != kEmpty; }
    /// Moves the last triangles into the free slots and shortens the list (end of a frame).
    void fillHoles();
    /// Whether shrink() would give memory back: the list uses two thirds of its capacity or
    /// less, the key table is under a quarter full (beyond a few hundred slots), or the slots
    /// hold twice what they use.
    bool hasSlack() const { return listHasSlack() || tableHasSlack() || slots_.hasSlack(); }
    /// Gives that memory back. Allocates: the tessellator calls it for a list that has had
    /// slack for a while (one that merely breathes is not shrunk and regrown).
    void shrink();

    /// Three indices per slot; a free slot (only between fillHoles() calls) is (0, 0, 0).
    std::span<const std::uint32_t> indices() const { return indices_; }
    std::uint32_t slotCount() const { return static_cast<std::uint32_t>(keys_of_slots_.size()); }
    std::uint32_t triangleCount() const { return live_; }
    /// Whether a triangle of the list uses vertex `index` (of the tile's array): most of a
    /// tile's array is not (the base grid a coarse tile skips, the grains' points a block's
    /// triangles do not reach), and nothing needs what no triangle draws.
    bool referenced(std::uint32_t index) const { return index < uses_.size() && uses_[index] != 0; }

    // The list as a reader holds it (delta_collector.h): the same triangles, their indices into
    // an array of the vertices the list uses only, each at a slot it keeps while used
    // (VertexSlots). A reader's copy and the GPU's buffers are then sized to what is drawn, not
    // to every vertex the tessellator could draw (about eight for each one drawn).
    /// Three slot indices per list slot (the same triangles as indices()).
    std::span<const std::uint32_t> drawnIndices() const { return drawn_; }
    /// Slots of the reader's array (held and free).
    std::uint32_t drawnVertexCount() const { return slots_.slotCount(); }
    /// The vertex (of the tile's array) a slot holds, or VertexSlots::kNone.
    std::uint32_t vertexOfSlot(std::uint32_t slot) const { return slots_.vertexOf(slot); }
    std::uint32_t slotOfVertex(std::uint32_t vertex) const { return slots_.slotOf(vertex); }
    /// Slots given a vertex since takeChanges() (a slot may be listed more than once); when
    /// more than it keeps (nobody took the changes for long), any slot may have been.
    std::span<const std::uint32_t> takenSlots() const { return taken_slots_; }
    bool manyTakenSlots() const { return taken_overflow_; }
    /// Since takeChanges(), every used vertex was given a slot afresh (more than half the
    /// slots were free: the array shrinks) or the list was cleared: a reader takes them all.
    bool slotsRelaid() const { return relaid_ || cleared_; }

    /// True once anything was written since takeChanges().
    bool dirty() const { return !dirty_pages_.empty() || cleared_; }
    /// The whole list was rewritten (rebuild): upload it all, and resize the buffer.
    bool rewritten() const { return cleared_; }
    /// Pages (of kSlotsPerPage slots) written since takeChanges(), in the order first written;
    /// pages beyond slotCount() were cut off by fillHoles() and need no upload.
    std::span<const std::uint32_t> dirtyPages() const { return dirty_pages_; }
    /// Bytes a renderer uploads for the dirty pages (all of the list after a rewrite).
    std::uint64_t dirtyUploadBytes() const;
    /// For the renderer, after uploading: forgets the changes.
    void takeChanges();

    std::size_t memoryBytes() const {
        return indices_.capacity() * sizeof(std::uint32_t) +
               dirty_pages_.capacity() * sizeof(std::uint32_t) + page_dirty_.capacity() +
               keys_of_slots_.capacity() * sizeof(std::uint32_t) +
               free_slots_.capacity() * sizeof(std::uint32_t) + uses_.capacity() +
               drawn_.capacity() * sizeof(std::uint32_t) + slots_.memoryBytes() +
               taken_slots_.capacity() * sizeof(std::uint32_t) +
               table_.capacity() * sizeof(std::uint64_t);
    }

    TileCounters& counters() { return counters_; }
    const TileCounters& counters() const { return counters_; }

  private:
    static constexpr std::uint32_t kEmpty = 0xffffffffu;
    static constexpr std::uint32_t kNoKey = 0xffffffffu;

    // a table entry: the key in the high half, its slot in the low half
    static constexpr std::uint64_t kEmptyEntry = std::uint64_t{kNoKey} << 32;
    static std::uint32_t keyOf(std::uint64_t entry) {
        return static_cast<std::uint32_t>(entry >> 32);
    }
    static std::uint64_t entryOf(std::uint32_t key, std::uint32_t slot) {
        return std::uint64_t{key} << 32 | slot;
    }
    /// The key's home position in a table of `size` entries (hash scaled, not masked).
    static std::size_t home(std::uint32_t key, std::size_t size);
    /// Position of the key's entry in table_; table_.size() if absent.
    std::size_t locate(std::uint32_t key) const;
    std::uint32_t find(std::uint32_t key) const;
    bool listHasSlack() const;
    bool tableHasSlack() const;
    void insertKey(std::uint32_t key, std::uint32_t slot);
    /// Empties table_[at] (backward shift).
    void eraseAt(std::size_t at);
    void resizeTable(std::size_t size);
    void appendSlot();
    /// Writes the list slot's indices and their slots.
    void write(std::uint32_t slot, const Indices& indices, const Indices& drawn);

    /// Counts the triangle on (by 1) or off (by -1) its vertices; a vertex coming into use takes
    /// a slot, one going out of use gives its slot back. Counting on: returns the slots.
    Indices use(const Indices& indices, int by);
    /// Slots taken kept before "any slot may have been" (manyTakenSlots).
    std::size_t takenLimit() const { return slots_.slotCount() / 4 + 256; }
    /// Every used vertex a slot afresh, in the order of the tile's array, and the drawn list
    /// written again (more than half the slots free).
    void relaySlots();
    std::vector<std::uint32_t> indices_;
    /// Per vertex of the tile's array: the triangles that use it (at most 8 in a 4-8 mesh).
    std::vector<std::uint8_t> uses_;
    std::vector<std::uint32_t> drawn_; ///< per list slot, three slots of the reader's array
    VertexSlots slots_;
    std::vector<std::uint32_t> taken_slots_;
    bool taken_overflow_ = false;
    bool relaid_ = false;
    std::vector<std::uint32_t> keys_of_slots_; ///< kNoKey for a free slot
    std::vector<std::uint32_t> free_slots_;
    // open addressing, linear probing, backward-shift deletion; at most 3/4 full
    std::vector<std::uint64_t> table_;
    std::uint32_t table_used_ = 0;
    std::uint32_t live_ = 0;
    std::vector<std::uint32_t> dirty_pages_;
    std::vector<std::uint8_t> page_dirty_;
    bool cleared_ = false;
    TileCounters counters_;
};

} // namespace terrain::roam
