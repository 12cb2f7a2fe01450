#include <terrain/roam/candidate_heap.h>

#include <algorithm>

namespace terrain::roam {

void CandidateHeap::resizeIds(
    std::size_t eager, const std::array<std::size_t, kPooledRanges>& pooled) {
    if (eager > position_.capacity()) // an eighth to spare: the eager range is large
        position_.reserve(eager + eager / 8);
    position_.resize(eager, -1);
    for (std::size_t r = 0; r < pooled.size(); ++r) {
        auto& p = pooled_position_[r];
        if (pooled[r] > p.capacity()) // grow by an eighth: pools are large
            p.reserve(pooled[r] + p.size() / 8);
        const bool shrinking = pooled[r] < p.size();
        p.resize(pooled[r], -1);
        if (shrinking && p.capacity() > p.size() + p.size() / 4)
            p.shrink_to_fit();
    }
}

void CandidateHeap::siftUp(std::size_t i) {
    const Entry e = heap_[i];
    while (i > 0) {
        const std::size_t parent = (i - 1) / 2;
        if (heap_[parent].key <= e.key)
            break;
        heap_[i] = heap_[parent];
        position(heap_[i].id) = static_cast<std::int32_t>(i);
        i = parent;
    }
    heap_[i] = e;
    position(e.id) = static_cast<std::int32_t>(i);
}

void CandidateHeap::siftDown(std::size_t i) {
    const Entry e = heap_[i];
    const std::size_t n = heap_.size();
    while (true) {
        std::size_t child = 2 * i + 1;
        if (child >= n)
            break;
        if (child + 1 < n && heap_[child + 1].key < heap_[child].key)
            ++child;
        if (e.key <= heap_[child].key)
            break;
        heap_[i] = heap_[child];
        position(heap_[i].id) = static_cast<std::int32_t>(i);
        i = child;
    }
    heap_[i] = e;
    position(e.id) = static_cast<std::int32_t>(i);
}

void CandidateHeap::push(std::uint32_t id, double exact_key) {
    const float key = storedKey(exact_key);
    if (position(id) >= 0) {
        const auto i = static_cast<std::size_t>(position(id));
        heap_[i].key = key;
        siftUp(i);
        siftDown(static_cast<std::size_t>(position(id)));
        return;
    }
    heap_.push_back({key, id});
    siftUp(heap_.size() - 1);
}

void CandidateHeap::remove(std::uint32_t id) {
    const auto i = static_cast<std::size_t>(position(id));
    position(id) = -1;
    const Entry last = heap_.back();
    heap_.pop_back();
    if (i == heap_.size())
        return;
    heap_[i] = last;
    position(last.id) = static_cast<std::int32_t>(i);
    siftUp(i);
    siftDown(static_cast<std::size_t>(position(last.id)));
}

void CandidateHeap::clear() {
    for (const Entry& e : heap_)
        position(e.id) = -1;
    heap_.clear();
}

void CandidateHeap::reset() {
    heap_.clear();
    position_.clear();
    for (auto& p : pooled_position_)
        p.clear();
}

} // namespace terrain::roam
