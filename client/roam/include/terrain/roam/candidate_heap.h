#pragma once

// The split/merge candidates waiting to be re-examined, ordered by the eye travel (metres) at
// which each is due: an indexed binary min-heap over diamond ids, so that a candidate can be
// re-keyed or taken out in O(log n) when a split, a merge or an op touches it. Entries are
// also open to sweeps by position (the tessellator's culling sweep, threshold moves). Ids are
// diamond ids (diamond_id.h): a position array per dense range.
// Pure: no GL, no clocks. Single-threaded.

#include <terrain/roam/diamond_id.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace terrain::roam {

class CandidateHeap {
  public:
    /// 8 bytes: the key is a float rounded down (storedKey), so that a candidate is never due
    /// later than asked, only up to one float step earlier (about 8 mm after 100 km of travel).
    struct Entry {
        float key = 0.0f;
        std::uint32_t id = 0;
    };
    /// The key an entry pushed with `key` holds: the largest float not above it.
    static float storedKey(double key) {
        auto f = static_cast<float>(key);
        if (static_cast<double>(f) > key)
            f = std::nextafter(f, -std::numeric_limits<float>::infinity());
        return f;
    }

    // the id layout, as the heap's users name it (diamond_id.h)
    static constexpr DiamondId kPooledIds = roam::kPooledIds;
    static constexpr int kPooledRanges = roam::kPooledRanges;
    static constexpr std::array<std::uint32_t, kPooledRanges> kRangeBase = roam::kRangeBase;

    /// Ids below `eager`, and in each pooled range r below kPooledIds + kRangeBase[r] +
    /// pooled[r], may be held; new ones start outside the heap. A pooled range may shrink: the
    /// ids cut off must not be held.
    void resizeIds(std::size_t eager, const std::array<std::size_t, kPooledRanges>& pooled);
    bool contains(std::uint32_t id) const { return position(id) >= 0; }
    /// Inserts `id`, or moves it to `key` (as storedKey) if it is held already.
    void push(std::uint32_t id, double key);
    /// Gives held `from`'s entry to `to` (not held), in place.
    void rename(std::uint32_t from, std::uint32_t to) {
        const std::int32_t at = position(from);
        position(from) = -1;
        position(to) = at;
        heap_[static_cast<std::size_t>(at)].id = to;
    }
    /// Takes `id` out; it must be held.
    void remove(std::uint32_t id);
    /// Takes every entry out (ids stay valid).
    void clear();
    /// Takes every entry out and forgets every id.
    void reset();

    bool empty() const { return heap_.empty(); }
    std::size_t size() const { return heap_.size(); }
    const Entry& top() const { return heap_.front(); }
    /// The entry at position i (0 <= i < size()), in heap order.
    const Entry& at(std::size_t i) const { return heap_[i]; }
    std::size_t memoryBytes() const {
        std::size_t bytes =
            heap_.capacity() * sizeof(Entry) + position_.capacity() * sizeof(std::int32_t);
        for (const auto& p : pooled_position_)
            bytes += p.capacity() * sizeof(std::int32_t);
        return bytes;
    }

  private:
    void siftUp(std::size_t i);
    void siftDown(std::size_t i);
    std::int32_t& position(std::uint32_t id) {
        if (id < kPooledIds)
            return position_[id];
        const int r = rangeOf(id);
        return pooled_position_[static_cast<std::size_t>(r)][pooledSlot(id, r)];
    }
    std::int32_t position(std::uint32_t id) const {
        return const_cast<CandidateHeap*>(this)->position(id);
    }

    std::vector<Entry> heap_;
    std::vector<std::int32_t> position_; ///< per eager id: index in heap_, or -1
    std::array<std::vector<std::int32_t>, kPooledRanges> pooled_position_; ///< per pooled id
};

} // namespace terrain::roam
