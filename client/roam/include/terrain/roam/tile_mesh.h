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
// allocates nothing. Pure: no GL.

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
    /// Gives back the memory of a list that has shrunk to a quarter of its peak (or less): for
    /// tiles the view has left, as it allocates.
    void shrink();

    /// Three indices per slot; a free slot (only between fillHoles() calls) is (0, 0, 0).
    std::span<const std::uint32_t> indices() const { return indices_; }
    std::uint32_t slotCount() const { return static_cast<std::uint32_t>(keys_of_slots_.size()); }
    std::uint32_t triangleCount() const { return live_; }

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
               free_slots_.capacity() * sizeof(std::uint32_t) +
               table_keys_.capacity() * sizeof(std::uint32_t) +
               table_slots_.capacity() * sizeof(std::uint32_t);
    }

    TileCounters& counters() { return counters_; }
    const TileCounters& counters() const { return counters_; }

  private:
    static constexpr std::uint32_t kEmpty = 0xffffffffu;
    static constexpr std::uint32_t kNoKey = 0xffffffffu;

    std::uint32_t find(std::uint32_t key) const;
    void insertKey(std::uint32_t key, std::uint32_t slot);
    void eraseKey(std::uint32_t key);
    void growTable();
    void resizeTable(std::size_t size);
    void write(std::uint32_t slot, const Indices& indices);
    static std::size_t hashKey(std::uint32_t key);

    std::vector<std::uint32_t> indices_;
    std::vector<std::uint32_t> keys_of_slots_; ///< kNoKey for a free slot
    std::vector<std::uint32_t> free_slots_;
    // open addressing, linear probing, backward-shift deletion; at most 70 % full
    std::vector<std::uint32_t> table_keys_;
    std::vector<std::uint32_t> table_slots_;
    std::uint32_t table_used_ = 0;
    std::uint32_t live_ = 0;
    std::vector<std::uint32_t> dirty_pages_;
    std::vector<std::uint8_t> page_dirty_;
    bool cleared_ = false;
    TileCounters counters_;
};

} // namespace terrain::roam
