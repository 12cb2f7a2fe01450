#include <terrain/assert.h>
#include <terrain/roam/block_pool.h>

#include <algorithm>
#include <functional>

namespace terrain::roam {

void BlockPool::clear() {
    for (Grain& g : grains_)
        g = Grain{};
    chunks_.clear();
}

void BlockPool::growVertices(int g) {
    // grow by an eighth, not double: the pool may be most of the memory
    const auto grow = [](auto& v, std::size_t n) {
        if (n > v.capacity())
            v.reserve(n + v.size() / 8);
        v.resize(n);
    };
    Grain& grain = grains_[gi(g)];
    grow(grain.heights, grain.block.size() * vertices(g));
    grow(grain.base, grain.block.size());
}

void BlockPool::resizeBlocks(std::size_t blocks) {
    chunks_.resize(blocks, {-1, -1, -1});
    Grain& coarse = grains_[0];
    if (coarse.block.size() < blocks) { // grain 0's chunks are the blocks
        coarse.block.resize(blocks, -1);
        coarse.used.resize(blocks, 0);
        coarse.segment.resize(blocks, -1);
    }
    for (int g = 0; g < kGrains; ++g)
        growVertices(g);
}

void BlockPool::adoptBlock(std::int32_t block, std::uint64_t epoch) {
    TERRAIN_ASSERT(gi(block) < chunks_.size());
    chunks_[gi(block)] = {block, -1, -1};
    grains_[0].block[gi(block)] = block;
    grains_[0].used[gi(block)] = epoch;
}

std::int32_t BlockPool::takeChunk(std::int32_t block, int g, std::uint64_t epoch) {
    TERRAIN_ASSERT(g > 0 && chunks_[gi(block)][gi(g)] < 0);
    Grain& grain = grains_[gi(g)];
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
        growVertices(g);
    }
    grain.block[gi(chunk)] = block;
    chunks_[gi(block)][gi(g)] = chunk;
    grain.used[gi(chunk)] = epoch;
    grains_[0].used[gi(block)] = epoch;
    return chunk;
}

void BlockPool::releaseChunk(std::int32_t block, int g) {
    Grain& grain = grains_[gi(g)];
    const std::int32_t chunk = chunks_[gi(block)][gi(g)];
    TERRAIN_ASSERT(chunk >= 0);
    grain.block[gi(chunk)] = -1;
    if (g > 0) {
        grain.free.push_back(chunk);
        std::push_heap(grain.free.begin(), grain.free.end(), std::greater<>());
        chunks_[gi(block)][gi(g)] = -1;
    }
}

bool BlockPool::referenced(
    std::int32_t block, const DetailBlocks& blocks, const DiamondSpace& space) const {
    // the centre split means the cell's triangles use the block's vertices; any state means a
    // diamond of the block is split or a candidate (held in the heap or a list)
    if (space.active(space.centreId(blocks.recordOfBlock(block))))
        return true;
    for (int g = 0; g < kGrains; ++g)
        if (const std::int32_t chunk = chunks_[gi(block)][gi(g)];
            chunk >= 0 && space.chunkReferenced(g, chunk))
            return true;
    return false;
}

std::int32_t BlockPool::evictionVictim(
    const DetailBlocks& blocks, const DiamondSpace& space, std::uint64_t epoch) {
    const auto slots = static_cast<std::size_t>(blocks.capacity());
    for (std::size_t step = 0; step < slots; ++step) {
        const auto block = static_cast<std::int32_t>(clock_hand_ % slots);
        clock_hand_ = (clock_hand_ + 1) % slots;
        if (!blocks.inUse(block) || grains_[0].used[gi(block)] == epoch ||
            referenced(block, blocks, space))
            continue;
        return block;
    }
    return -1;
}

void BlockPool::sweepIdle(
    const DetailBlocks& blocks,
    const DiamondSpace& space,
    std::uint64_t epoch,
    std::uint64_t idle_epochs,
    std::vector<Release>& out) {
    out.clear();
    const auto slots = static_cast<std::size_t>(blocks.capacity());
    if (idle_epochs == 0 || slots == 0)
        return;
    // each slot at most once: a release found here changes nothing another slot's test reads
    for (std::size_t step = 0; step < std::min(slots, kIdleSweep); ++step) {
        const auto block = static_cast<std::int32_t>(idle_hand_ % slots);
        idle_hand_ = (idle_hand_ + 1) % slots;
        if (!blocks.inUse(block))
            continue;
        if (grains_[0].used[gi(block)] + idle_epochs < epoch && !referenced(block, blocks, space)) {
            out.push_back({block, 0});
            continue;
        }
        for (int g = kGrains - 1; g > 0; --g) {
            const std::int32_t chunk = chunks_[gi(block)][gi(g)];
            if (chunk >= 0 && grains_[gi(g)].used[gi(chunk)] + idle_epochs < epoch &&
                !space.chunkReferenced(g, chunk))
                out.push_back({block, g});
        }
    }
}

void BlockPool::trim(Mover& mover) {
    // Incremental: each call moves up to kTrimMoves of the highest chunks into the lowest free
    // ones (the owner keeps their segments, so the vertices drawn do not change, and renames
    // their ids), then cuts the free end off.
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
            while (!grain.free.empty() && gi(grain.free.front()) >= end) {
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
            const std::size_t n = vertices(static_cast<int>(g));
            std::copy_n(
                grain.heights.begin() + static_cast<std::ptrdiff_t>(gi(from) * n), n,
                grain.heights.begin() + static_cast<std::ptrdiff_t>(gi(to) * n));
            grain.base[gi(to)] = grain.base[gi(from)];
            grain.used[gi(to)] = grain.used[gi(from)];
            grain.segment[gi(to)] = grain.segment[gi(from)];
            const std::int32_t block = grain.block[gi(from)];
            grain.block[gi(to)] = block;
            grain.block[gi(from)] = -1;
            chunks_[gi(block)][g] = to;
            mover.chunkMoved(static_cast<int>(g), from, to);
            grain.segment[gi(from)] = -1;
            moved_.push_back({from, to});
            ++moved_count_;
        }
        if (end == size)
            continue;
        std::erase_if(grain.free, [&](std::int32_t c) { return gi(c) >= end; });
        std::make_heap(grain.free.begin(), grain.free.end(), std::greater<>());
        const auto fit = [](auto& v, std::size_t n) {
            v.resize(n);
            if (v.capacity() > n + n / 4)
                v.shrink_to_fit();
        };
        fit(grain.block, end);
        fit(grain.used, end);
        fit(grain.segment, end);
        fit(grain.base, end);
        fit(grain.heights, end * vertices(static_cast<int>(g)));
        mover.chunksCut(static_cast<int>(g), end, moved_);
    }
}

BlockPool::Memory BlockPool::memory() const {
    Memory m;
    m.blocks = chunks_.capacity() * sizeof(Chunks);
    for (std::size_t g = 0; g < kGrains; ++g) {
        const Grain& grain = grains_[g];
        m.grains[g] = grain.heights.capacity() * sizeof(std::uint32_t) +
                      grain.base.capacity() * sizeof(std::int64_t) +
                      (grain.block.capacity() + grain.segment.capacity() + grain.free.capacity()) *
                          sizeof(std::int32_t) +
                      grain.used.capacity() * sizeof(std::uint64_t);
    }
    return m;
}

} // namespace terrain::roam
