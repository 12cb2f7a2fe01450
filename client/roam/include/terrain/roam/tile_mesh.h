#pragma once

// One tile's output: a triangle list of indices into the tile's vertex array, kept in stable
// slots so that a split or merge rewrites three or six indices, not the whole list.
//
// A split replaces one triangle by two: the first child takes the parent's slot, the second the
// most recently freed slot or a new one at the end. Freed slots hold a degenerate triangle
// (0, 0, 0) until reused, so the list can be drawn as is; when more than a quarter of the slots
// are free the list is compacted (one full rewrite). Every write is counted, and the range of
// slots written since the renderer last took the tile is kept, so an index buffer is uploaded
// only where it changed (glBufferSubData over that range).
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

    /// Drops every triangle (a full rewrite follows).
    void clear();
    void add(std::uint64_t key, const Indices& indices);
    /// Frees the triangle's slot; false if the tile does not hold it.
    bool remove(std::uint64_t key);
    bool contains(std::uint64_t key) const { return find(key) != kEmpty; }
    /// Rewrites the list without free slots when more than a quarter are free.
    void compactIfSparse();

    /// Three indices per slot; free slots are (0, 0, 0).
    std::span<const std::uint32_t> indices() const { return indices_; }
    std::uint32_t slotCount() const { return static_cast<std::uint32_t>(keys_of_slots_.size()); }
    std::uint32_t triangleCount() const { return live_; }

    /// True once anything was written since takeChanges(); [first, last] is the slot range.
    bool dirty() const { return dirty_first_ <= dirty_last_; }
    std::uint32_t dirtyFirstSlot() const { return dirty_first_; }
    std::uint32_t dirtyLastSlot() const { return dirty_last_; }
    /// For the renderer, after uploading: forgets the changed range.
    void takeChanges();

    std::size_t memoryBytes() const {
        return indices_.capacity() * sizeof(std::uint32_t) +
               keys_of_slots_.capacity() * sizeof(std::uint64_t) +
               free_slots_.capacity() * sizeof(std::uint32_t) +
               table_keys_.capacity() * sizeof(std::uint64_t) +
               table_slots_.capacity() * sizeof(std::uint32_t);
    }

    TileCounters& counters() { return counters_; }
    const TileCounters& counters() const { return counters_; }

  private:
    static constexpr std::uint32_t kEmpty = 0xffffffffu;
    static constexpr std::uint64_t kNoKey = ~std::uint64_t{0};

    std::uint32_t find(std::uint64_t key) const;
    void insertKey(std::uint64_t key, std::uint32_t slot);
    void eraseKey(std::uint64_t key);
    void growTable();
    void write(std::uint32_t slot, const Indices& indices);
    static std::size_t hashKey(std::uint64_t key);

    std::vector<std::uint32_t> indices_;
    std::vector<std::uint64_t> keys_of_slots_; ///< kNoKey for a free slot
    std::vector<std::uint32_t> free_slots_;
    // open addressing, linear probing, backward-shift deletion
    std::vector<std::uint64_t> table_keys_;
    std::vector<std::uint32_t> table_slots_;
    std::uint32_t table_used_ = 0;
    std::uint32_t live_ = 0;
    std::uint32_t dirty_first_ = 1;
    std::uint32_t dirty_last_ = 0;
    TileCounters counters_;
};

} // namespace terrain::roam
