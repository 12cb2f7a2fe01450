#pragma once

// The resident detail blocks' grains (block_grains.h) as chunks, and the rules that keep the
// pool within its means: which block goes when the pool needs a slot (clock order), which idle
// blocks and grains go anyway (a sweep), and the compaction of the finer grains' arrays once a
// battle's peak has passed (trim).
//
// Owns: per chunk its block, its last use (an epoch), its segment in its tile's vertex array
// and its vertex heights; per block its chunk of each grain; the free chunks; the clock and
// sweep hands. Reads: DetailBlocks' slots (which are in use, a block's record) and DiamondSpace's
// states (a block is referenced while its centre is split or any diamond of its chunks has a
// state). Does not touch: diamond states or bounds, tiles, the candidate heap, the terrain. What
// must follow a release or a move elsewhere is its owner's to do: evictionVictim and sweepIdle
// say what to release and the owner releases it; trim tells a Mover each chunk it moves.
// Pure, single-threaded.

#include <terrain/roam/block_grains.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/diamond_space.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace terrain::roam {

class BlockPool {
  public:
    using Chunks = std::array<std::int32_t, kGrains>; ///< per grain, a chunk or -1

    /// No block resident; memory given back. The hands and the moved count stay.
    void clear();
    /// The eviction clock starts again from slot 0 (a new world).
    void restartClock() { clock_hand_ = 0; }
    /// Sizes the per-block arrays for `blocks` slots (grain 0's chunk of a block is the block
    /// itself, so grain 0's per-chunk arrays too).
    void resizeBlocks(std::size_t blocks);

    std::size_t chunkCount(int g) const { return grains_[gi(g)].block.size(); }
    const Chunks& chunksOf(std::int32_t block) const { return chunks_[gi(block)]; }
    std::int32_t chunkOf(std::int32_t block, int g) const { return chunks_[gi(block)][gi(g)]; }
    /// The block a chunk holds a grain of; -1 if the chunk is free.
    std::int32_t blockOf(int g, std::int32_t chunk) const {
        return grains_[gi(g)].block[gi(chunk)];
    }

    // per chunk data the tessellator's other parts fill and read
    /// The chunk's segment in its tile's vertex array (-1: none; the tile emitter's).
    std::int32_t& segment(int g, std::int32_t chunk) { return grains_[gi(g)].segment[gi(chunk)]; }
    std::int32_t segment(int g, std::int32_t chunk) const {
        return grains_[gi(g)].segment[gi(chunk)];
    }
    /// The chunk's lowest vertex height (fine units); heights() are above it. The heights of one
    /// cell differ by far less than 2^32 fine units (262 km).
    std::int64_t& base(int g, std::int32_t chunk) { return grains_[gi(g)].base[gi(chunk)]; }
    std::int64_t base(int g, std::int32_t chunk) const { return grains_[gi(g)].base[gi(chunk)]; }
    std::span<std::uint32_t> heights(int g, std::int32_t chunk) {
        return {grains_[gi(g)].heights.data() + gi(chunk) * vertices(g), vertices(g)};
    }
    std::span<const std::uint32_t> heights(int g, std::int32_t chunk) const {
        return {grains_[gi(g)].heights.data() + gi(chunk) * vertices(g), vertices(g)};
    }

    // use
    /// The chunk and its block are used in `epoch`: neither goes while it lasts (ids of them
    /// may be held on the stack).
    void markUsed(int g, std::int32_t chunk, std::uint64_t epoch) {
        grains_[gi(g)].used[gi(chunk)] = epoch;
        grains_[0].used[gi(grains_[gi(g)].block[gi(chunk)])] = epoch;
    }
    void markBlockUsed(std::int32_t block, std::uint64_t epoch) {
        grains_[0].used[gi(block)] = epoch;
    }

    // residency
    /// `block` (a slot DetailBlocks just gave out, within resizeBlocks' size) becomes resident
    /// with its coarse grain.
    void adoptBlock(std::int32_t block, std::uint64_t epoch);
    /// Gives `block` a chunk of grain g (1 or 2): the lowest free one, or a new one at the end
    /// (chunkCount(g) grows; the owner sizes what it keeps per chunk to follow).
    std::int32_t takeChunk(std::int32_t block, int g, std::uint64_t epoch);
    /// `block`'s grain g goes (the chunk is free again; grain 0's only with the block).
    void releaseChunk(std::int32_t block, int g);
    /// `block` goes (after its chunks have been released).
    void releaseBlock(std::int32_t block) { chunks_[gi(block)] = {-1, -1, -1}; }

