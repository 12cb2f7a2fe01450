#pragma once

// The split/merge candidates waiting to be re-examined, ordered by the eye travel (metres) at
// which each is due: an indexed binary min-heap over diamond ids, so that a candidate can be
// re-keyed or taken out in O(log n) when a split, a merge or an op touches it. Entries are
// also open to sweeps by position (the tessellator's culling sweep, threshold moves). Ids come in
// two dense ranges: below kPooledIds (eager diamonds) and from it (diamonds of pooled blocks).
// Pure: no GL, no clocks. Single-threaded.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrain::roam {

class CandidateHeap {
  public:
    struct Entry {
        double key = 0.0;
        std::uint32_t id = 0;
    };

    static constexpr std::uint32_t kPooledIds = 1u << 31;

    /// Ids below `eager`, and from kPooledIds below kPooledIds + `pooled`, may be held; new ones
    /// start outside the heap.
    void resizeIds(std::size_t eager, std::size_t pooled);
    bool contains(std::uint32_t id) const { return position(id) >= 0; }
    /// Inserts `id`, or moves it to `key` if it is held already.
    void push(std::uint32_t id, double key);
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
        return heap_.capacity() * sizeof(Entry) +
               (position_.capacity() + pooled_position_.capacity()) * sizeof(std::int32_t);
    }

  private:
    void siftUp(std::size_t i);
    void siftDown(std::size_t i);
    std::int32_t& position(std::uint32_t id) {
        return id < kPooledIds ? position_[id] : pooled_position_[id - kPooledIds];
    }
    std::int32_t position(std::uint32_t id) const {
        return id < kPooledIds ? position_[id] : pooled_position_[id - kPooledIds];
    }

    std::vector<Entry> heap_;
    std::vector<std::int32_t> position_;        ///< per eager id: index in heap_, or -1
    std::vector<std::int32_t> pooled_position_; ///< per pooled id
};

} // namespace terrain::roam
