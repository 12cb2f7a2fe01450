// The tessellator's pool of detail blocks: a detail cell's heights and finer diamonds exist only
// while the view refines it. A block is materialised when a split needs it, and evicted (clock
// order) when the pool needs its slot and no diamond refers to it; a block used in the current
// frame is never evicted, so ids held across a split stay valid.

#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>
#include <array>
#include <functional>

namespace terrain::roam {

using namespace detail;

void Tessellator::clearAllState() {
    std::fill(state_.begin(), state_.end(), std::uint8_t{0});
    std::fill(centre_state_.begin(), centre_state_.end(), std::uint8_t{0});
    for (Grain& g : grains_)
        std::fill(g.state.begin(), g.state.end(), std::uint8_t{0});
}

void Tessellator::refuse(bool pool) {
    refused_by_cap_ = true;
    if (pool) {
        ++pool_refusals_;
        last_pool_refusal_ = frame_;
    }
}

bool Tessellator::grainPinned(int g, std::int32_t chunk) const {
    const Grain& grain = grains_[static_cast<std::size_t>(g)];
    const auto size = static_cast<std::size_t>(kGrainDiamonds[static_cast<std::size_t>(g)]);
    const auto first = grain.state.begin() + static_cast<std::ptrdiff_t>(idx(chunk) * size);
    return std::any_of(
        first, first + static_cast<std::ptrdiff_t>(size), [](std::uint8_t s) { return s != 0; });
}

bool Tessellator::pinned(std::int32_t block) const {
    // the centre split means the cell's triangles use the block's vertices; any state means a
    // diamond of the block is split or a candidate (held in the heap or a list)
    if (active(centreId(blocks_.recordOfBlock(block))))
        return true;
    for (int g = 0; g < kGrains; ++g)
        if (const std::int32_t chunk = block_chunks_[idx(block)][static_cast<std::size_t>(g)];
            chunk >= 0 && grainPinned(g, chunk))
            return true;
    return false;
}

std::int32_t Tessellator::pinnedBlockCount() const {
    std::int32_t n = 0;
    for (std::int32_t b = 0; b < blocks_.capacity(); ++b)
        n += blocks_.inUse(b) && pinned(b) ? 1 : 0;
    return n;
}

std::array<std::int32_t, kGrains> Tessellator::grainCounts() const {
    std::array<std::int32_t, kGrains> n{};
    for (std::size_t g = 0; g < kGrains; ++g)
        for (const std::int32_t b : grains_[g].block)
            n[g] += b >= 0 ? 1 : 0;
    return n;
}

void Tessellator::releaseGrain(std::int32_t block, int g) {
    // no diamond of the grain is split or a candidate, so no triangle uses its vertices
    Grain& grain = grains_[static_cast<std::size_t>(g)];
    const std::int32_t chunk = block_chunks_[idx(block)][static_cast<std::size_t>(g)];
    const auto size = static_cast<std::size_t>(kGrainDiamonds[static_cast<std::size_t>(g)]);
    for (std::size_t slot = 0; slot < size; ++slot) {
        TERRAIN_ASSERT(!heap_.contains(grainId(g, chunk, static_cast<std::uint32_t>(slot))));
        grain.state[idx(chunk) * size + slot] = 0;
    }
    detachGrain(block, g);
    grain.block[idx(chunk)] = -1;
    if (g > 0) {
        grain.free.push_back(chunk);
        std::push_heap(grain.free.begin(), grain.free.end(), std::greater<>());
        block_chunks_[idx(block)][static_cast<std::size_t>(g)] = -1;
    }
}

void Tessellator::evict(std::int32_t block) {
    for (int g = kGrains - 1; g >= 0; --g)
        if (block_chunks_[idx(block)][static_cast<std::size_t>(g)] >= 0)
            releaseGrain(block, g);
    block_chunks_[idx(block)] = {-1, -1, -1};
    if (idx(block) < block_stale_.size())
        block_stale_[idx(block)] = 0; // its place in stale_ is skipped
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
        if (!blocks_.inUse(block) || grains_[0].used[idx(block)] == use_epoch_ || pinned(block))
            continue;
        evict(block);
        return true;
    }
    return false;
}

