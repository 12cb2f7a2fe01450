// The tessellator's side of the block pool (block_pool.h keeps the chunks and the rules): a
// detail cell's heights and finer diamonds exist only while the view refines it. A block is
// materialised when a split needs it, and evicted when the pool needs its slot and no diamond
// refers to it; a block used in the current frame is never evicted, so ids held across a split
// stay valid. Here the pool's decisions reach the tiles' vertex arrays, the heap and the bounds.

#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>
#include <array>
#include <functional>

namespace terrain::roam {

using namespace detail;

void Tessellator::refuse(bool pool) {
    refused_by_cap_ = true;
    if (pool) {
        ++pool_refusals_;
        last_pool_refusal_ = frame_;
    }
}

std::int32_t Tessellator::pinnedBlockCount() const {
    std::int32_t n = 0;
    for (std::int32_t b = 0; b < blocks_.capacity(); ++b)
        n += blocks_.inUse(b) && pool_.referenced(b, blocks_, space_) ? 1 : 0;
    return n;
}

std::array<std::int32_t, kGrains> Tessellator::grainCounts() const {
    std::array<std::int32_t, kGrains> n{};
    for (int g = 0; g < kGrains; ++g)
        for (std::size_t c = 0; c < pool_.chunkCount(g); ++c)
            n[static_cast<std::size_t>(g)] +=
                pool_.blockOf(g, static_cast<std::int32_t>(c)) >= 0 ? 1 : 0;
    return n;
}

void Tessellator::releaseGrain(std::int32_t block, int g) {
    // no diamond of the grain is split or a candidate, so no triangle uses its vertices
    const std::int32_t chunk = pool_.chunkOf(block, g);
    for (std::uint32_t slot = 0; slot < static_cast<std::uint32_t>(kGrainDiamonds[idx(g)]); ++slot)
        TERRAIN_ASSERT(!policy_.holds(grainId(g, chunk, slot)));
    space_.clearChunk(g, chunk);
    detachGrain(block, g);
    pool_.releaseChunk(block, g);
}

void Tessellator::evict(std::int32_t block) {
    for (int g = kGrains - 1; g >= 0; --g)
        if (pool_.chunkOf(block, g) >= 0)
            releaseGrain(block, g);
    pool_.releaseBlock(block);
    bounds_.forget(block); // its place in the stale queue is skipped
    emitter_.blockChanged(block);
    blocks_.release(block);
    ++evicted_;
}

bool Tessellator::evictOne() {
    const std::int32_t block = pool_.evictionVictim(blocks_, space_, use_epoch_);
    if (block < 0)
        return false;
    evict(block);
    return true;
}

void Tessellator::sweepIdleBlocks() {
    // memory follows the view: a block out of reach goes after a while even when the pool has
    // room, and so does a finer grain no split needs any more
    pool_.sweepIdle(
        blocks_, space_, use_epoch_, static_cast<std::uint64_t>(options_.detail_block_idle_frames),
        releases_);
    for (const BlockPool::Release& r : releases_) {
        if (r.grain == 0) {
            evict(r.block);
            continue;
        }
        releaseGrain(r.block, r.grain);
        emitter_.blockChanged(r.block);
    }
}

struct Tessellator::PoolMover final : BlockPool::Mover {
    explicit PoolMover(Tessellator& t) : t_(t) {}

    void chunkMoved(int g, std::int32_t from, std::int32_t to) override {
        t_.space_.moveChunk(g, from, to);
        // the tile's vertex array keeps the segment: the same vertices, read from the new chunk
        if (const std::int32_t segment = t_.pool_.segment(g, to); segment >= 0)
            t_.emitter_.grainMoved(t_.pool_.blockOf(g, to), segment, to);
        t_.policy_.chunkMoved(g, from, to);
    }

    void chunksCut(
        int g,
        std::size_t end,
        std::span<const std::pair<std::int32_t, std::int32_t>> moved) override {
        // ids of the chunks cut off, in the lists kept across frames
        t_.policy_.chunksCut(g, end, moved);
        t_.space_.fitChunks(g, end);
        t_.resizeDiamondState();
    }

  private:
    Tessellator& t_;
};

void Tessellator::trimGrains() {
    PoolMover mover(*this);
    pool_.trim(mover);
}

std::int32_t Tessellator::materialise(std::int32_t record) {
    // once every slot was found in use, the rest of the frame is refused without a search
    if (blocks_.count() >= options_.max_detail_blocks &&
        (pool_full_epoch_ == use_epoch_ || !evictOne())) {
        pool_full_epoch_ = use_epoch_;
        refuse(true);
        return -1;
    }
    const std::int32_t block = blocks_.materialise(record);
    if (idx(block) >= pool_.chunkCount(0)) // a new slot, not a free one
        resizeDiamondState();
    pool_.adoptBlock(block, use_epoch_);
    space_.clearChunk(0, block);
    attachGrain(block, 0);
    if (batching_)
        batch(block, 1u);
    else if (!defer_bounds_)
        bounds_.boundGrains(block, 1u);
    ++materialised_;
    return block;
}

void Tessellator::materialiseGrain(std::int32_t block, int g) {
    const std::int32_t chunk = pool_.takeChunk(block, g, use_epoch_);
    if (pool_.chunkCount(g) > space_.chunkCount(g)) // a new chunk, not a free one
        resizeDiamondState();
    space_.clearChunk(g, chunk);
    attachGrain(block, g);
    if (batching_)
        batch(block, 1u << g);
    else if (!defer_bounds_)
        bounds_.boundGrains(block, 1u << g);
    ++grains_materialised_;
}

void Tessellator::batch(std::int32_t block, unsigned grains) {
    for (auto& [b, mask] : batched_)
        if (b == block) {
            mask |= grains;
            return;
        }
    batched_.emplace_back(block, grains);
}

void Tessellator::boundBatched() {
    bounds_.boundGrainsOf(batched_);
    batched_.clear();
}

struct Tessellator::PrefetchGrains final : BoundsUpdate::PassListener {
    PrefetchGrains(Tessellator& t, const ViewMetric& m, double threshold)
        : t_(t), m_(m), threshold_(threshold) {}

