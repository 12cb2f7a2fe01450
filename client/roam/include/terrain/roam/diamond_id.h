#pragma once

// Diamond ids: the one number by which the tessellator's parts (its state and bounds arrays,
// the candidate heap, the block pool) name a diamond. Dense ranges, so that each part keeps a
// plain array per range:
// - below kPooledIds, the eager ids: the grid's diamonds (one per grid vertex), then one centre
//   per detail record;
// - from kPooledIds + kRangeBase[r], the diamonds of the resident chunks of grain r of the detail
//   blocks (kGrainDiamonds[r] a chunk, block_grains.h), slot by slot.
// Pure: constants and arithmetic.

#include <array>
#include <cstddef>
#include <cstdint>

namespace terrain::roam {

using DiamondId = std::uint32_t;
inline constexpr DiamondId kNoDiamond = 0xffffffffu;

inline constexpr DiamondId kPooledIds = 1u << 31;
inline constexpr int kPooledRanges = 3;
/// Offset of each pooled range from kPooledIds: 2^29 ids each for the first two, the rest for
/// the finest grain.
inline constexpr std::array<std::uint32_t, kPooledRanges> kRangeBase = {0, 1u << 29, 1u << 30};

constexpr bool isPooled(DiamondId id) {
    return id >= kPooledIds && id != kNoDiamond;
}

/// The pooled range of a pooled id.
constexpr int rangeOf(DiamondId id) {
    const std::uint32_t r = (id - kPooledIds) >> 29;
    return r >= 2 ? 2 : static_cast<int>(r);
}

/// Index of a pooled id in its range's arrays.
constexpr std::size_t pooledSlot(DiamondId id, int range) {
    return id - kPooledIds - kRangeBase[static_cast<std::size_t>(range)];
}

/// The pooled id of `slot` in range `range`.
constexpr DiamondId pooledIdAt(int range, std::size_t slot) {
    return kPooledIds + kRangeBase[static_cast<std::size_t>(range)] + static_cast<DiamondId>(slot);
}

} // namespace terrain::roam
