#pragma once

// Where a tile's drawn vertices sit in the arrays a reader holds (the frame's copy, the GPU's
// buffers): each vertex of the tessellator's array that a triangle uses has a slot of the
// reader's array, and a slot that no vertex holds waits for the next one (TileMesh keeps them
// as its triangles come and go). The tessellator's
// array keeps a place for every vertex it could draw (about eight for each one drawn), so the
// map from its vertices to slots is kept in pages of kPage vertices, a page only where one is
// held: a few bytes per drawn vertex, not four per place.
//
// Owns: the two directions of the map and the free slots. Pure, single-threaded.

#include <cstdint>
#include <vector>

namespace terrain::roam {

class VertexSlots {
  public:
    static constexpr std::uint32_t kNone = 0xffffffffu;
    static constexpr std::uint32_t kPage = 64;

    /// The vertex's slot, or kNone.
    std::uint32_t slotOf(std::uint32_t vertex) const {
        const std::uint32_t page = vertex / kPage;
        if (page >= page_of_.size() || page_of_[page] == kNone)
            return kNone;
        return entries_[std::size_t{page_of_[page]} * kPage + vertex % kPage];
    }
    /// The vertex the slot holds, or kNone (a free slot).
    std::uint32_t vertexOf(std::uint32_t slot) const { return vertex_of_[slot]; }
    /// Slots in the reader's array (held and free).
    std::uint32_t slotCount() const { return static_cast<std::uint32_t>(vertex_of_.size()); }
    std::uint32_t freeCount() const { return static_cast<std::uint32_t>(free_.size()); }
    /// Pages of the map that no vertex uses now (kept for the next).
    std::uint32_t freePages() const { return static_cast<std::uint32_t>(free_pages_.size()); }

    /// A slot for a vertex that has none: a free one, else a new one at the end.
    std::uint32_t take(std::uint32_t vertex);
    /// The vertex gives its slot back.
    void release(std::uint32_t vertex);
    /// No vertex holds a slot and the reader's array is empty (the memory is kept).
    void clear();
    /// Whether shrink() after the vertices are taken again in order would give back much: over
    /// half the memory held is not in use.
    bool hasSlack() const;
    /// Gives back the memory the slots and pages do not use now (a clear() and the vertices
    /// taken again in order leave no free page or slot).
    void shrink();

    std::size_t memoryBytes() const;

  private:
    void set(std::uint32_t vertex, std::uint32_t slot);

    std::vector<std::uint32_t> page_of_; ///< per kPage vertices: its page, or kNone
    std::vector<std::uint32_t> entries_; ///< kPage slots (or kNone) per page
    std::vector<std::uint16_t> held_;    ///< per page: vertices with a slot
    std::vector<std::uint32_t> free_pages_;
    std::vector<std::uint32_t> vertex_of_; ///< per slot
    std::vector<std::uint32_t> free_;      ///< free slots
};

} // namespace terrain::roam