    // the rules
    /// A diamond refers to the block: its centre is split, or a diamond of its chunks has a
    /// state (split or a candidate, held in the heap or a list).
    bool
    referenced(std::int32_t block, const DetailBlocks& blocks, const DiamondSpace& space) const;
    /// The next block in clock order that may go: in use, not used in `epoch`, not referenced;
    /// -1 if none.
    std::int32_t
    evictionVictim(const DetailBlocks& blocks, const DiamondSpace& space, std::uint64_t epoch);
    /// A release the sweep found: the whole block (grain 0), or its finer grain `grain`.
    struct Release {
        std::int32_t block = -1;
        int grain = 0;
    };
    /// Memory follows the view: looks at the next kIdleSweep block slots and lists (in `out`,
    /// cleared first) the blocks idle for `idle_epochs` and not referenced, and the finer grains
    /// of the others idle that long and not referenced. A slot is looked at about every
    /// capacity / kIdleSweep calls, so an idle block goes between idle and idle + that many
    /// epochs after its last use. `idle_epochs` 0: nothing.
    void sweepIdle(
        const DetailBlocks& blocks,
        const DiamondSpace& space,
        std::uint64_t epoch,
        std::uint64_t idle_epochs,
        std::vector<Release>& out);
    static constexpr std::size_t kIdleSweep = 512;

    /// What the owner does when trim() moves a chunk or cuts chunks off.
    class Mover {
      public:
        /// Grain g's chunk `from` now lives at `to` (the pool's own data moved already).
        virtual void chunkMoved(int g, std::int32_t from, std::int32_t to) = 0;
        /// Grain g's chunks from `end` on are gone; `moved` lists those of them that moved
        /// (from, to) in this trim.
        virtual void chunksCut(
            int g,
            std::size_t end,
            std::span<const std::pair<std::int32_t, std::int32_t>> moved) = 0;

      protected:
        ~Mover() = default;
    };
    /// Gives back the memory of free grain 1 and 2 chunks once they are a quarter of their
    /// arrays (and those hold kTrimMinChunks or more): moves up to kTrimMoves of the highest
    /// live chunks into the lowest free ones per call, then cuts the free end off.
    void trim(Mover& mover);
    static constexpr std::size_t kTrimMinChunks = 256;
    static constexpr std::size_t kTrimMoves = 256;
    /// Chunks moved since construction (clear() keeps the count).
    std::int64_t movedCount() const { return moved_count_; }

    struct Memory {
        std::size_t blocks = 0; ///< the per-block chunk table
        std::array<std::size_t, kGrains> grains{};
    };
    Memory memory() const;

  private:
    static std::size_t gi(std::int64_t v) { return static_cast<std::size_t>(v); }
    static std::size_t vertices(int g) { return static_cast<std::size_t>(kGrainVertices[gi(g)]); }
    /// Sizes grain g's heights and bases for its chunk count, to spare an eighth.
    void growVertices(int g);

    struct Grain {
        std::vector<std::uint32_t> heights; ///< per vertex slot of every chunk, above its base
        std::vector<std::int64_t> base;     ///< per chunk: its lowest height (fine units)
        std::vector<std::int32_t> block;    ///< per chunk: its block, or -1 (free)
        std::vector<std::uint64_t> used;    ///< per chunk: the epoch it was last used in
        std::vector<std::int32_t> segment;  ///< per chunk: its segment in its tile, or -1
        /// Free chunks (grains 1 and 2; grain 0's are blocks), a min-heap: the lowest is reused
        /// first, so that the free ones gather at the end, where trim() cuts them off.
        std::vector<std::int32_t> free;
    };
    std::array<Grain, kGrains> grains_;
    std::vector<Chunks> chunks_; ///< per block slot
    std::array<bool, kGrains> trimming_{};
    std::vector<std::pair<std::int32_t, std::int32_t>> moved_; ///< this trim's moves, from -> to
    std::size_t clock_hand_ = 0;
    std::size_t idle_hand_ = 0;
    std::int64_t moved_count_ = 0;
};

} // namespace terrain::roam