    void bounded(std::size_t i, std::int32_t block) override;

  private:
    Tessellator& t_;
    const ViewMetric& m_;
    double threshold_;
};

void Tessellator::prefetchBlocks(const ViewMetric& m, double threshold) {
    // A top-down build at the threshold splits every centre whose priority exceeds it (its
    // parents' priorities are no lower: bounds and boxes nest), so the cells whose blocks it
    // will make are known from the records alone; and a grain's deepest diamonds above it split
    // too, so whether the next grain is needed is known once the grain's bounds are. Forced
    // splits may need more: the build makes those one at a time, as before.
    prefetch_.clear();
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = emitter_.tileRoot(tile);
        if (priority(m, root, idOf(root.centre)) <= threshold)
            continue; // nothing in the tile splits
        const std::int32_t x0 = (tile % spec_.tilesX()) * kTileCells;
        const std::int32_t y0 = (tile / spec_.tilesX()) * kTileCells;
        for (std::int32_t cy = y0; cy < y0 + kTileCells; ++cy)
            for (std::int32_t cx = x0; cx < x0 + kTileCells; ++cx) {
                const std::int32_t r = blocks_.recordOf(cx, cy);
                if (r < 0 || blocks_.blockOfRecord(r) >= 0)
                    continue;
                const Diamond centre = diamondAt(
                    {cx * kLatticePerCell + kCentreLocal, cy * kLatticePerCell + kCentreLocal});
                if (const double p = priority(m, centre, bounds_.centreBounds(r)); p > threshold)
                    prefetch_.push_back({p, r});
            }
    }
    const auto room =
        static_cast<std::size_t>(std::max(0, options_.max_detail_blocks - blocks_.count()));
    if (prefetch_.size() > room) { // the pool binds: the largest errors first
        std::nth_element(
            prefetch_.begin(), prefetch_.begin() + static_cast<std::ptrdiff_t>(room),
            prefetch_.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        prefetch_.resize(room);
    }
    if (prefetch_.empty())
        return;
    defer_bounds_ = true;
    made_.clear();
    for (const auto& [p, r] : prefetch_)
        made_.push_back(materialise(r));
    defer_bounds_ = false;
    PrefetchGrains grains(*this, m, threshold);
    bounds_.boundBlocks(made_, &grains);
}

void Tessellator::PrefetchGrains::bounded(std::size_t i, std::int32_t block) {
    const DetailBlocks::CellXY c = t_.blocks_.cellOf(block);
    const GrainTables& tables = grainTables();
    for (int g = 1; g < kGrains; ++g) {
        if (t_.pool_.chunkOf(block, g) >= 0)
            continue;
        // the build makes grain g when one of grain g - 1's deepest diamonds splits
        const auto coarser = static_cast<std::size_t>(g - 1);
        bool needed = false;
        for (std::int32_t slot = 0; slot < kGrainDiamonds[coarser] && !needed; ++slot) {
            const std::uint8_t local =
                tables.diamond_local[coarser][static_cast<std::size_t>(slot)];
            const LatticePoint p{
                c.x * kLatticePerCell + local % kLatticePerCell,
                c.y * kLatticePerCell + local / kLatticePerCell};
            const Diamond d = diamondAt(p);
            if (d.level != kGrainDeepestLevel[coarser] || !t_.insideMap(p))
                continue;
            needed =
                t_.priority(m_, d, t_.space_.codec().outward(t_.bounds_.passBounds(i, local))) >
                threshold_;
        }
        if (!needed)
            return; // nor the finer ones: they hang from this one's splits
        t_.defer_bounds_ = true;
        t_.materialiseGrain(block, g);
        t_.defer_bounds_ = false;
        t_.bounds_.storeGrains(i, block, 1u << g);
    }
}

void Tessellator::materialiseAll() {
    const std::int32_t limit = options_.max_detail_blocks;
    options_.max_detail_blocks = blocks_.recordCapacity() + 1;
    // every grain of every block, then their bounds in passes over squares of cells
    defer_bounds_ = true;
    made_.clear();
    for (std::int32_t r = 0; r < blocks_.recordCapacity(); ++r) {
        if (!blocks_.recordInUse(r))
            continue;
        std::int32_t block = blocks_.blockOfRecord(r);
        if (block < 0)
            block = materialise(r);
        for (int g = 1; g < kGrains; ++g)
            if (pool_.chunkOf(block, g) < 0)
                materialiseGrain(block, g);
        made_.push_back(block);
    }
    defer_bounds_ = false;
    bounds_.boundBlocks(made_);
    options_.max_detail_blocks = std::max(limit, blocks_.count());
}

} // namespace terrain::roam