void Tessellator::sweepIdleBlocks() {
    // memory follows the view: a block out of reach goes after a while even when the pool has
    // room, and so does a finer grain no split needs any more. A slot is checked about every
    // capacity / kIdleSweep frames, so an idle block goes between idle and idle + that many
    // frames after its last use.
    const auto idle = static_cast<std::uint64_t>(options_.detail_block_idle_frames);
    const auto slots = static_cast<std::size_t>(blocks_.capacity());
    if (idle == 0 || slots == 0)
        return;
    for (std::size_t step = 0; step < std::min(slots, kIdleSweep); ++step) {
        const auto block = static_cast<std::int32_t>(idle_hand_ % slots);
        idle_hand_ = (idle_hand_ + 1) % slots;
        if (!blocks_.inUse(block))
            continue;
        if (grains_[0].used[idx(block)] + idle < use_epoch_ && !pinned(block)) {
            evict(block);
            continue;
        }
        for (int g = kGrains - 1; g > 0; --g) {
            const std::int32_t chunk = block_chunks_[idx(block)][static_cast<std::size_t>(g)];
            if (chunk >= 0 &&
                grains_[static_cast<std::size_t>(g)].used[idx(chunk)] + idle < use_epoch_ &&
                !grainPinned(g, chunk)) {
                releaseGrain(block, g);
                if (const std::int32_t tile = tileOfCell(blocks_.cellOf(block)); tile >= 0)
                    ++vertex_version_[idx(tile)];
            }
        }
    }
}

void Tessellator::moveChunk(int g, std::int32_t from, std::int32_t to) {
    Grain& grain = grains_[static_cast<std::size_t>(g)];
    const auto diamonds = static_cast<std::size_t>(kGrainDiamonds[static_cast<std::size_t>(g)]);
    const auto vertices = static_cast<std::size_t>(kGrainVertices[static_cast<std::size_t>(g)]);
    const auto copy = [](auto& v, std::size_t n, std::int32_t a, std::int32_t b) {
        std::copy_n(
            v.begin() + static_cast<std::ptrdiff_t>(idx(a) * n), n,
            v.begin() + static_cast<std::ptrdiff_t>(idx(b) * n));
    };
    copy(grain.bounds, diamonds, from, to);
    copy(grain.state, diamonds, from, to);
    copy(grain.heights, vertices, from, to);
    copy(grain.base, 1, from, to);
    copy(grain.used, 1, from, to);
    copy(grain.segment, 1, from, to);
    const std::int32_t block = grain.block[idx(from)];
    grain.block[idx(to)] = block;
    grain.block[idx(from)] = -1;
    block_chunks_[idx(block)][static_cast<std::size_t>(g)] = to;
    // the tile's vertex array keeps the segment: the same vertices, read from the new chunk
    if (const std::int32_t segment = grain.segment[idx(to)]; segment >= 0)
        tile_segments_[idx(tileOfCell(blocks_.cellOf(block)))][idx(segment)].chunk = to;
    grain.segment[idx(from)] = -1;
    for (std::size_t slot = 0; slot < diamonds; ++slot) {
        const auto s = static_cast<std::uint32_t>(slot);
        if (grain.state[idx(to) * diamonds + slot] != 0 && heap_.contains(grainId(g, from, s)))
            heap_.rename(grainId(g, from, s), grainId(g, to, s));
        grain.state[idx(from) * diamonds + slot] = 0;
    }
}

