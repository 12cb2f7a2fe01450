#include <terrain/roam/diamond_space.h>

#include <algorithm>

namespace terrain::roam {

namespace {

// grow by an eighth of what is there, not a doubling: the pooled arrays may be most of the
// tessellator's memory
template <class V> void grow(V& v, std::size_t n) {
    if (n > v.capacity())
        v.reserve(n + v.size() / 8);
    v.resize(n);
}

template <class V> void fit(V& v, std::size_t n) {
    v.resize(n);
    if (v.capacity() > n + n / 4)
        v.shrink_to_fit();
}

} // namespace

void DiamondSpace::reset(std::uint32_t grid_count, const BoundsCodec& codec) {
    codec_ = codec;
    grid_count_ = grid_count;
    grid_bounds_.assign(grid_count, PackedBounds{});
    grid_bounds_.shrink_to_fit();
    grid_state_.assign(grid_count, 0);
    grid_state_.shrink_to_fit();
    centre_state_.clear();
    dropChunks();
}

void DiamondSpace::dropChunks() {
    for (Chunks& c : chunks_)
        c = Chunks{};
}

void DiamondSpace::clearStates() {
    std::fill(grid_state_.begin(), grid_state_.end(), std::uint8_t{0});
    std::fill(centre_state_.begin(), centre_state_.end(), std::uint8_t{0});
    for (Chunks& c : chunks_)
        std::fill(c.state.begin(), c.state.end(), std::uint8_t{0});
}

void DiamondSpace::resizeCentres(std::size_t records) {
    // ids are uint32: eager ones below 2^31 (kNoDiamond reserved)
    TERRAIN_ASSERT(grid_count_ + records < kPooledIds);
    // records come a few at a time with ops: an eighth of them to spare, not a doubling
    if (records > centre_state_.capacity())
        centre_state_.reserve(records + records / 8);
    centre_state_.resize(records, 0);
}

void DiamondSpace::resizeChunks(int g, std::size_t chunks) {
    const std::size_t diamonds = chunks * static_cast<std::size_t>(kGrainDiamonds[gi(g)]);
    // each grain's ids fit its range of diamond_id.h
    TERRAIN_ASSERT(diamonds < kRangeBase[1] || (g == 2 && diamonds < (1u << 30)));
    grow(chunks_[gi(g)].bounds, diamonds);
    grow(chunks_[gi(g)].state, diamonds);
}

void DiamondSpace::fitChunks(int g, std::size_t chunks) {
    const std::size_t diamonds = chunks * static_cast<std::size_t>(kGrainDiamonds[gi(g)]);
    fit(chunks_[gi(g)].bounds, diamonds);
    fit(chunks_[gi(g)].state, diamonds);
}

void DiamondSpace::clearChunk(int g, std::int32_t chunk) {
    const auto size = static_cast<std::size_t>(kGrainDiamonds[gi(g)]);
    std::fill_n(
        chunks_[gi(g)].state.begin() + static_cast<std::ptrdiff_t>(gi(chunk) * size), size,
        std::uint8_t{0});
}

bool DiamondSpace::chunkReferenced(int g, std::int32_t chunk) const {
    const auto size = static_cast<std::size_t>(kGrainDiamonds[gi(g)]);
    const auto first = chunks_[gi(g)].state.begin() + static_cast<std::ptrdiff_t>(gi(chunk) * size);
    return std::any_of(
        first, first + static_cast<std::ptrdiff_t>(size), [](std::uint8_t s) { return s != 0; });
}

void DiamondSpace::moveChunk(int g, std::int32_t from, std::int32_t to) {
    const auto size = static_cast<std::size_t>(kGrainDiamonds[gi(g)]);
    const auto copy = [&](auto& v) {
        std::copy_n(
            v.begin() + static_cast<std::ptrdiff_t>(gi(from) * size), size,
            v.begin() + static_cast<std::ptrdiff_t>(gi(to) * size));
    };
    copy(chunks_[gi(g)].bounds);
    copy(chunks_[gi(g)].state);
    clearChunk(g, from);
}

DiamondSpace::Memory DiamondSpace::memory() const {
    Memory m;
    m.grid = grid_bounds_.capacity() * sizeof(PackedBounds) + grid_state_.capacity() +
             centre_state_.capacity();
    for (std::size_t g = 0; g < kGrains; ++g)
        m.chunks[g] =
            chunks_[g].bounds.capacity() * sizeof(PackedBounds) + chunks_[g].state.capacity();
    return m;
}

} // namespace terrain::roam
