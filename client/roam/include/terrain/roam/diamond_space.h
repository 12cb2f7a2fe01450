#pragma once

// The tessellator's diamonds by id (diamond_id.h) and what each one carries: a state byte
// (split, candidate, watched) for every id, and packed error bounds (packed_bounds.h) for the
// grid's and the blocks' diamonds.
//
// Owns: the per-id arrays, sized by the grid, by the detail records (one centre each) and by
// each grain's chunk count (the block pool decides that count; this follows it).
// Does not know: where a diamond lies (lattice points), which block a chunk belongs to
// (BlockPool), the candidate heap, the terrain. A detail cell's centre stores no bounds: they
// come from the records of its 3 x 3 cells, which the tessellator reads.
// Pure, single-threaded; the accessors are inline because split/merge calls them per diamond.

#include <terrain/assert.h>
#include <terrain/roam/block_grains.h>
#include <terrain/roam/diamond_id.h>
#include <terrain/roam/packed_bounds.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrain::roam {

class DiamondSpace {
  public:
    /// State bits.
    static constexpr std::uint8_t kActive = 1;         ///< split
    static constexpr std::uint8_t kSplitCandidate = 2; ///< not split, both parents split
    static constexpr std::uint8_t kMergeCandidate = 4; ///< split, no split child
    static constexpr std::uint8_t kWatched = 8;        ///< wants a split but is culled
    static_assert(kPooledRanges == kGrains);

    /// A new world: `grid_count` grid diamonds (state clear, bounds {0, 0, 0}), no centres, no
    /// chunks; bounds packed with `codec`.
    void reset(std::uint32_t grid_count, const BoundsCodec& codec);
    /// Forgets every chunk (states and bounds, memory included); the grid and centres stay.
    void dropChunks();
    /// Every state byte to 0.
    void clearStates();

    /// Sizes the centres' states for `records` (new ones clear), to spare an eighth.
    void resizeCentres(std::size_t records);
    /// Sizes grain g's arrays for `chunks` (new chunks' states clear; growing by an eighth, not
    /// a doubling: the pool may be most of the memory).
    void resizeChunks(int g, std::size_t chunks);
    /// As resizeChunks, and gives back the capacity past a quarter to spare (after a trim).
    void fitChunks(int g, std::size_t chunks);

    std::uint32_t gridCount() const { return grid_count_; }
    std::size_t centreCount() const { return centre_state_.size(); }
    std::size_t chunkCount(int g) const {
        return chunks_[gi(g)].state.size() / static_cast<std::size_t>(kGrainDiamonds[gi(g)]);
    }
    /// Ids below kPooledIds in use (grid and centres), and pooled ids per range: the sizes
    /// CandidateHeap::resizeIds wants.
    std::size_t eagerCount() const { return grid_count_ + centre_state_.size(); }
    std::array<std::size_t, kGrains> pooledCounts() const {
        return {chunks_[0].state.size(), chunks_[1].state.size(), chunks_[2].state.size()};
    }

    // ids
    bool isGrid(DiamondId id) const { return id < grid_count_; }
    bool isCentre(DiamondId id) const { return id >= grid_count_ && id < kPooledIds; }
    DiamondId centreId(std::int32_t record) const {
        return grid_count_ + static_cast<DiamondId>(record);
    }
    std::int32_t recordOfCentre(DiamondId id) const {
        return static_cast<std::int32_t>(id - grid_count_);
    }
    static int grainOfId(DiamondId id) { return rangeOf(id); }
    static std::int32_t chunkOfId(DiamondId id, int g) {
        return static_cast<std::int32_t>(
            pooledSlot(id, g) / static_cast<std::size_t>(kGrainDiamonds[gi(g)]));
    }
    /// Slot of a pooled id within its chunk (block_grains.h's diamond slots).
    static std::uint32_t slotOfId(DiamondId id, int g) {
        return static_cast<std::uint32_t>(
            pooledSlot(id, g) % static_cast<std::size_t>(kGrainDiamonds[gi(g)]));
    }
    static DiamondId pooledId(int g, std::int32_t chunk, std::uint32_t slot) {
        return pooledIdAt(
            g, static_cast<std::size_t>(chunk) * static_cast<std::size_t>(kGrainDiamonds[gi(g)]) +
                   slot);
    }

    // state
    std::uint8_t& state(DiamondId id) {
        if (id < grid_count_)
            return grid_state_[id];
        if (id < kPooledIds)
            return centre_state_[id - grid_count_];
        const int g = grainOfId(id);
        return chunks_[gi(g)].state[pooledSlot(id, g)];
    }
    std::uint8_t state(DiamondId id) const { return const_cast<DiamondSpace*>(this)->state(id); }
    bool active(DiamondId id) const { return id != kNoDiamond && (state(id) & kActive) != 0; }

    // stored bounds (grid and pooled ids; not centres)
    const BoundsCodec& codec() const { return codec_; }
    DiamondBounds storedBounds(DiamondId id) const { return codec_.unpack(packed(id)); }
    /// Stores `b` packed; whether the stored value changed.
    bool storeBounds(DiamondId id, const DiamondBounds& b) {
        const PackedBounds p = codec_.pack(b);
        PackedBounds& stored = packed(id);
        const bool changed = stored != p;
        stored = p;
        return changed;
    }

    // chunks
    /// Clears the states of grain g's `chunk` (a chunk made or released).
    void clearChunk(int g, std::int32_t chunk);
    /// Some diamond of the chunk is split or a candidate: the chunk is referenced.
    bool chunkReferenced(int g, std::int32_t chunk) const;
    /// Copies chunk `from`'s states and bounds to `to` and clears `from`'s states (a compaction).
    void moveChunk(int g, std::int32_t from, std::int32_t to);

    struct Memory {
        std::size_t grid = 0; ///< the grid's bounds and states, the centres' states
        std::array<std::size_t, kGrains> chunks{};
    };
    Memory memory() const;

  private:
    static std::size_t gi(int g) { return static_cast<std::size_t>(g); }
    PackedBounds& packed(DiamondId id) {
        TERRAIN_ASSERT(!isCentre(id));
        if (id < grid_count_)
            return grid_bounds_[id];
        const int g = grainOfId(id);
        return chunks_[gi(g)].bounds[pooledSlot(id, g)];
    }
    PackedBounds packed(DiamondId id) const { return const_cast<DiamondSpace*>(this)->packed(id); }

    struct Chunks {
        std::vector<PackedBounds> bounds; ///< per diamond slot of every chunk
        std::vector<std::uint8_t> state;  ///< per diamond slot
    };
    BoundsCodec codec_;
    std::uint32_t grid_count_ = 0;
    std::vector<PackedBounds> grid_bounds_;
    std::vector<std::uint8_t> grid_state_;
    std::vector<std::uint8_t> centre_state_; ///< per record (records come and go with ops)
    std::array<Chunks, kGrains> chunks_;
};

} // namespace terrain::roam