void Tessellator::trimGrains() {
    // Incremental: each frame moves up to kTrimMoves of the highest chunks into the lowest free
    // ones, keeping their segments (the vertices drawn do not change) and renaming their ids in
    // the heap and the lists kept across frames, then cuts the free end off.
    for (std::size_t g = 1; g < kGrains; ++g) {
        Grain& grain = grains_[g];
        const std::size_t size = grain.block.size();
        if (!trimming_[g]) {
            if (size < kTrimMinChunks || grain.free.size() * 4 < size)
                continue;
            trimming_[g] = true;
        }
        std::size_t end = size;
        moved_.clear();
        for (std::size_t moves = 0;; ++moves) {
            while (end > 0 && grain.block[end - 1] < 0)
                --end;
            // the lowest free chunk below the end (those above it are cut off)
            while (!grain.free.empty() && idx(grain.free.front()) >= end) {
                std::pop_heap(grain.free.begin(), grain.free.end(), std::greater<>());
                grain.free.pop_back();
            }
            if (grain.free.empty()) {
                trimming_[g] = false; // dense
                break;
            }
            if (moves == kTrimMoves)
                break;
            std::pop_heap(grain.free.begin(), grain.free.end(), std::greater<>());
            const std::int32_t to = grain.free.back();
            grain.free.pop_back();
            const auto from = static_cast<std::int32_t>(end - 1);
            moveChunk(static_cast<int>(g), from, to);
            moved_.push_back({from, to});
            ++chunks_moved_;
        }
        if (end == size)
            continue;
        std::erase_if(grain.free, [&](std::int32_t c) { return idx(c) >= end; });
        std::make_heap(grain.free.begin(), grain.free.end(), std::greater<>());
        // ids of the chunks cut off, in the lists kept across frames: renamed if the chunk
        // moved; dropped if it was free (a released grain's watched ids lost their state)
        const auto diamonds = static_cast<std::size_t>(kGrainDiamonds[g]);
        const auto rename = [&](std::vector<DiamondId>& ids) {
            std::erase_if(ids, [&](DiamondId& id) {
                if (id < kPooled || grainOfId(id) != static_cast<int>(g))
                    return false;
                const std::size_t slot = pooledSlot(id, static_cast<int>(g));
                const std::size_t chunk = slot / diamonds;
                if (chunk < end)
                    return false;
                for (const auto& [from, to] : moved_)
                    if (idx(from) == chunk) {
                        id = grainId(
                            static_cast<int>(g), to, static_cast<std::uint32_t>(slot % diamonds));
                        return false;
                    }
                return true;
            });
        };
        rename(watched_);
        rename(rekey_);
        const auto fit = [](auto& v, std::size_t n) {
            v.resize(n);
            if (v.capacity() > n + n / 4)
                v.shrink_to_fit();
        };
        fit(grain.block, end);
        fit(grain.used, end);
        fit(grain.segment, end);
        fit(grain.base, end);
        fit(grain.bounds, end * diamonds);
        fit(grain.state, end * diamonds);
        fit(grain.heights, end * static_cast<std::size_t>(kGrainVertices[g]));
        resizeDiamondState();
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
    const std::int32_t block = blocks_.materialise(record);
    if (idx(block) >= grains_[0].block.size()) // a new slot, not a free one
        resizeDiamondState();
    block_chunks_[idx(block)] = {block, -1, -1};
    Grain& coarse = grains_[0];
    coarse.block[idx(block)] = block;
    const auto size = static_cast<std::size_t>(kGrainDiamonds[0]);
    std::fill_n(
        coarse.state.begin() + static_cast<std::ptrdiff_t>(idx(block) * size), size,
        std::uint8_t{0});
    coarse.used[idx(block)] = use_epoch_;
    attachGrain(block, 0);
    if (!defer_bounds_)
        boundGrains(block, 1u);
    ++materialised_;
    return block;
}

void Tessellator::materialiseGrain(std::int32_t block, int g) {
    Grain& grain = grains_[static_cast<std::size_t>(g)];
    std::int32_t chunk = 0;
    if (!grain.free.empty()) {
        std::pop_heap(grain.free.begin(), grain.free.end(), std::greater<>());
        chunk = grain.free.back();
        grain.free.pop_back();
    } else {
        chunk = static_cast<std::int32_t>(grain.block.size());
        grain.block.push_back(-1);
        grain.used.push_back(0);
        grain.segment.push_back(-1);
        resizeDiamondState();
    }
    grain.block[idx(chunk)] = block;
    block_chunks_[idx(block)][static_cast<std::size_t>(g)] = chunk;
    const auto size = static_cast<std::size_t>(kGrainDiamonds[static_cast<std::size_t>(g)]);
    std::fill_n(
        grain.state.begin() + static_cast<std::ptrdiff_t>(idx(chunk) * size), size,
        std::uint8_t{0});
    grain.used[idx(chunk)] = use_epoch_;
    grains_[0].used[idx(block)] = use_epoch_;
    attachGrain(block, g);
    if (!defer_bounds_)
        boundGrains(block, 1u << g);
    ++grains_materialised_;
}

void Tessellator::boundGrains(std::int32_t block, unsigned grain_mask) {
    const DetailBlocks::CellXY cell = blocks_.cellOf(block);
    // a split that needs a block often needs its next grain soon after (the pass computed every
    // grain's bounds): the last pass is reused while the terrain has not changed since
    if (bounded_cell_.x != cell.x || bounded_cell_.y != cell.y ||
        bounded_generation_ != terrain_generation_) {
        const BlockGeometry geometry{
            metres_per_fine_, grid_w_, grid_h_, spec_.cellsX(), spec_.cellsY()};
        block_bounds_.compute(
            *terrain_, blocks_, geometry, std::span<const DetailBlocks::CellXY>(&cell, 1));
        bounded_cell_ = cell;
        bounded_generation_ = terrain_generation_;
    }
    storeGrains(0, block, grain_mask, false);
    if (const std::int32_t tile = tileOfCell(cell); tile >= 0)
        ++vertex_version_[idx(tile)];
}

void Tessellator::prefetchBlocks(const ViewMetric& m, double threshold) {
    // A top-down build at the threshold splits every centre whose priority exceeds it (its
    // parents' priorities are no lower: bounds and boxes nest), so the cells whose blocks it
    // will make are known from the records alone; and a grain's deepest diamonds above it split
    // too, so whether the next grain is needed is known once the grain's bounds are. Forced
    // splits may need more: the build makes those one at a time, as before.
    prefetch_.clear();
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
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
                if (const double p = priority(m, centre, centreBounds(r)); p > threshold)
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
    pass_.clear();
    for (const auto& [p, r] : prefetch_)
        pass_.push_back(materialise(r));
    defer_bounds_ = false;
    prefetch_view_ = &m;
    prefetch_threshold_ = threshold;
    boundBlocks(pass_, false);
    prefetch_view_ = nullptr;
}

void Tessellator::prefetchGrains(std::size_t i, std::int32_t block) {
    const DetailBlocks::CellXY c = blocks_.cellOf(block);
    const GrainTables& tables = grainTables();
    for (int g = 1; g < kGrains; ++g) {
        if (block_chunks_[idx(block)][static_cast<std::size_t>(g)] >= 0)
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
            if (d.level != kGrainDeepestLevel[coarser] || !insideMap(p))
                continue;
            needed = priority(*prefetch_view_, d, codec_.outward(block_bounds_.bounds(i, local))) >
                     prefetch_threshold_;
        }
        if (!needed)
            return; // nor the finer ones: they hang from this one's splits
        defer_bounds_ = true;
        materialiseGrain(block, g);
        defer_bounds_ = false;
        storeGrains(i, block, 1u << g, false);
    }
}

void Tessellator::materialiseAll() {
    const std::int32_t limit = options_.max_detail_blocks;
    options_.max_detail_blocks = blocks_.recordCapacity() + 1;
    // every grain of every block, then their bounds in passes over squares of cells
    defer_bounds_ = true;
    pass_.clear();
    for (std::int32_t r = 0; r < blocks_.recordCapacity(); ++r) {
        if (!blocks_.recordInUse(r))
            continue;
        std::int32_t block = blocks_.blockOfRecord(r);
        if (block < 0)
            block = materialise(r);
        for (int g = 1; g < kGrains; ++g)
            if (block_chunks_[idx(block)][static_cast<std::size_t>(g)] < 0)
                materialiseGrain(block, g);
        pass_.push_back(block);
    }
    defer_bounds_ = false;
    boundBlocks(pass_, false);
    options_.max_detail_blocks = std::max(limit, blocks_.count());
}

} // namespace terrain::roam
