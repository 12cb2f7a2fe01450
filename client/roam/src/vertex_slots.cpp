#include <terrain/roam/vertex_slots.h>

#include <algorithm>

namespace terrain::roam {

void VertexSlots::set(std::uint32_t vertex, std::uint32_t slot) {
    const std::uint32_t page = vertex / kPage;
    if (page >= page_of_.size())
        page_of_.resize(page + 1, kNone);
    if (page_of_[page] == kNone) {
        if (free_pages_.empty()) {
            page_of_[page] = static_cast<std::uint32_t>(held_.size());
            held_.push_back(0);
            entries_.resize(entries_.size() + kPage, kNone);
        } else {
            page_of_[page] = free_pages_.back();
            free_pages_.pop_back();
        }
    }
    const std::uint32_t at = page_of_[page];
    std::uint32_t& entry = entries_[std::size_t{at} * kPage + vertex % kPage];
    if (entry == kNone && slot != kNone)
        ++held_[at];
    else if (entry != kNone && slot == kNone)
        --held_[at];
    entry = slot;
    if (held_[at] == 0) {
        // the page's last vertex gave its slot back: the page serves another
        page_of_[page] = kNone;
        free_pages_.push_back(at);
    }
}

std::uint32_t VertexSlots::take(std::uint32_t vertex) {
    std::uint32_t slot = 0;
    if (!free_.empty()) {
        slot = free_.back();
        free_.pop_back();
    } else {
        slot = static_cast<std::uint32_t>(vertex_of_.size());
        vertex_of_.push_back(kNone);
    }
    vertex_of_[slot] = vertex;
    set(vertex, slot);
    return slot;
}

void VertexSlots::release(std::uint32_t vertex) {
    const std::uint32_t slot = slotOf(vertex);
    if (slot == kNone)
        return;
    vertex_of_[slot] = kNone;
    free_.push_back(slot);
    set(vertex, kNone);
}

void VertexSlots::clear() {
    std::fill(page_of_.begin(), page_of_.end(), kNone);
    entries_.clear();
    held_.clear();
    free_pages_.clear();
    vertex_of_.clear();
    free_.clear();
}

bool VertexSlots::hasSlack() const {
    const std::size_t pages = held_.size() - free_pages_.size();
    const std::size_t used = slotCount() - freeCount();
    return entries_.capacity() > 2 * pages * kPage + 1024 ||
           vertex_of_.capacity() > 2 * used + 1024;
}

void VertexSlots::shrink() {
    if (free_pages_.empty()) {
        entries_.shrink_to_fit();
        held_.shrink_to_fit();
    }
    if (free_.empty())
        vertex_of_.shrink_to_fit();
    std::vector<std::uint32_t>(free_).swap(free_);
    std::vector<std::uint32_t>(free_pages_).swap(free_pages_);
}

std::size_t VertexSlots::memoryBytes() const {
    return (page_of_.capacity() + entries_.capacity() + free_pages_.capacity() +
            vertex_of_.capacity() + free_.capacity()) *
               sizeof(std::uint32_t) +
           held_.capacity() * sizeof(std::uint16_t);
}

} // namespace terrain::roam
