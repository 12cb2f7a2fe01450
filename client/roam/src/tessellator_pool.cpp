// The tessellator's pool of detail blocks: a detail cell's heights and finer diamonds exist only
// while the view refines it. A block is materialised when a split needs it, and evicted (clock
// order) when the pool needs its slot and no diamond refers to it; a block used in the current
// frame is never evicted, so ids held across a split stay valid.

#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>
#include <array>

namespace terrain::roam {

using namespace detail;

void Tessellator::clearAllState() {
    std::fill(state_.begin(), state_.end(), std::uint8_t{0});
    std::fill(pooled_state_.begin(), pooled_state_.end(), std::uint8_t{0});
}

void Tessellator::refuse(bool pool) {
    refused_by_cap_ = true;
    if (pool) {
        ++pool_refusals_;
        last_pool_refusal_ = frame_;
    }
}

bool Tessellator::pinned(std::int32_t block) const {
    // the centre split means the cell's triangles use the block's vertices; any state means a
    // diamond of the block is split or a candidate (held in the heap or a list)
    if (active(centreId(blocks_.recordOfBlock(block))))
        return true;
    const std::size_t base = idx(block) * kDiamondsPerBlock;
    return std::any_of(
        pooled_state_.begin() + static_cast<std::ptrdiff_t>(base),
        pooled_state_.begin() + static_cast<std::ptrdiff_t>(base + kDiamondsPerBlock),
        [](std::uint8_t s) { return s != 0; });
}

std::int32_t Tessellator::pinnedBlockCount() const {
    std::int32_t n = 0;
    for (std::int32_t b = 0; b < blocks_.capacity(); ++b)
        n += blocks_.inUse(b) && pinned(b) ? 1 : 0;
    return n;
}

void Tessellator::evict(std::int32_t block) {
    for (std::uint32_t local = 0; local < kDiamondsPerBlock; ++local) {
        const DiamondId id = pooledId(block, local);
        TERRAIN_ASSERT(!heap_.contains(id)); // candidates pin their block
        pooled_state_[id - kPooled] = 0;
    }
    detachBlock(block);
    if (const std::int32_t tile = tileOfCell(blocks_.cellOf(block)); tile >= 0)
        ++vertex_version_[idx(tile)];
    blocks_.release(block);
    ++evicted_;
}

bool Tessellator::evictOne() {
    const auto slots = static_cast<std::size_t>(blocks_.capacity());
    for (std::size_t step = 0; step < slots; ++step) {
        const auto block = static_cast<std::int32_t>(clock_hand_ % slots);
        clock_hand_ = (clock_hand_ + 1) % slots;
        if (!blocks_.inUse(block) || block_used_[idx(block)] == use_epoch_ || pinned(block))
            continue;
        evict(block);
        return true;
    }
    return false;
}

void Tessellator::sweepIdleBlocks() {
    // memory follows the view: a block out of reach goes after a while even when the pool has
    // room. A slot is checked about every capacity / kIdleSweep frames, so an idle block goes
    // between idle and idle + that many frames after its last use.
    const auto idle = static_cast<std::uint64_t>(options_.detail_block_idle_frames);
    const auto slots = static_cast<std::size_t>(blocks_.capacity());
    if (idle == 0 || slots == 0)
        return;
    for (std::size_t step = 0; step < std::min(slots, kIdleSweep); ++step) {
        const auto block = static_cast<std::int32_t>(idle_hand_ % slots);
        idle_hand_ = (idle_hand_ + 1) % slots;
        if (blocks_.inUse(block) && block_used_[idx(block)] + idle < use_epoch_ && !pinned(block))
            evict(block);
    }
}

std::int32_t Tessellator::materialise(std::int32_t record) {
    // once every slot was found in use, the rest of the frame is refused without a search
    if (blocks_.count() >= options_.max_detail_blocks &&
        (pool_full_epoch_ == use_epoch_ || !evictOne())) {
        pool_full_epoch_ = use_epoch_;
        refuse(true);
        return -1;
    }
    const std::int32_t block = blocks_.materialise(*terrain_, record);
    resizeDiamondState();
    for (std::uint32_t local = 0; local < kDiamondsPerBlock; ++local)
        pooled_state_[pooledId(block, local) - kPooled] = 0;
    block_used_[idx(block)] = use_epoch_;
    attachBlock(block);
    if (const std::int32_t tile = tileOfCell(blocks_.cellOf(block)); tile >= 0)
        ++vertex_version_[idx(tile)];
    const std::array<std::int32_t, 1> one = {block};
    boundBlocks(one, false);
    ++materialised_;
    return block;
}

void Tessellator::materialiseAll() {
    const std::int32_t limit = options_.max_detail_blocks;
    options_.max_detail_blocks = blocks_.recordCapacity() + 1;
    for (std::int32_t r = 0; r < blocks_.recordCapacity(); ++r)
        if (blocks_.recordInUse(r) && blocks_.blockOfRecord(r) < 0)
            materialise(r);
    options_.max_detail_blocks = std::max(limit, blocks_.count());
}

} // namespace terrain::roam
